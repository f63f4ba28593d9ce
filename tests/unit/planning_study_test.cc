// The planning study: its medians against the planners run by hand, thread-independence, the ratio and
// gain-share arithmetic, option checks, progress and failures of a run.
#include <atomic>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "robocal/core/accuracy.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/identification.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/planning.h"
#include "robocal/core/planning_study.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"
#include "robocal/core/virtual_cell.h"

namespace robocal {
namespace {

using ::testing::ContainsRegex;
using ::testing::HasSubstr;
using ::testing::Not;

// Two robots x two types, so that rows map to the right robot and type.
PlanningStudyOptions SmallStudy() {
  PlanningStudyOptions o;
  o.robots = {"grinder5", "ur5e"};
  o.measurement_types = {MeasurementType::kPosition, MeasurementType::kPose};
  o.num_configurations = 10;
  o.seeds = 4;
  o.first_seed = 11;
  o.budgets = {10, 60};
  o.num_validation = 15;
  o.exchange_candidates = 60;
  return o;
}

std::string Fixed2(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f", value);
  return text;
}

TEST(PlanningStudy, MediansAreThoseOfThePlannersRunByHand) {
  const PlanningStudyOptions o = SmallStudy();
  const PlanningStudyResult result = RunPlanningStudy(o);
  ASSERT_EQ(result.rows.size(), 4u);
  const std::string text = FormatPlanningStudy(result);
  for (size_t r = 0; r < result.rows.size(); ++r) {
    const PlanningStudyRow& row = result.rows[r];
    const std::string& robot = o.robots[r / 2];
    const MeasurementType type = o.measurement_types[r % 2];
    SCOPED_TRACE(robot + " " + ToString(type));
    EXPECT_EQ(row.robot, robot);
    EXPECT_EQ(row.measurement_type, type);
    const RobotModel model = Preset(robot);
    ObservabilityOptions obs;
    obs.measurement_type = type;
    obs.parameters = FindIdentifiableParameters(model, type).identifiable;
    EXPECT_EQ(row.num_parameters, static_cast<int>(obs.parameters.size()));
    Rng validation_rng(o.first_seed + kPlanningStudyValidationSeedOffset);
    const auto validation = RandomConfigurations(model, o.num_validation, &validation_rng);
    auto rms = [&](const std::vector<Eigen::VectorXd>& plan) {
      const PredictedAccuracy p = PredictAccuracy(model, obs, plan, validation);
      return p.num_validation > 0 ? p.rms_position_mm : std::nan("");
    };
    std::vector<double> start, start_rms, exchange, exchange_rms;
    std::vector<std::vector<double>> cond(o.budgets.size()), cond_rms(o.budgets.size());
    for (int s = 0; s < o.seeds; ++s) {
      const std::uint64_t seed = o.first_seed + s;
      // The study's premise: every budget of a seed starts from the same random set, this one.
      Rng start_rng(seed);
      const auto start_set = RandomConfigurations(model, o.num_configurations, &start_rng);
      ObservabilityEvaluator evaluator(model, obs);
      evaluator.SetConfigurations(start_set);
      start_rms.push_back(rms(start_set));
      for (size_t b = 0; b < o.budgets.size(); ++b) {
        SolisWetsOptions sw = SolisWetsOptions::Paper();
        sw.k_max = o.budgets[b];
        sw.seed = seed;
        const Plan plan = PlanSolisWets(model, o.num_configurations, obs, sw);
        EXPECT_NEAR(plan.summary.initial.condition_number, evaluator.indices().condition_number,
                    1e-9 * evaluator.indices().condition_number);
        if (b == 0) start.push_back(plan.summary.initial.condition_number);
        cond[b].push_back(plan.summary.final.condition_number);
        cond_rms[b].push_back(rms(plan.configurations));
      }
      ExchangeOptions ex;
      ex.objective = ObservabilityIndex::kLogDet;
      ex.num_candidates = o.exchange_candidates;
      ex.seed = seed;
      const Plan plan = PlanExchange(model, o.num_configurations, obs, ex);
      exchange.push_back(plan.summary.final.condition_number);
      exchange_rms.push_back(rms(plan.configurations));
    }
    EXPECT_DOUBLE_EQ(row.start_condition_number, Median(start));
    EXPECT_DOUBLE_EQ(row.start_rms_position_mm, Median(start_rms));
    ASSERT_EQ(row.condition_number.size(), o.budgets.size());
    for (size_t b = 0; b < o.budgets.size(); ++b) {
      EXPECT_DOUBLE_EQ(row.condition_number[b], Median(cond[b]));
      EXPECT_DOUBLE_EQ(row.rms_position_mm[b], Median(cond_rms[b]));
    }
    EXPECT_DOUBLE_EQ(row.exchange_condition_number, Median(exchange));
    EXPECT_DOUBLE_EQ(row.exchange_rms_position_mm, Median(exchange_rms));
    // What the study is for: optimised plans are better conditioned than their random starts.
    EXPECT_LT(row.condition_number.back(), row.start_condition_number);
    // The table prints this row's figures in order: L, start, budgets, exchange, ratio.
    EXPECT_THAT(text, ContainsRegex(robot + " +" + ToString(type) + " +" + std::to_string(row.num_parameters) + " +" +
                                    Fixed2(row.start_condition_number) + " +" + Fixed2(row.condition_number[0]) + " +" +
                                    Fixed2(row.condition_number[1]) + " +" + Fixed2(row.exchange_condition_number) +
                                    " +" + Fixed2(row.Ratio(0)) + "x"));
  }
  EXPECT_THAT(text, HasSubstr("M = 10, medians over 4 seeds (from 11), rows / noise (0.015 mm, 0.0001 rad); "
                              "columns: column_norm; paper preset with k_max 10 60"));
  EXPECT_THAT(text, HasSubstr("Predicted RMS position error"));
}

TEST(PlanningStudy, ThreadsDoNotChangeTheResult) {
  PlanningStudyOptions o = SmallStudy();
  o.threads = 1;
  const PlanningStudyResult one = RunPlanningStudy(o);
  o.threads = 3;
  const PlanningStudyResult three = RunPlanningStudy(o);
  ASSERT_EQ(one.rows.size(), three.rows.size());
  for (size_t r = 0; r < one.rows.size(); ++r) {
    const PlanningStudyRow &a = one.rows[r], &b = three.rows[r];
    EXPECT_EQ(a.robot, b.robot);
    EXPECT_EQ(a.measurement_type, b.measurement_type);
    EXPECT_EQ(a.start_condition_number, b.start_condition_number);
    EXPECT_EQ(a.condition_number, b.condition_number);
    EXPECT_EQ(a.exchange_condition_number, b.exchange_condition_number);
    EXPECT_EQ(a.start_rms_position_mm, b.start_rms_position_mm);
    EXPECT_EQ(a.rms_position_mm, b.rms_position_mm);
    EXPECT_EQ(a.exchange_rms_position_mm, b.exchange_rms_position_mm);
    EXPECT_EQ(a.start_simulated_rms_error_mm, b.start_simulated_rms_error_mm);
    ASSERT_EQ(a.objectives.size(), b.objectives.size());
    for (size_t k = 0; k < a.objectives.size(); ++k) {
      EXPECT_EQ(a.objectives[k].predicted_rms_error_mm, b.objectives[k].predicted_rms_error_mm);
      EXPECT_EQ(a.objectives[k].simulated_rms_error_mm, b.objectives[k].simulated_rms_error_mm);
    }
  }
  EXPECT_EQ(FormatPlanningStudy(one), FormatPlanningStudy(three));
}

TEST(PlanningStudy, RatioAndGainShareByHand) {
  PlanningStudyRow row;
  row.start_condition_number = 16.0;
  row.condition_number = {8.0, 4.0, 2.0};
  EXPECT_DOUBLE_EQ(row.Ratio(0), 2.0);
  EXPECT_DOUBLE_EQ(row.Ratio(2), 8.0);
  // ln 2 / ln 8 = 1/3; ln 4 / ln 8 = 2/3.
  EXPECT_NEAR(row.GainShare(0), 1.0 / 3.0, 1e-15);
  EXPECT_NEAR(row.GainShare(1), 2.0 / 3.0, 1e-15);
  EXPECT_DOUBLE_EQ(row.GainShare(2), 1.0);
  row.condition_number = {16.0, 16.0};  // the longest run gained nothing: no share to speak of
  EXPECT_TRUE(std::isnan(row.GainShare(0)));
}

TEST(PlanningStudy, ProgressCountsEveryRunOneCallAtATime) {
  PlanningStudyOptions o = SmallStudy();
  o.exchange = false;
  o.threads = 3;
  std::vector<int> done_sequence;
  std::atomic<bool> inside{false};
  std::atomic<int> overlaps{0};
  int last_total = 0;
  o.progress = [&](int done, int total) {
    if (inside.exchange(true)) ++overlaps;
    done_sequence.push_back(done);
    last_total = total;
    inside = false;
  };
  RunPlanningStudy(o);
  EXPECT_EQ(overlaps, 0);
  std::vector<int> expected(16);
  for (int i = 0; i < 16; ++i) expected[i] = i + 1;
  EXPECT_EQ(done_sequence, expected);
  EXPECT_EQ(last_total, 16);
}

TEST(PlanningStudy, AFailingRunStopsTheStudyAndIsRethrown) {
  PlanningStudyOptions o = SmallStudy();
  o.exchange = false;
  o.threads = 2;
  std::atomic<int> calls{0};
  o.progress = [&](int, int) {
    if (++calls == 3) throw std::runtime_error("stop at the third run");
  };
  try {
    RunPlanningStudy(o);
    ADD_FAILURE() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "stop at the third run");
  }
  EXPECT_LT(calls, 16);  // the remaining runs were not handed out
}

TEST(PlanningStudy, TooFewConfigurationsForTheParametersAreRefused) {
  PlanningStudyOptions o = SmallStudy();
  o.robots = {"ur5e"};
  o.measurement_types = {MeasurementType::kPose};
  o.num_configurations = 4;  // 24 rows for 30 parameters
  o.exchange_candidates = 60;
  try {
    RunPlanningStudy(o);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("num_configurations: 4 pose measurements give 24 rows for the 30 identifiable "
                                    "parameters of ur5e"));
  }
}

TEST(PlanningStudy, BadOptionsAreNamed) {
  struct Bad {
    std::function<void(PlanningStudyOptions*)> change;
    const char* message;
  };
  const std::vector<Bad> bad = {
      {[](PlanningStudyOptions* o) { o->robots = {"grinder5", "kuka"}; },
       "robots[1]: unknown robot 'kuka' (known: grinder5, puma560, ur5e)"},
      {[](PlanningStudyOptions* o) { o->robots = {"ur5e", "ur5e"}; }, "robots[1]: 'ur5e' is listed twice"},
      {[](PlanningStudyOptions* o) { o->robots.clear(); }, "robots: at least one"},
      {[](PlanningStudyOptions* o) { o->measurement_types.clear(); }, "measurement_types: at least one"},
      {[](PlanningStudyOptions* o) { o->measurement_types = {MeasurementType::kPose, MeasurementType::kPose}; },
       "measurement_types[1]: 'pose' is listed twice"},
      {[](PlanningStudyOptions* o) { o->seeds = 0; }, "seeds must be in [1, 100000]"},
      {[](PlanningStudyOptions* o) { o->num_configurations = 0; }, "num_configurations must be in [1, 1000]"},
      {[](PlanningStudyOptions* o) { o->budgets = {100, 100}; }, "budgets[1]: budgets must be strictly ascending"},
      {[](PlanningStudyOptions* o) { o->budgets = {0}; }, "budgets[0]: k_max must be in"},
      {[](PlanningStudyOptions* o) { o->budgets.clear(); }, "budgets: at least one"},
      {[](PlanningStudyOptions* o) { o->noise.orientation_rad = 0.0; }, "noise: position_mm and orientation_rad"},
      {[](PlanningStudyOptions* o) { o->expected_translation_mm = -1.0; }, "expected_translation_mm and"},
      {[](PlanningStudyOptions* o) { o->num_validation = 0; }, "num_validation must be in"},
      {[](PlanningStudyOptions* o) { o->exchange_candidates = 5; },
       "exchange_candidates: 5 must be in [num_configurations (10), 1000000]"},
      {[](PlanningStudyOptions* o) { o->threads = 0; }, "threads must be in [1, 256]"},
      {[](PlanningStudyOptions* o) {
         o->objectives = {ObservabilityIndex::kLogDet, ObservabilityIndex::kO1, ObservabilityIndex::kLogDet};
       },
       "objectives[2]: 'log_det' is listed twice"},
      {[](PlanningStudyOptions* o) { o->objective_validation = 0; }, "objective_validation must be in"},
  };
  for (const Bad& b : bad) {
    PlanningStudyOptions o = SmallStudy();
    b.change(&o);
    std::string error;
    EXPECT_FALSE(o.IsValid(&error)) << b.message;
    EXPECT_THAT(error, HasSubstr(b.message));
    try {
      RunPlanningStudy(o);
      ADD_FAILURE() << "no exception for " << b.message;
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), HasSubstr(b.message));
    }
  }
}

// The objective comparison, recomputed by hand for one case: every objective's plan by the paper preset and by
// exchange, judged by PredictAccuracy and by a calibration in the seed's virtual cell.
TEST(PlanningStudy, ObjectiveComparisonIsThatOfThePlannersRunByHand) {
  PlanningStudyOptions o;
  o.robots = {"grinder5"};
  o.measurement_types = {MeasurementType::kPose};
  o.seeds = 3;
  o.first_seed = 5;
  o.budgets = {15, 30};
  o.num_validation = 12;
  o.exchange_candidates = 60;
  o.objective_validation = 9;
  const PlanningStudyResult result = RunPlanningStudy(o);
  ASSERT_EQ(result.rows.size(), 1u);
  const PlanningStudyRow& row = result.rows.front();
  ASSERT_EQ(row.objectives.size(), 6u);

  const RobotModel model = Preset("grinder5");
  ObservabilityOptions obs;
  obs.measurement_type = MeasurementType::kPose;
  obs.parameters = FindIdentifiableParameters(model, obs.measurement_type).identifiable;
  Rng validation_rng(o.first_seed + kPlanningStudyValidationSeedOffset);
  const auto validation = RandomConfigurations(model, o.num_validation, &validation_rng);
  // The simulated error by hand: one shot per pose in the seed's cell, identified, compared with the truth.
  auto simulated = [&](std::uint64_t seed, const std::vector<Eigen::VectorXd>& plan) {
    VirtualCellOptions cell_options;
    cell_options.seed = seed + kPlanningStudySimulationSeedOffset;
    cell_options.shots_per_pose = 1;
    VirtualCell cell(model, cell_options);
    IdentificationOptions id;
    id.measurement_type = obs.measurement_type;
    id.parameters = obs.parameters;
    const Calibration cal = Identify(model, cell.MeasureAll(plan), id);
    EXPECT_NE(cal.summary.termination, Termination::kFailure);
    KinematicsWorkspace ws(cal.model);
    double sum = 0.0;
    for (const Eigen::VectorXd& q : validation) {
      const Transform predicted = ForwardKinematics(cal.model, q, cal.errors, &ws);
      const Transform truth = cell.TruePose(q);
      const double angle = Eigen::AngleAxisd(truth.linear().transpose() * predicted.linear()).angle();
      sum += (predicted.translation() - truth.translation()).squaredNorm() + 30.0 * 30.0 * angle * angle;
    }
    return std::sqrt(sum / validation.size());
  };
  std::vector<double> start_predicted, start_simulated;
  std::vector<std::vector<double>> predicted(6), simulation(6), cond(6);
  for (int s = 0; s < o.seeds; ++s) {
    const std::uint64_t seed = o.first_seed + s;
    Rng start_rng(seed);
    const auto start = RandomConfigurations(model, o.num_configurations, &start_rng);
    start_predicted.push_back(PredictAccuracy(model, obs, start, validation).rms_error_mm);
    start_simulated.push_back(simulated(seed, start));
    for (size_t k = 0; k < 6; ++k) {
      const ObservabilityIndex objective = o.objectives[k % 3];
      Plan plan;
      if (k < 3) {
        SolisWetsOptions sw = SolisWetsOptions::Paper();
        sw.k_max = o.budgets.front();
        sw.seed = seed;
        sw.objective = objective;
        sw.num_validation = o.objective_validation;
        plan = PlanSolisWets(model, o.num_configurations, obs, sw);
      } else {
        ExchangeOptions ex;
        ex.num_candidates = o.exchange_candidates;
        ex.seed = seed;
        ex.objective = objective;
        ex.num_validation = o.objective_validation;
        plan = PlanExchange(model, o.num_configurations, obs, ex);
      }
      cond[k].push_back(plan.summary.final.condition_number);
      predicted[k].push_back(PredictAccuracy(model, obs, plan.configurations, validation).rms_error_mm);
      simulation[k].push_back(simulated(seed, plan.configurations));
    }
  }
  EXPECT_DOUBLE_EQ(row.start_predicted_rms_error_mm, Median(start_predicted));
  EXPECT_DOUBLE_EQ(row.start_simulated_rms_error_mm, Median(start_simulated));
  for (size_t k = 0; k < 6; ++k) {
    const ObjectivePlanResult& plan = row.objectives[k];
    SCOPED_TRACE(plan.method + " " + ToString(plan.objective));
    EXPECT_EQ(plan.objective, o.objectives[k % 3]);
    EXPECT_EQ(plan.method, k < 3 ? "solis_wets" : "exchange");
    EXPECT_DOUBLE_EQ(plan.condition_number, Median(cond[k]));
    EXPECT_DOUBLE_EQ(plan.predicted_rms_error_mm, Median(predicted[k]));
    EXPECT_DOUBLE_EQ(plan.simulated_rms_error_mm, Median(simulation[k]));
    // Calibrating from any of these plans leaves errors of the order predicted (tens of um), far below the
    // robot's uncalibrated millimetres.
    EXPECT_LT(plan.simulated_rms_error_mm, 3.0 * plan.predicted_rms_error_mm);
  }
  // The paper preset with the condition number is the first budget's plan of the first table.
  EXPECT_DOUBLE_EQ(row.objectives[0].condition_number, row.condition_number[0]);
  const std::string text = FormatPlanningStudy(result);
  EXPECT_THAT(text, HasSubstr("Objectives compared"));
  EXPECT_THAT(text, HasSubstr("sw predicted_error"));
  EXPECT_THAT(text, HasSubstr("ex log_det"));

  // Without simulation the comparison is predicted only; with no objectives there is none.
  o.simulate = false;
  const PlanningStudyResult predicted_only = RunPlanningStudy(o);
  EXPECT_TRUE(std::isnan(predicted_only.rows.front().objectives.front().simulated_rms_error_mm));
  EXPECT_DOUBLE_EQ(predicted_only.rows.front().objectives.front().predicted_rms_error_mm,
                   row.objectives.front().predicted_rms_error_mm);
  o.objectives.clear();
  const PlanningStudyResult none = RunPlanningStudy(o);
  EXPECT_TRUE(none.rows.front().objectives.empty());
  EXPECT_THAT(FormatPlanningStudy(none), Not(HasSubstr("Objectives compared")));
}

}  // namespace
}  // namespace robocal
