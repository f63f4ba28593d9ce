// Measurement configuration optimisers: the paper's Solis & Wets preset against random starting sets, longer
// budgets, the exchange optimiser against random selection, limits, reproducibility, options, cancelling.
#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "robocal/core/accuracy.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/planning.h"
#include "robocal/core/presets.h"

namespace robocal {
namespace {

using ::testing::HasSubstr;

constexpr int kSeeds = 20;
constexpr int kM = 10;

ObservabilityOptions OptionsFor(const RobotModel& model, MeasurementType type) {
  ObservabilityOptions o;
  o.measurement_type = type;
  o.parameters = FindIdentifiableParameters(model, type).identifiable;
  return o;
}

void ExpectWithinLimits(const RobotModel& model, const Plan& plan, int m) {
  ASSERT_EQ(static_cast<int>(plan.configurations.size()), m);
  for (const Eigen::VectorXd& q : plan.configurations) EXPECT_TRUE(model.WithinLimits(q)) << q.transpose();
}

using Case = std::tuple<std::string, MeasurementType>;

class PlannerTest : public ::testing::TestWithParam<Case> {};

// Medians over 20 seeds. The paper's preset (k_max = 100) must at least halve the condition number of the
// random starting sets where the problem leaves room for it. It reaches 61-67 % of the best gain found (10^5
// iterations) on every robot; for 6-axis arms in full pose that best is only 2.2-2.5x below random sets, and
// the preset reaches 1.66x and 1.83x there (docs/planning.md, `robocal-plan-study`), so the bar for them is
// 1.5x. A ten times longer budget must improve further in every case.
TEST_P(PlannerTest, PaperPresetImprovesOnRandomStartsAndLongerBudgetsImproveFurther) {
  const auto& [preset, type] = GetParam();
  const RobotModel model = Preset(preset);
  const ObservabilityOptions o = OptionsFor(model, type);
  std::vector<double> start, paper, longer;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    SolisWetsOptions options = SolisWetsOptions::Paper();
    options.seed = seed;
    const Plan plan = PlanSolisWets(model, kM, o, options);
    ExpectWithinLimits(model, plan, kM);
    EXPECT_EQ(plan.summary.termination, Termination::kConvergence) << plan.summary.message;
    EXPECT_EQ(plan.summary.iterations, 100);
    EXPECT_EQ(static_cast<int>(plan.summary.objective_trace.size()), 100);
    EXPECT_TRUE(std::is_sorted(plan.summary.objective_trace.rbegin(), plan.summary.objective_trace.rend()));
    EXPECT_LE(plan.summary.final.condition_number, plan.summary.initial.condition_number);
    start.push_back(plan.summary.initial.condition_number);
    paper.push_back(plan.summary.final.condition_number);
    // Other seeds for the longer runs: with the same seed a longer run repeats the shorter one's first 100
    // iterations and could not end worse, which would make the comparison below hold by construction.
    options.k_max = 1000;
    options.seed = seed + 1000;
    const Plan long_plan = PlanSolisWets(model, kM, o, options);
    ExpectWithinLimits(model, long_plan, kM);
    longer.push_back(long_plan.summary.final.condition_number);
  }
  const bool six_axis_pose = preset != "grinder5" && type == MeasurementType::kPose;
  const double required = six_axis_pose ? 1.5 : 2.0;
  EXPECT_GT(Median(start) / Median(paper), required)
      << "median cond: random start " << Median(start) << ", paper preset " << Median(paper);
  EXPECT_LT(Median(longer), Median(paper)) << "k_max 1000 " << Median(longer) << " vs 100 " << Median(paper);
}

TEST_P(PlannerTest, ExchangeBeatsRandomSelectionOnO1) {
  const auto& [preset, type] = GetParam();
  const RobotModel model = Preset(preset);
  const ObservabilityOptions o = OptionsFor(model, type);
  std::vector<double> random_o1, exchange_o1;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    RandomSelectionOptions r;
    r.seed = seed;
    r.objective = ObservabilityIndex::kO1;
    const Plan random = PlanRandom(model, kM, o, r);
    ExpectWithinLimits(model, random, kM);
    random_o1.push_back(random.summary.final.o1);
    ExchangeOptions e;
    e.seed = seed;
    e.objective = ObservabilityIndex::kO1;
    e.num_candidates = 500;
    const Plan exchange = PlanExchange(model, kM, o, e);
    ExpectWithinLimits(model, exchange, kM);
    EXPECT_EQ(exchange.summary.termination, Termination::kConvergence) << exchange.summary.message;
    EXPECT_GE(exchange.summary.final.o1, exchange.summary.initial.o1);
    exchange_o1.push_back(exchange.summary.final.o1);
  }
  EXPECT_GT(Median(exchange_o1), Median(random_o1));
}

INSTANTIATE_TEST_SUITE_P(PresetsAndTypes, PlannerTest,
                         ::testing::Combine(::testing::Values("grinder5", "puma560", "ur5e"),
                                            ::testing::Values(MeasurementType::kPosition, MeasurementType::kPose)),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           return std::get<0>(info.param) + "_" + ToString(std::get<1>(info.param));
                         });

TEST(SolisWetsOptionsTest, PaperPresetHoldsThePapersConstants) {
  // Wang & Zhang (2007), section 3: k_max = 100, Scent = 5, Fcent = 3, sigma_0 = 1, sigma_ub = 3, sigma_lb = 0.1,
  // ex = 2, ct = 0.5, the condition number as objective, one run.
  const SolisWetsOptions p = SolisWetsOptions::Paper();
  EXPECT_EQ(p.k_max, 100);
  EXPECT_EQ(p.scent_threshold, 5);
  EXPECT_EQ(p.fcent_threshold, 3);
  EXPECT_EQ(p.sigma0, 1.0);
  EXPECT_EQ(p.sigma_ub, 3.0);
  EXPECT_EQ(p.sigma_lb, 0.1);
  EXPECT_EQ(p.expansion, 2.0);
  EXPECT_EQ(p.contraction, 0.5);
  EXPECT_EQ(p.objective, ObservabilityIndex::kConditionNumber);
  EXPECT_EQ(p.restarts, 0);
  EXPECT_EQ(p.max_evaluations, 0);
  // The decisions on what the paper leaves open (docs/planning.md).
  EXPECT_EQ(p.step_fraction, 0.1);
  EXPECT_TRUE(p.reset_counters);
  EXPECT_EQ(p.limits, LimitHandling::kReflect);
  std::string error;
  EXPECT_TRUE(p.IsValid(&error)) << error;
}

TEST(PlanningTest, SameSeedSameResultOtherSeedOtherResult) {
  const RobotModel model = Preset("grinder5");
  const ObservabilityOptions o = OptionsFor(model, MeasurementType::kPose);
  SolisWetsOptions options = SolisWetsOptions::Paper();
  options.seed = 5;
  const Plan a = PlanSolisWets(model, kM, o, options);
  const Plan b = PlanSolisWets(model, kM, o, options);
  ASSERT_EQ(a.configurations.size(), b.configurations.size());
  for (size_t i = 0; i < a.configurations.size(); ++i) EXPECT_EQ(a.configurations[i], b.configurations[i]);
  EXPECT_EQ(a.summary.objective_trace, b.summary.objective_trace);
  options.seed = 6;
  EXPECT_NE(PlanSolisWets(model, kM, o, options).configurations[0], a.configurations[0]);

  ExchangeOptions e;
  e.num_candidates = 300;
  EXPECT_EQ(PlanExchange(model, kM, o, e).configurations, PlanExchange(model, kM, o, e).configurations);
}

TEST(PlanningTest, ClampKeepsLimitsAndRestartsAndBudgetsAreHonoured) {
  const RobotModel model = Preset("puma560");
  const ObservabilityOptions o = OptionsFor(model, MeasurementType::kPosition);
  SolisWetsOptions options = SolisWetsOptions::Paper();
  options.limits = LimitHandling::kClamp;
  options.restarts = 2;
  Plan plan = PlanSolisWets(model, kM, o, options);
  ExpectWithinLimits(model, plan, kM);
  EXPECT_EQ(plan.summary.iterations, 300);
  options.max_evaluations = 50;
  plan = PlanSolisWets(model, kM, o, options);
  EXPECT_EQ(plan.summary.termination, Termination::kNoConvergence);
  EXPECT_LE(plan.summary.evaluations, 50);
  ExpectWithinLimits(model, plan, kM);
}

// A restart whose previous run ended exactly at max_evaluations must not evaluate its starting set.
TEST(PlanningTest, RestartsNeverEvaluatePastTheBudget) {
  const RobotModel model = Preset("grinder5");
  const ObservabilityOptions o = OptionsFor(model, MeasurementType::kPose);
  SolisWetsOptions options = SolisWetsOptions::Paper();
  options.k_max = 10;
  const int one_run = PlanSolisWets(model, kM, o, options).summary.evaluations;
  options.restarts = 3;
  options.max_evaluations = one_run;
  const Plan plan = PlanSolisWets(model, kM, o, options);
  EXPECT_EQ(plan.summary.evaluations, one_run);
  EXPECT_EQ(plan.summary.termination, Termination::kNoConvergence);
  EXPECT_EQ(plan.summary.message, "evaluation budget reached");
  EXPECT_LE(plan.summary.evaluations, MaxPlanWork(kM, options).evaluations);
}

// The exchange optimiser counts each candidate's screening gain: an iteration costs num_candidates +
// min(screen, num_candidates - M) evaluations, and a run cut by max_iterations costs MaxPlanWork exactly.
TEST(PlanningTest, ExchangeCountsScreeningAndReachesItsWorkBoundExactly) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = OptionsFor(model, MeasurementType::kPose);
  ExchangeOptions options;
  options.num_candidates = 300;
  options.max_iterations = 2;
  const Plan cut = PlanExchange(model, kM, o, options);
  ASSERT_EQ(cut.summary.iterations, 2) << cut.summary.message;
  EXPECT_EQ(cut.summary.evaluations, 1 + 2 * (300 + 16));
  EXPECT_EQ(cut.summary.evaluations, MaxPlanWork(kM, options).evaluations);
  EXPECT_EQ(MaxPlanWork(kM, options).jacobians, 300);
  // The result's indices are those of its configurations.
  EXPECT_NEAR(cut.summary.final.condition_number, ComputeIndicesBySvd(model, cut.configurations, o).condition_number,
              1e-8 * cut.summary.final.condition_number);
}

TEST(PlanningTest, ExchangeStopsAtItsEvaluationBudget) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = OptionsFor(model, MeasurementType::kPose);
  ExchangeOptions options;
  options.num_candidates = 300;
  const Plan free = PlanExchange(model, kM, o, options);
  ASSERT_EQ(free.summary.termination, Termination::kConvergence) << free.summary.message;
  ASSERT_GE(free.summary.iterations, 3);
  EXPECT_EQ(free.summary.evaluations, 1 + free.summary.iterations * (300 + 16));
  // Room for two iterations and a half: it stops before the third.
  options.max_evaluations = 1 + 2 * 316 + 158;
  const Plan budgeted = PlanExchange(model, kM, o, options);
  EXPECT_EQ(budgeted.summary.iterations, 2);
  EXPECT_EQ(budgeted.summary.evaluations, 1 + 2 * 316);
  EXPECT_EQ(budgeted.summary.termination, Termination::kNoConvergence);
  EXPECT_THAT(budgeted.summary.message, HasSubstr("evaluation budget reached"));
  ExpectWithinLimits(model, budgeted, kM);
  // The same path as the free run up to the cut.
  EXPECT_EQ(budgeted.summary.objective_trace,
            std::vector<double>(free.summary.objective_trace.begin(), free.summary.objective_trace.begin() + 2));
}

TEST(PlanningTest, EveryOptimiserStaysWithinItsWorkBound) {
  const RobotModel model = Preset("puma560");
  const ObservabilityOptions o = OptionsFor(model, MeasurementType::kPosition);
  SolisWetsOptions solis_wets = SolisWetsOptions::Paper();
  solis_wets.k_max = 30;
  solis_wets.restarts = 2;
  const Plan a = PlanSolisWets(model, kM, o, solis_wets);
  EXPECT_EQ(MaxPlanWork(kM, solis_wets).evaluations, 3 * 61);
  EXPECT_EQ(MaxPlanWork(kM, solis_wets).jacobians, 3 * 61 * kM);
  EXPECT_LE(a.summary.evaluations, MaxPlanWork(kM, solis_wets).evaluations);
  EXPECT_GE(a.summary.evaluations, 3 * 31);  // every run: its starting set and a forward step per iteration
  EXPECT_NEAR(a.summary.final.condition_number, ComputeIndicesBySvd(model, a.configurations, o).condition_number,
              1e-8 * a.summary.final.condition_number);
  solis_wets.max_evaluations = 50;
  EXPECT_EQ(MaxPlanWork(kM, solis_wets).evaluations, 50);
  RandomSelectionOptions random;
  random.num_sets = 7;
  EXPECT_EQ(PlanRandom(model, kM, o, random).summary.evaluations, 7);
  EXPECT_EQ(MaxPlanWork(kM, random).evaluations, 7);
  EXPECT_EQ(MaxPlanWork(kM, random).jacobians, 7 * kM);
  // Bounds of absurd options saturate instead of overflowing.
  solis_wets.k_max = 10000000;
  solis_wets.restarts = 10000;
  solis_wets.max_evaluations = 0;
  EXPECT_EQ(MaxPlanWork(1000000000, solis_wets).jacobians, std::numeric_limits<std::int64_t>::max());
  EXPECT_EQ(MaxPlanWork(kM, solis_wets).evaluations, 10001LL * 20000001LL);
}

TEST(PlanningTest, StartsFromAGivenSetAndValidatesIt) {
  const RobotModel model = Preset("grinder5");
  const ObservabilityOptions o = OptionsFor(model, MeasurementType::kPose);
  Rng rng(3);
  const auto initial = RandomConfigurations(model, kM, &rng);
  const Plan plan = PlanSolisWets(model, kM, o, SolisWetsOptions::Paper(), initial);
  // The planner's indices come from the eigenvalues of the normal matrix, the reference from an SVD of the
  // stacked Jacobian: they agree to round-off, not bit for bit.
  const double reference = ComputeIndicesBySvd(model, initial, o).condition_number;
  EXPECT_NEAR(plan.summary.initial.condition_number, reference, 1e-12 * reference);
  auto outside = initial;
  outside[3][0] = model.upper_limits()[0] + 1.0;
  EXPECT_THROW(PlanSolisWets(model, kM, o, SolisWetsOptions::Paper(), outside), std::invalid_argument);
  EXPECT_THROW(PlanSolisWets(model, kM + 1, o, SolisWetsOptions::Paper(), initial), std::invalid_argument);
}

TEST(PlanningTest, InvalidOptionsAreRejectedByName) {
  const RobotModel model = Preset("grinder5");
  const ObservabilityOptions o = OptionsFor(model, MeasurementType::kPose);
  SolisWetsOptions s = SolisWetsOptions::Paper();
  s.sigma_lb = 5;  // above sigma_ub
  std::string error;
  EXPECT_FALSE(s.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("sigma"));
  try {
    PlanSolisWets(model, kM, o, s);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("SolisWetsOptions"));
  }
  EXPECT_THROW(PlanSolisWets(model, 0, o, SolisWetsOptions::Paper()), std::invalid_argument);
  ExchangeOptions e;
  e.num_candidates = 5;
  EXPECT_THROW(PlanExchange(model, kM, o, e), std::invalid_argument);
  RandomSelectionOptions r;
  r.num_sets = 0;
  EXPECT_THROW(PlanRandom(model, kM, o, r), std::invalid_argument);
}

TEST(PlanningTest, ProgressCallbackCancels) {
  const RobotModel model = Preset("grinder5");
  const ObservabilityOptions o = OptionsFor(model, MeasurementType::kPose);
  SolisWetsOptions options = SolisWetsOptions::Paper();
  double last = 0;
  options.progress = [&](double fraction) {
    last = fraction;
    return fraction < 0.25;
  };
  const Plan plan = PlanSolisWets(model, kM, o, options);
  EXPECT_EQ(plan.summary.termination, Termination::kNoConvergence);
  EXPECT_EQ(plan.summary.message, "cancelled");
  EXPECT_EQ(plan.summary.iterations, 25);
  EXPECT_DOUBLE_EQ(last, 0.25);
  ExpectWithinLimits(model, plan, kM);
}

TEST(PlanningTest, ReportsNameMethodObjectiveAndScaling) {
  const RobotModel model = Preset("grinder5");
  const ObservabilityOptions o = OptionsFor(model, MeasurementType::kPose);
  const Plan plan = PlanSolisWets(model, kM, o, SolisWetsOptions::Paper());
  EXPECT_THAT(plan.summary.BriefReport(), HasSubstr("solis_wets"));
  EXPECT_THAT(plan.summary.BriefReport(), HasSubstr("condition_number"));
  EXPECT_THAT(plan.summary.FullReport(), HasSubstr("column_norm"));
}

}  // namespace
}  // namespace robocal
