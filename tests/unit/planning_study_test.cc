// The planning study: its medians against the planners run by hand, thread-independence, the ratio and
// headroom arithmetic, option checks, progress.
#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "robocal/core/accuracy.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/planning.h"
#include "robocal/core/planning_study.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"

namespace robocal {
namespace {

using ::testing::HasSubstr;

PlanningStudyOptions SmallStudy() {
  PlanningStudyOptions o;
  o.robots = {"grinder5", "ur5e"};
  o.measurement_types = {MeasurementType::kPose};
  o.num_configurations = 8;
  o.seeds = 4;
  o.first_seed = 11;
  o.budgets = {10, 60};
  o.num_validation = 15;
  o.exchange_candidates = 60;
  return o;
}

TEST(PlanningStudy, MediansAreThoseOfThePlannersRunByHand) {
  const PlanningStudyOptions o = SmallStudy();
  const PlanningStudyResult result = RunPlanningStudy(o);
  ASSERT_EQ(result.rows.size(), 2u);
  for (size_t r = 0; r < result.rows.size(); ++r) {
    const PlanningStudyRow& row = result.rows[r];
    const RobotModel model = Preset(o.robots[r]);
    EXPECT_EQ(row.robot, o.robots[r]);
    ObservabilityOptions obs;
    obs.measurement_type = MeasurementType::kPose;
    obs.parameters = FindIdentifiableParameters(model, obs.measurement_type).identifiable;
    EXPECT_EQ(row.num_parameters, static_cast<int>(obs.parameters.size()));
    Rng validation_rng(o.first_seed + kPlanningStudyValidationSeedOffset);
    const auto validation = RandomConfigurations(model, o.num_validation, &validation_rng);
    auto rms = [&](const std::vector<Eigen::VectorXd>& plan) {
      return PredictAccuracy(model, obs, plan, validation).rms_position_mm;
    };
    std::vector<double> start, start_rms, exchange, exchange_rms;
    std::vector<std::vector<double>> cond(o.budgets.size()), cond_rms(o.budgets.size());
    for (int s = 0; s < o.seeds; ++s) {
      const std::uint64_t seed = o.first_seed + s;
      for (size_t b = 0; b < o.budgets.size(); ++b) {
        SolisWetsOptions sw = SolisWetsOptions::Paper();
        sw.k_max = o.budgets[b];
        sw.seed = seed;
        const Plan plan = PlanSolisWets(model, o.num_configurations, obs, sw);
        if (b == 0) start.push_back(plan.summary.initial.condition_number);
        cond[b].push_back(plan.summary.final.condition_number);
        cond_rms[b].push_back(rms(plan.configurations));
      }
      Rng start_rng(seed);
      start_rms.push_back(rms(RandomConfigurations(model, o.num_configurations, &start_rng)));
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
  }
  const std::string text = FormatPlanningStudy(result);
  EXPECT_THAT(text, HasSubstr("M = 8, medians over 4 seeds (from 11), scaling column_norm"));
  EXPECT_THAT(text, HasSubstr("k=60"));
  EXPECT_THAT(text, HasSubstr("Predicted RMS position error"));
}

TEST(PlanningStudy, ThreadsDoNotChangeTheResult) {
  PlanningStudyOptions o = SmallStudy();
  o.robots = {"grinder5"};
  o.threads = 1;
  const PlanningStudyResult one = RunPlanningStudy(o);
  o.threads = 3;
  const PlanningStudyResult three = RunPlanningStudy(o);
  ASSERT_EQ(one.rows.size(), three.rows.size());
  EXPECT_EQ(one.rows[0].condition_number, three.rows[0].condition_number);
  EXPECT_EQ(one.rows[0].rms_position_mm, three.rows[0].rms_position_mm);
  EXPECT_EQ(one.rows[0].exchange_condition_number, three.rows[0].exchange_condition_number);
}

TEST(PlanningStudy, RatioAndHeadroomByHand) {
  PlanningStudyRow row;
  row.start_condition_number = 16.0;
  row.condition_number = {8.0, 4.0, 2.0};
  EXPECT_DOUBLE_EQ(row.Ratio(0), 2.0);
  EXPECT_DOUBLE_EQ(row.Ratio(2), 8.0);
  // ln 2 / ln 8 = 1/3; ln 4 / ln 8 = 2/3.
  EXPECT_NEAR(row.HeadroomFraction(0), 1.0 / 3.0, 1e-15);
  EXPECT_NEAR(row.HeadroomFraction(1), 2.0 / 3.0, 1e-15);
  EXPECT_DOUBLE_EQ(row.HeadroomFraction(2), 1.0);
  row.condition_number = {16.0, 16.0};  // nothing gained by the longest run: no headroom to share
  EXPECT_TRUE(std::isnan(row.HeadroomFraction(0)));
}

TEST(PlanningStudy, ProgressCountsEveryRun) {
  PlanningStudyOptions o = SmallStudy();
  o.exchange = false;
  o.threads = 2;
  int calls = 0, last_done = 0, last_total = 0;
  o.progress = [&](int done, int total) {
    ++calls;
    last_done = done;
    last_total = total;
  };
  RunPlanningStudy(o);
  EXPECT_EQ(calls, 8);
  EXPECT_EQ(last_done, 8);
  EXPECT_EQ(last_total, 8);
}

TEST(PlanningStudy, BadOptionsAreNamed) {
  struct Bad {
    std::function<void(PlanningStudyOptions*)> change;
    const char* message;
  };
  const std::vector<Bad> bad = {
      {[](PlanningStudyOptions* o) { o->robots = {"grinder5", "kuka"}; }, "robots[1]: unknown robot 'kuka'"},
      {[](PlanningStudyOptions* o) { o->robots.clear(); }, "robots: at least one"},
      {[](PlanningStudyOptions* o) { o->measurement_types.clear(); }, "measurement_types"},
      {[](PlanningStudyOptions* o) { o->seeds = 0; }, "seeds"},
      {[](PlanningStudyOptions* o) { o->num_configurations = 0; }, "num_configurations"},
      {[](PlanningStudyOptions* o) { o->budgets = {100, 100}; }, "budgets[1]: budgets must be strictly ascending"},
      {[](PlanningStudyOptions* o) { o->budgets = {0}; }, "budgets[0]: k_max must be in"},
      {[](PlanningStudyOptions* o) { o->budgets.clear(); }, "budgets: at least one"},
      {[](PlanningStudyOptions* o) { o->num_validation = 0; }, "num_validation"},
      {[](PlanningStudyOptions* o) { o->exchange_candidates = 5; }, "exchange_candidates"},
      {[](PlanningStudyOptions* o) { o->threads = 0; }, "threads"},
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

}  // namespace
}  // namespace robocal
