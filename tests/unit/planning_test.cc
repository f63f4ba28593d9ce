// Measurement configuration optimisers: the paper's Solis & Wets preset against random starting sets, longer
// budgets, the exchange optimiser against random selection, limits, reproducibility, options, cancelling.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <tuple>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "robocal/core/accuracy.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/planning.h"
#include "robocal/core/presets.h"
#include "test_util.h"

namespace robocal {
namespace {

using ::testing::HasSubstr;

constexpr int kSeeds = 20;
constexpr int kM = 10;

void ExpectWithinLimits(const RobotModel& model, const Plan& plan, int m) {
  ASSERT_EQ(static_cast<int>(plan.configurations.size()), m);
  for (const Eigen::VectorXd& q : plan.configurations) EXPECT_TRUE(model.WithinLimits(q)) << q.transpose();
}

using PlannerCase = std::tuple<std::string, MeasurementType>;

class PlannerTest : public ::testing::TestWithParam<PlannerCase> {};

// Medians over 20 seeds. The paper's preset (k_max = 100) must at least halve the condition number of the
// random starting sets where the problem leaves room for it. It reaches 61-67 % of the best gain found (10^5
// iterations) on every robot; for 6-axis arms in full pose that best is only 2.2-2.5x below random sets, and
// the preset reaches 1.66x and 1.83x there (docs/planning.md, `robocal-plan-study`), so the bar for them is
// 1.5x. A ten times longer budget must improve further in every case.
TEST_P(PlannerTest, PaperPresetImprovesOnRandomStartsAndLongerBudgetsImproveFurther) {
  const auto& [preset, type] = GetParam();
  const RobotModel model = Preset(preset);
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, type);
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
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, type);
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
                         [](const ::testing::TestParamInfo<PlannerCase>& info) {
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
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
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
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPosition);
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
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
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
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
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
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
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
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPosition);
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
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
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
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
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
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
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
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  const Plan plan = PlanSolisWets(model, kM, o, SolisWetsOptions::Paper());
  EXPECT_THAT(plan.summary.BriefReport(), HasSubstr("solis_wets"));
  EXPECT_THAT(plan.summary.BriefReport(), HasSubstr("condition_number"));
  EXPECT_THAT(plan.summary.FullReport(), HasSubstr("column_norm"));
}

// Feasibility: every planner draws from, and returns only, configurations a predicate accepts; an empty
// predicate changes nothing; rejection sampling is bounded.

// Run by the code before predicates existed (ur5e, pose, M = 10, seed 7): an empty predicate must reproduce it.
constexpr double kPinnedSolisWets[2][6] = {{0.26524225928015444, -1.7034847662914245, -0.16024860957340348,
                                            2.0653732059241445, 3.4369600721341005, 0.35848615574811316},
                                           {-1.4625925925839027, 2.6863237497073964, -2.3438024263082804,
                                            -1.0025049414205478, -2.2825550072915703, 5.9614053787328416}};
constexpr double kPinnedRandom[2][6] = {{5.2076850290709089, -5.0208585232311025, -4.5706102843616456,
                                         -2.2261238124197025, -0.60535356563469112, -0.62540229324539087},
                                        {0.26591847120072742, 5.6157580637623816, 1.9631098684038228,
                                         -3.2612161617383633, 3.247699111866277, 0.89769052820258288}};
constexpr double kPinnedExchange[2][6] = {{0.54672106544999632, -4.9543585375564207, 0.1261870655745172,
                                           -1.9482236425971919, -1.0252249856386921, -5.2942427231112088},
                                          {0.00081948969266054661, -6.0593478122617137, -2.8795640224227537,
                                           2.5521054609181348, -0.83026610968335124, 5.0210705912195515}};

SolisWetsOptions PinnedSolisWets() {
  SolisWetsOptions s = SolisWetsOptions::Paper();
  s.seed = 7;
  s.k_max = 40;
  s.restarts = 1;
  return s;
}
RandomSelectionOptions PinnedRandom() {
  RandomSelectionOptions r;
  r.seed = 7;
  r.num_sets = 5;
  return r;
}
ExchangeOptions PinnedExchange() {
  ExchangeOptions e;
  e.seed = 7;
  e.num_candidates = 200;
  return e;
}

void ExpectPinned(const Plan& plan, const double (&pinned)[2][6], double cond, int evaluations) {
  ASSERT_EQ(plan.configurations.size(), 10u) << plan.summary.message;
  EXPECT_NEAR(plan.summary.final.condition_number, cond, 1e-12 * cond);
  EXPECT_EQ(plan.summary.evaluations, evaluations);
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR(plan.configurations.front()[i], pinned[0][i], 1e-12);
    EXPECT_NEAR(plan.configurations.back()[i], pinned[1][i], 1e-12);
  }
}

void ExpectSameResult(const Plan& a, const Plan& b) {
  EXPECT_EQ(a.configurations, b.configurations);
  EXPECT_EQ(a.summary.objective_trace, b.summary.objective_trace);
  EXPECT_EQ(a.summary.evaluations, b.summary.evaluations);
}

TEST(FeasibilityTest, EmptyPredicateReproducesThePlannersBeforePredicates) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  const Plan solis_wets = PlanSolisWets(model, kM, o, PinnedSolisWets());
  ExpectPinned(solis_wets, kPinnedSolisWets, 4.5368237975117349, 153);
  const Plan random = PlanRandom(model, kM, o, PinnedRandom());
  ExpectPinned(random, kPinnedRandom, 6.6396087351997641, 5);
  const Plan exchange = PlanExchange(model, kM, o, PinnedExchange());
  ExpectPinned(exchange, kPinnedExchange, 4.290283410388489, 1945);
  // Draws are counted without a predicate too; nothing is rejected and no predicate work is bounded.
  EXPECT_EQ(solis_wets.summary.feasibility_draws, 2 * kM);
  EXPECT_EQ(random.summary.feasibility_draws, 5 * kM);
  EXPECT_EQ(exchange.summary.feasibility_draws, 200);
  for (const Plan* p : {&solis_wets, &random, &exchange}) {
    EXPECT_EQ(p->summary.feasibility_rejections, 0);
    EXPECT_EQ(p->summary.infeasible_candidates, 0);
  }
  EXPECT_EQ(MaxPlanWork(kM, PinnedSolisWets()).feasibility_checks, 0);
  EXPECT_EQ(MaxPlanWork(kM, PinnedRandom()).feasibility_checks, 0);
  EXPECT_EQ(MaxPlanWork(kM, PinnedExchange()).feasibility_checks, 0);

  // A predicate accepting everything takes the same path, bit for bit.
  const FeasibilityPredicate all = [](const Eigen::VectorXd&) { return true; };
  SolisWetsOptions s = PinnedSolisWets();
  s.feasible = all;
  ExpectSameResult(PlanSolisWets(model, kM, o, s), solis_wets);
  RandomSelectionOptions r = PinnedRandom();
  r.feasible = all;
  ExpectSameResult(PlanRandom(model, kM, o, r), random);
  ExchangeOptions e = PinnedExchange();
  e.feasible = all;
  ExpectSameResult(PlanExchange(model, kM, o, e), exchange);
}

// Joint 2 above zero (half of the range) and joint 3 outside [-2, 2] (a band taken out of the middle).
bool InCell(const Eigen::VectorXd& q) { return q[1] > 0.0 && std::abs(q[2]) > 2.0; }

void ExpectFeasible(const Plan& plan) {
  ASSERT_EQ(static_cast<int>(plan.configurations.size()), kM) << plan.summary.message;
  for (const Eigen::VectorXd& q : plan.configurations) {
    // Re-checked here, not by the predicate the planner was given.
    EXPECT_GT(q[1], 0.0) << q.transpose();
    EXPECT_GT(std::abs(q[2]), 2.0) << q.transpose();
  }
}

// A tight cell: InCell and joint 1 within a tenth of its range (about 3 % of the joint space feasible). A
// whole-set step of 10 configurations survives with probability about 0.2^10 (each configuration's step stays
// feasible about a fifth of the time): no step is ever taken and the plan is its starting set. Holding the
// infeasible configurations back, the search moves the others and improves.
bool InTightCell(const Eigen::VectorXd& q) { return InCell(q) && std::abs(q[0]) < 0.1 * std::numbers::pi; }

TEST(SolisWetsInACellTest, HoldingInfeasibleConfigurationsBackKeepsTheSearchMoving) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  SolisWetsOptions s = SolisWetsOptions::Paper();
  s.feasible = InTightCell;
  s.cell_step = SolisWetsOptions::CellStep::kWholeSet;
  const Plan whole = PlanSolisWets(model, kM, o, s);
  s.cell_step = SolisWetsOptions::CellStep::kFeasibleConfigurations;
  const Plan held = PlanSolisWets(model, kM, o, s);
  for (const Plan* plan : {&whole, &held}) {
    ASSERT_EQ(static_cast<int>(plan->configurations.size()), kM) << plan->summary.message;
    for (const Eigen::VectorXd& q : plan->configurations) {
      EXPECT_GT(q[1], 0.0);
      EXPECT_GT(std::abs(q[2]), 2.0);
      EXPECT_LT(std::abs(q[0]), 0.1 * std::numbers::pi);
    }
  }
  // The same seed draws the same starting set.
  EXPECT_EQ(whole.summary.initial.condition_number, held.summary.initial.condition_number);
  // Whole sets: almost every candidate infeasible (a few tiny steps once sigma has contracted), and little
  // gained.
  EXPECT_LT(whole.summary.evaluations, s.k_max / 10);
  EXPECT_GT(whole.summary.infeasible_candidates, 2 * s.k_max * 9 / 10);
  EXPECT_GT(whole.summary.final.condition_number, 0.9 * whole.summary.initial.condition_number);
  // Held: steps are taken and the condition number falls by more than a quarter.
  EXPECT_GT(held.summary.evaluations, s.k_max);
  EXPECT_LT(held.summary.final.condition_number, 0.75 * held.summary.initial.condition_number);
}

class FeasiblePlanTest : public ::testing::TestWithParam<ObservabilityIndex> {};

TEST_P(FeasiblePlanTest, EveryPlannerReturnsOnlyFeasibleConfigurations) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  SolisWetsOptions s = SolisWetsOptions::Paper();
  s.objective = GetParam();
  s.feasible = InCell;
  const Plan solis_wets = PlanSolisWets(model, kM, o, s);
  ExpectFeasible(solis_wets);
  EXPECT_EQ(solis_wets.summary.termination, Termination::kConvergence) << solis_wets.summary.message;
  // Steps leave the cell (a third of each joint-3 range is a band of width 4 rad), are not evaluated, and the
  // search still improves on its start.
  EXPECT_GT(solis_wets.summary.infeasible_candidates, 0);
  EXPECT_LE(solis_wets.summary.evaluations, 2 * s.k_max + 1);
  EXPECT_LT(ObjectiveValue(solis_wets.summary.final, s.objective),
            ObjectiveValue(solis_wets.summary.initial, s.objective));
  // Rejection sampling rejects about two thirds (1 - 0.5 x 0.68) of the draws.
  EXPECT_GT(solis_wets.summary.feasibility_rejections, 0);
  EXPECT_EQ(solis_wets.summary.feasibility_draws - solis_wets.summary.feasibility_rejections,
            kM + (GetParam() == ObservabilityIndex::kPredictedError ? s.num_validation : 0));
  EXPECT_THAT(solis_wets.summary.FullReport(), HasSubstr("rejected as infeasible"));

  RandomSelectionOptions r;
  r.objective = GetParam();
  r.num_sets = 5;
  r.feasible = InCell;
  ExpectFeasible(PlanRandom(model, kM, o, r));

  ExchangeOptions e;
  e.objective = GetParam();
  e.num_candidates = 300;
  e.feasible = InCell;
  const Plan exchange = PlanExchange(model, kM, o, e);
  ExpectFeasible(exchange);
  EXPECT_EQ(exchange.summary.feasibility_draws - exchange.summary.feasibility_rejections,
            300 + (GetParam() == ObservabilityIndex::kPredictedError ? e.num_validation : 0));
  EXPECT_LE(exchange.summary.feasibility_draws, MaxPlanWork(kM, e).feasibility_checks);
}

INSTANTIATE_TEST_SUITE_P(Objectives, FeasiblePlanTest,
                         ::testing::Values(ObservabilityIndex::kConditionNumber, ObservabilityIndex::kPredictedError),
                         [](const ::testing::TestParamInfo<ObservabilityIndex>& info) { return ToString(info.param); });

TEST(FeasibilityTest, RejectionSamplingIsBoundedAndFailsWithItsCounts) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  const FeasibilityPredicate nothing = [](const Eigen::VectorXd&) { return false; };
  SolisWetsOptions s = SolisWetsOptions::Paper();
  s.feasible = nothing;
  const Plan solis_wets = PlanSolisWets(model, kM, o, s);
  EXPECT_EQ(solis_wets.summary.termination, Termination::kFailure);
  EXPECT_TRUE(solis_wets.configurations.empty());
  EXPECT_EQ(solis_wets.summary.feasibility_draws, 100 * kM);
  EXPECT_EQ(solis_wets.summary.feasibility_rejections, 100 * kM);
  EXPECT_THAT(solis_wets.summary.message,
              HasSubstr("0 of 1000 random configurations within the joint limits were feasible"));
  EXPECT_THAT(solis_wets.summary.message, HasSubstr("max_draws_per_configuration"));

  // Joint 1 within 0.2 % of its range: 0.2 % feasible, under the 1 % that 100 draws per configuration allow.
  const double top = model.upper_limits()[0] - 0.002 * (model.upper_limits()[0] - model.lower_limits()[0]);
  ExchangeOptions e;
  e.num_candidates = 200;
  e.feasible = [top](const Eigen::VectorXd& q) { return q[0] > top; };
  const Plan exchange = PlanExchange(model, kM, o, e);
  EXPECT_EQ(exchange.summary.termination, Termination::kFailure);
  EXPECT_TRUE(exchange.configurations.empty());
  EXPECT_EQ(exchange.summary.feasibility_draws, 20000);
  const std::int64_t found = exchange.summary.feasibility_draws - exchange.summary.feasibility_rejections;
  EXPECT_GT(found, 0);
  EXPECT_LT(found, 200);
  EXPECT_THAT(
      exchange.summary.message,
      HasSubstr(std::to_string(found) + " of 20000 random configurations within the joint limits were feasible"));
  // More draws per configuration find them.
  e.max_draws_per_configuration = 2000;
  const Plan patient = PlanExchange(model, kM, o, e);
  EXPECT_NE(patient.summary.termination, Termination::kFailure) << patient.summary.message;
  for (const Eigen::VectorXd& q : patient.configurations) EXPECT_GT(q[0], top);

  RandomSelectionOptions r;
  r.feasible = nothing;
  r.objective = ObservabilityIndex::kPredictedError;  // its validation sample runs out first
  const Plan random = PlanRandom(model, kM, o, r);
  EXPECT_EQ(random.summary.termination, Termination::kFailure);
  EXPECT_EQ(random.summary.feasibility_draws, 100 * (kM + r.num_validation));
}

TEST(FeasibilityTest, InfeasibleInitialSetAndDrawOptionsAreRejected) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  Rng rng(3);
  std::vector<Eigen::VectorXd> initial;
  FeasibleDraws account;
  ASSERT_TRUE(DrawFeasibleConfigurations(model, kM, InCell, &rng, &account, &initial));
  SolisWetsOptions s = SolisWetsOptions::Paper();
  s.k_max = 5;
  s.feasible = InCell;
  ExpectFeasible(PlanSolisWets(model, kM, o, s, initial));
  initial[2][1] = -0.5;
  try {
    PlanSolisWets(model, kM, o, s, initial);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("initial[2] is infeasible"));
  }
  std::string error;
  s.max_draws_per_configuration = 0;
  EXPECT_FALSE(s.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("max_draws_per_configuration"));
  RandomSelectionOptions r;
  r.num_validation = 0;
  EXPECT_FALSE(r.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("num_validation"));
  ExchangeOptions e;
  e.max_draws_per_configuration = 0;
  EXPECT_FALSE(e.IsValid(&error));
}

// The shared sampler: with an empty predicate it is RandomConfigurations, draw for draw.
TEST(FeasibilityTest, SamplerWithoutPredicateIsRandomConfigurations) {
  const RobotModel model = Preset("puma560");
  Rng a(9), b(9);
  std::vector<Eigen::VectorXd> drawn;
  FeasibleDraws account;
  ASSERT_TRUE(DrawFeasibleConfigurations(model, 7, {}, &a, &account, &drawn));
  EXPECT_EQ(drawn, RandomConfigurations(model, 7, &b));
  EXPECT_EQ(account.draws, 7);
  EXPECT_EQ(account.Describe(), "7 of 7 random configurations within the joint limits were feasible");
  account.max_draws = 9;
  EXPECT_FALSE(DrawFeasibleConfigurations(model, 5, {}, &a, &account, &drawn));
  EXPECT_EQ(drawn.size(), 9u);
}

TEST(FeasibilityTest, WorkBoundsCountPredicateCallsAndValidationJacobians) {
  const FeasibilityPredicate any = [](const Eigen::VectorXd&) { return true; };
  SolisWetsOptions s = SolisWetsOptions::Paper();
  s.restarts = 1;
  s.feasible = any;
  // Starting sets: 100 draws x 2 x 10; candidates: 2 runs x 200 sets x 10 configurations.
  EXPECT_EQ(MaxPlanWork(kM, s).feasibility_checks, 100 * 20 + 2 * 200 * 10);
  s.objective = ObservabilityIndex::kPredictedError;
  EXPECT_EQ(MaxPlanWork(kM, s).feasibility_checks, 100 * (20 + 50) + 2 * 200 * 10);
  EXPECT_EQ(MaxPlanWork(kM, s).jacobians, 2 * 201 * kM + 50);
  RandomSelectionOptions r;
  r.num_sets = 3;
  r.feasible = any;
  EXPECT_EQ(MaxPlanWork(kM, r).feasibility_checks, 100 * 30);
  ExchangeOptions e;
  e.num_candidates = 500;
  e.objective = ObservabilityIndex::kPredictedError;
  EXPECT_EQ(MaxPlanWork(kM, e).jacobians, 550);
  EXPECT_EQ(MaxPlanWork(kM, e).feasibility_checks, 0);
  e.feasible = any;
  EXPECT_EQ(MaxPlanWork(kM, e).feasibility_checks, 100 * 550);
}

// The predicted_error objective: every planner lowers it from its start, and what it reports is PredictAccuracy
// at the documented validation sample (num_validation configurations from Rng(seed + kPredictedErrorSeedOffset)).
TEST(PredictedErrorObjectiveTest, EveryPlannerLowersItAndReportsTheDocumentedSample) {
  const RobotModel model = Preset("puma560");
  for (MeasurementType type : {MeasurementType::kPosition, MeasurementType::kPose}) {
    SCOPED_TRACE(ToString(type));
    const ObservabilityOptions o = test::IdentifiableSetOptions(model, type);
    SolisWetsOptions s = SolisWetsOptions::Paper();
    s.objective = ObservabilityIndex::kPredictedError;
    s.seed = 4;
    const Plan solis_wets = PlanSolisWets(model, kM, o, s);
    RandomSelectionOptions r;
    r.objective = ObservabilityIndex::kPredictedError;
    r.num_sets = 20;
    r.seed = 4;
    const Plan random = PlanRandom(model, kM, o, r);
    ExchangeOptions e;
    e.objective = ObservabilityIndex::kPredictedError;
    e.num_candidates = 500;
    e.seed = 4;
    const Plan exchange = PlanExchange(model, kM, o, e);
    Rng rng(4 + kPredictedErrorSeedOffset);
    const auto validation = RandomConfigurations(model, 50, &rng);
    for (const Plan* p : {&solis_wets, &random, &exchange}) {
      SCOPED_TRACE(p->summary.method);
      ExpectWithinLimits(model, *p, kM);
      const double start = p->summary.initial.predicted_error_mm, end = p->summary.final.predicted_error_mm;
      EXPECT_TRUE(std::isfinite(end));
      EXPECT_LE(end, start);
      EXPECT_NEAR(end, PredictAccuracy(model, o, p->configurations, validation).rms_error_mm, 1e-8 * end);
      EXPECT_THAT(p->summary.BriefReport(), HasSubstr("predicted_error"));
    }
    EXPECT_LT(solis_wets.summary.final.predicted_error_mm, 0.9 * solis_wets.summary.initial.predicted_error_mm);
    EXPECT_LT(exchange.summary.final.predicted_error_mm, 0.9 * exchange.summary.initial.predicted_error_mm);
    EXPECT_EQ(exchange.summary.termination, Termination::kConvergence) << exchange.summary.message;
  }
}

// What the objective is for: exchange plans minimising it predict less error at its sample than plans minimising
// the condition number (medians over seeds). Against log det it is no better with this optimiser: the exchange
// stops after 3-7 exchanges with either screening gain, and D-optimal plans predict errors as low
// (docs/planning.md).
TEST(PredictedErrorObjectiveTest, ExchangeWithItPredictsLessErrorThanWithTheConditionNumber) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPosition);
  std::vector<double> predicted_error, condition_number;
  for (int seed = 1; seed <= 5; ++seed) {
    Rng rng(seed + kPredictedErrorSeedOffset);
    const auto validation = RandomConfigurations(model, 50, &rng);
    ExchangeOptions e;
    e.num_candidates = 300;
    e.seed = seed;
    e.objective = ObservabilityIndex::kPredictedError;
    predicted_error.push_back(
        PredictAccuracy(model, o, PlanExchange(model, kM, o, e).configurations, validation).rms_error_mm);
    e.objective = ObservabilityIndex::kConditionNumber;
    condition_number.push_back(
        PredictAccuracy(model, o, PlanExchange(model, kM, o, e).configurations, validation).rms_error_mm);
  }
  EXPECT_LT(Median(predicted_error), 0.9 * Median(condition_number));
}

}  // namespace
}  // namespace robocal
