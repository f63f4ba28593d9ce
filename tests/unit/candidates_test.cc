// Plans from the cell's own configurations: the planners over a candidate pool (members and indices, the account of
// rejected candidates, too few usable ones, against random draws from the same pool, seeds), the coverage warning,
// task configurations, the model error in the predicted error, and the predicted error against N.
#include "robocal/core/candidates.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <set>
#include <stdexcept>

#include "robocal/core/kinematics.h"
#include "robocal/core/planning.h"
#include "robocal/core/presets.h"
#include "test_util.h"

namespace robocal {
namespace {

using ::testing::HasSubstr;

constexpr double kDeg = std::numbers::pi / 180.0;

std::shared_ptr<const std::vector<Eigen::VectorXd>> Pool(const RobotModel& model, int count, std::uint64_t seed) {
  return std::make_shared<const std::vector<Eigen::VectorXd>>(test::RandomConfigurations(model, count, seed));
}

// Every configuration is exactly the candidate its index names, and no candidate is chosen twice.
void ExpectMembersOfThePool(const Plan& plan, const std::vector<Eigen::VectorXd>& pool, int m) {
  ASSERT_EQ(static_cast<int>(plan.configurations.size()), m) << plan.summary.message;
  ASSERT_EQ(plan.candidate_indices.size(), plan.configurations.size());
  for (int i = 0; i < m; ++i) {
    ASSERT_GE(plan.candidate_indices[i], 0);
    ASSERT_LT(plan.candidate_indices[i], static_cast<int>(pool.size()));
    EXPECT_EQ(plan.configurations[i], pool[plan.candidate_indices[i]]);
  }
  EXPECT_EQ(std::set<int>(plan.candidate_indices.begin(), plan.candidate_indices.end()).size(), static_cast<size_t>(m));
}

TEST(CandidatePlanTest, EveryPlannerChoosesMembersOfThePoolWithTheirIndices) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  const auto pool = Pool(model, 300, 11);
  SolisWetsOptions s = SolisWetsOptions::Paper();
  s.candidates.configurations = pool;
  const Plan solis_wets = PlanSolisWets(model, 10, o, s);
  ExpectMembersOfThePool(solis_wets, *pool, 10);
  EXPECT_LT(solis_wets.summary.final.condition_number, solis_wets.summary.initial.condition_number);
  RandomSelectionOptions r;
  r.num_sets = 20;
  r.candidates.configurations = pool;
  ExpectMembersOfThePool(PlanRandom(model, 10, o, r), *pool, 10);
  ExchangeOptions e;
  e.objective = ObservabilityIndex::kLogDet;
  e.candidates.configurations = pool;
  const Plan exchange = PlanExchange(model, 10, o, e);
  ExpectMembersOfThePool(exchange, *pool, 10);
  EXPECT_EQ(exchange.summary.termination, Termination::kConvergence) << exchange.summary.message;
  for (const Plan* p : {&solis_wets, &exchange}) {
    EXPECT_EQ(p->summary.candidates.num_candidates, 300);
    EXPECT_EQ(p->summary.candidates.num_usable, 300);
    EXPECT_TRUE(p->summary.candidates.rejected.empty());
    // Nothing is drawn from a pool of candidates.
    EXPECT_EQ(p->summary.feasibility_draws, 0);
  }
  // The work bounds hold over candidates too.
  EXPECT_LE(solis_wets.summary.evaluations, MaxPlanWork(10, s).evaluations);
  EXPECT_LE(exchange.summary.evaluations, MaxPlanWork(10, e).evaluations);
}

TEST(CandidatePlanTest, SameSeedSameResultOtherSeedOtherResult) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  const auto pool = Pool(model, 200, 3);
  SolisWetsOptions s = SolisWetsOptions::Paper();
  s.candidates.configurations = pool;
  s.seed = 5;
  const Plan a = PlanSolisWets(model, 10, o, s);
  const Plan b = PlanSolisWets(model, 10, o, s);
  EXPECT_EQ(a.candidate_indices, b.candidate_indices);
  EXPECT_EQ(a.summary.objective_trace, b.summary.objective_trace);
  s.seed = 6;
  EXPECT_NE(PlanSolisWets(model, 10, o, s).candidate_indices, a.candidate_indices);
  RandomSelectionOptions r;
  r.candidates.configurations = pool;
  r.seed = 5;
  EXPECT_EQ(PlanRandom(model, 10, o, r).candidate_indices, PlanRandom(model, 10, o, r).candidate_indices);
  ExchangeOptions e;
  e.candidates.configurations = pool;
  e.seed = 5;
  const Plan x = PlanExchange(model, 10, o, e);
  EXPECT_EQ(x.candidate_indices, PlanExchange(model, 10, o, e).candidate_indices);
  EXPECT_EQ(x.summary.objective_trace, PlanExchange(model, 10, o, e).summary.objective_trace);
}

// Joint 2 above zero: the rule "joint2_down" rejects the others.
bool Joint2Up(const Eigen::VectorXd& q) { return q[1] > 0.0; }

TEST(CandidatePlanTest, RejectedCandidatesAreNeverChosenAndCountedWithTheirReason) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  std::vector<Eigen::VectorXd> candidates = test::RandomConfigurations(model, 200, 21);
  candidates[3] = Eigen::VectorXd::Zero(5);
  candidates[7][2] = std::numeric_limits<double>::quiet_NaN();
  candidates[9][4] = model.upper_limits()[4] + 0.1;
  candidates[12] = Eigen::VectorXd::Zero(7);
  int down = 0, first_down = -1;
  for (int i = 0; i < 200; ++i) {
    if (i == 3 || i == 7 || i == 9 || i == 12 || Joint2Up(candidates[i])) continue;
    ++down;
    if (first_down < 0) first_down = i;
  }
  ASSERT_GT(down, 50);
  auto pool = std::make_shared<const std::vector<Eigen::VectorXd>>(candidates);
  ExchangeOptions e;
  e.objective = ObservabilityIndex::kLogDet;
  e.feasible = Joint2Up;
  e.candidates.configurations = pool;
  // By default a malformed candidate is the caller's mistake, named by its index.
  try {
    PlanExchange(model, 10, o, e);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& error) {
    EXPECT_THAT(error.what(), HasSubstr("candidates[3] has 5 joint values"));
  }
  e.candidates.malformed = MalformedCandidates::kReject;
  e.candidates.infeasibility_reasons = [](const Eigen::VectorXd&) { return std::vector<std::string>{"joint2_down"}; };
  SolisWetsOptions s = SolisWetsOptions::Paper();
  s.feasible = e.feasible;
  s.candidates = e.candidates;
  RandomSelectionOptions r;
  r.num_sets = 10;
  r.feasible = e.feasible;
  r.candidates = e.candidates;
  for (const Plan& plan :
       {PlanExchange(model, 10, o, e), PlanSolisWets(model, 10, o, s), PlanRandom(model, 10, o, r)}) {
    SCOPED_TRACE(plan.summary.method);
    ExpectMembersOfThePool(plan, candidates, 10);
    for (const Eigen::VectorXd& q : plan.configurations) EXPECT_TRUE(Joint2Up(q));
    const CandidateAccount& a = plan.summary.candidates;
    EXPECT_EQ(a.num_candidates, 200);
    EXPECT_EQ(a.num_usable, 200 - 4 - down);
    ASSERT_EQ(a.rejected.size(), 4u) << a.Describe();
    EXPECT_EQ(a.rejected[0].reason, "joint_count");
    EXPECT_EQ(a.rejected[0].count, 2);
    EXPECT_EQ(a.rejected[0].first_indices, (std::vector<int>{3, 12}));
    EXPECT_EQ(a.rejected[1].reason, "not_finite");
    EXPECT_EQ(a.rejected[1].first_indices, (std::vector<int>{7}));
    EXPECT_EQ(a.rejected[2].reason, "beyond_limits");
    EXPECT_EQ(a.rejected[2].first_indices, (std::vector<int>{9}));
    EXPECT_EQ(a.rejected[3].reason, "joint2_down");
    EXPECT_EQ(a.rejected[3].count, down);
    EXPECT_EQ(static_cast<int>(a.rejected[3].first_indices.size()), kRejectedIndicesKept);
    EXPECT_EQ(a.rejected[3].first_indices.front(), first_down);
    EXPECT_THAT(plan.summary.FullReport(), HasSubstr("joint2_down " + std::to_string(down) + " (#"));
  }
  // Without names the predicate's rejections are "infeasible".
  e.candidates.infeasibility_reasons = nullptr;
  EXPECT_EQ(PlanExchange(model, 10, o, e).summary.candidates.rejected.back().reason, "infeasible");
}

TEST(CandidatePlanTest, ACellNamesItsRulesForTheCandidatesItRejects) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  const Cell cell = Cell::Build(model, PresetCellSpec("ur5e"));
  const auto pool = Pool(model, 3000, 4);
  ExchangeOptions e;
  e.objective = ObservabilityIndex::kLogDet;
  e.feasible = [&](const Eigen::VectorXd& q) { return IsFeasible(model, cell, q); };
  e.candidates.configurations = pool;
  e.candidates.infeasibility_reasons = CellRuleReasons(model, cell);
  const Plan plan = PlanExchange(model, 10, o, e);
  ExpectMembersOfThePool(plan, *pool, 10);
  for (const Eigen::VectorXd& q : plan.configurations) EXPECT_TRUE(IsFeasible(model, cell, q));
  const CandidateAccount& a = plan.summary.candidates;
  ASSERT_FALSE(a.rejected.empty());
  int rejected_by_the_cell = 0;
  for (int i = 0; i < 3000; ++i) rejected_by_the_cell += IsFeasible(model, cell, (*pool)[i]) ? 0 : 1;
  EXPECT_EQ(a.num_usable, 3000 - rejected_by_the_cell);
  for (const CandidateRejections& r : a.rejected) {
    EXPECT_THAT(
        (std::vector<std::string>{"joint_range", "obstacle", "self_collision", "distance", "incidence", "beam"}),
        ::testing::Contains(r.reason));
    // The first index kept for each rule does fail that rule.
    const ConfigurationCheck check = CheckConfiguration(model, cell, (*pool)[r.first_indices.front()]);
    bool named = false;
    for (CellRule rule : check.failed_rules) named = named || r.reason == ToString(rule);
    EXPECT_TRUE(named) << r.reason;
  }
}

TEST(CandidatePlanTest, FewerUsableCandidatesThanConfigurationsFailsWithBothCounts) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  const auto pool = Pool(model, 40, 8);
  int up = 0;
  for (const Eigen::VectorXd& q : *pool) up += Joint2Up(q) ? 1 : 0;
  ASSERT_LT(up, 30);
  ExchangeOptions e;
  e.feasible = Joint2Up;
  e.candidates.configurations = pool;
  const Plan plan = PlanExchange(model, 30, o, e);
  EXPECT_EQ(plan.summary.termination, Termination::kFailure);
  EXPECT_TRUE(plan.configurations.empty());
  EXPECT_THAT(plan.summary.message,
              HasSubstr("30 configurations asked, " + std::to_string(up) + " of 40 candidates usable"));
  SolisWetsOptions s;
  s.feasible = Joint2Up;
  s.candidates.configurations = pool;
  EXPECT_EQ(PlanSolisWets(model, 30, o, s).summary.termination, Termination::kFailure);
  RandomSelectionOptions r;
  r.feasible = Joint2Up;
  r.candidates.configurations = pool;
  EXPECT_EQ(PlanRandom(model, 30, o, r).summary.termination, Termination::kFailure);
  // A plan from candidates cannot also start from a given set.
  EXPECT_THROW(PlanSolisWets(model, 3, o, s, {(*pool)[0], (*pool)[1], (*pool)[2]}), std::invalid_argument);
}

TEST(CandidatePlanTest, ExchangeFromCandidatesBeatsTheBestOf50RandomDrawsOnLogDet) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  const auto pool = Pool(model, 500, 17);
  ExchangeOptions e;
  e.objective = ObservabilityIndex::kLogDet;
  e.candidates.configurations = pool;
  const Plan exchange = PlanExchange(model, 15, o, e);
  RandomSelectionOptions r;
  r.objective = ObservabilityIndex::kLogDet;
  r.num_sets = 50;
  r.candidates.configurations = pool;
  const Plan random = PlanRandom(model, 15, o, r);
  ExpectMembersOfThePool(random, *pool, 15);
  EXPECT_GT(exchange.summary.final.log_det, random.summary.final.log_det);
  // And Solis & Wets over the same pool improves on its random start.
  SolisWetsOptions s = SolisWetsOptions::Paper();
  s.objective = ObservabilityIndex::kLogDet;
  s.candidates.configurations = pool;
  const Plan solis_wets = PlanSolisWets(model, 15, o, s);
  EXPECT_GT(solis_wets.summary.final.log_det, solis_wets.summary.initial.log_det);
}

TEST(CandidateTaskTest, AGivenTaskIsThePredictedErrorsSampleAndTheModelErrorAddsInQuadrature) {
  const RobotModel model = Preset("ur5e");
  ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  const auto pool = Pool(model, 300, 2);
  const auto task = std::make_shared<const std::vector<Eigen::VectorXd>>(test::RandomConfigurations(model, 40, 99));
  ExchangeOptions e;
  e.objective = ObservabilityIndex::kPredictedError;
  e.candidates.configurations = pool;
  e.task = task;
  const Plan plan = PlanExchange(model, 12, o, e);
  ASSERT_EQ(plan.configurations.size(), 12u);
  const double parameter_part = PredictAccuracy(model, o, plan.configurations, *task).rms_error_mm;
  EXPECT_NEAR(plan.summary.final.predicted_error_mm, parameter_part, 1e-6 * parameter_part);
  // Nothing was drawn for the validation sample.
  EXPECT_EQ(plan.summary.feasibility_draws, 0);
  EXPECT_EQ(MaxPlanWork(12, e).jacobians, 300 + 40);
  o.model_error_mm = 0.2;
  const Plan with_model_error = PlanExchange(model, 12, o, e);
  EXPECT_EQ(with_model_error.candidate_indices, plan.candidate_indices);
  EXPECT_NEAR(with_model_error.summary.final.predicted_error_mm, std::sqrt(parameter_part * parameter_part + 0.2 * 0.2),
              1e-9);
  // An empty task, or one of the wrong size, is the caller's mistake.
  e.task = std::make_shared<const std::vector<Eigen::VectorXd>>();
  EXPECT_THROW(PlanExchange(model, 12, o, e), std::invalid_argument);
  e.task = std::make_shared<const std::vector<Eigen::VectorXd>>(1, Eigen::VectorXd::Zero(5));
  EXPECT_THROW(PlanExchange(model, 12, o, e), std::invalid_argument);
  o.model_error_mm = -1.0;
  std::string error;
  EXPECT_FALSE(o.IsValid(model, &error));
}

TEST(CandidateTaskTest, TaskConfigurationsReachTheBoxInTheGivenOrientations) {
  const RobotModel model = Preset("ur5e");
  TaskBox box;
  box.min_mm = Eigen::Vector3d(300.0, -200.0, 100.0);
  box.max_mm = Eigen::Vector3d(500.0, 200.0, 300.0);
  // Tool pointing down, and tilted 30 degrees about x.
  const Eigen::Matrix3d down = Eigen::AngleAxisd(std::numbers::pi, Eigen::Vector3d::UnitX()).toRotationMatrix();
  box.orientations = {down, down * Eigen::AngleAxisd(30 * kDeg, Eigen::Vector3d::UnitX()).toRotationMatrix()};
  const TaskSample sample = SampleTaskConfigurations(model, box, 30, 7);
  EXPECT_EQ(sample.method, "inverse_kinematics");
  ASSERT_TRUE(sample.complete) << sample.message;
  ASSERT_EQ(sample.configurations.size(), 30u);
  const Transform T_base_world = model.T_world_base().inverse();
  for (const Eigen::VectorXd& q : sample.configurations) {
    EXPECT_TRUE(model.WithinLimits(q));
    const Transform T_base_tool = T_base_world * ForwardKinematics(model, q);
    EXPECT_TRUE((T_base_tool.translation().array() >= box.min_mm.array() - 1e-6).all() &&
                (T_base_tool.translation().array() <= box.max_mm.array() + 1e-6).all())
        << T_base_tool.translation().transpose();
    const double to_first = Eigen::AngleAxisd(T_base_tool.linear() * box.orientations[0].transpose()).angle();
    const double to_second = Eigen::AngleAxisd(T_base_tool.linear() * box.orientations[1].transpose()).angle();
    EXPECT_LT(std::min(to_first, to_second), 1e-6);
  }
  EXPECT_EQ(SampleTaskConfigurations(model, box, 30, 7).configurations, sample.configurations);
  EXPECT_NE(SampleTaskConfigurations(model, box, 30, 8).configurations, sample.configurations);

  // The paper's PPPRR robot has no closed-form solver here: rejection sampling by the tool point, said so.
  const RobotModel grinder = Preset("grinder5");
  Rng rng(1);
  const Eigen::Vector3d tool =
      grinder.T_world_base().inverse() * ForwardKinematics(grinder, RandomConfiguration(grinder, &rng)).translation();
  TaskBox near;
  near.min_mm = tool - Eigen::Vector3d::Constant(200.0);
  near.max_mm = tool + Eigen::Vector3d::Constant(200.0);
  near.orientations = {down};
  const TaskSample rejection = SampleTaskConfigurations(grinder, near, 10, 3);
  EXPECT_EQ(rejection.method, "rejection_sampling");
  EXPECT_THAT(rejection.message, HasSubstr("orientations not imposed"));
  for (const Eigen::VectorXd& q : rejection.configurations) {
    const Eigen::Vector3d t = grinder.T_world_base().inverse() * ForwardKinematics(grinder, q).translation();
    EXPECT_TRUE((t.array() >= near.min_mm.array()).all() && (t.array() <= near.max_mm.array()).all());
  }
  TaskBox inverted = box;
  std::swap(inverted.min_mm, inverted.max_mm);
  EXPECT_THROW(SampleTaskConfigurations(model, inverted, 5, 1), std::invalid_argument);
}

TEST(CandidateCoverageTest, ANarrowJoint2IsNamedWithTheParametersItLeavesUndeterminedAndASpreadPoolIsNot) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  std::vector<Eigen::VectorXd> spread = test::RandomConfigurations(model, 1000, 31);
  const CandidateCoverage wide = AnalyseCoverage(model, o, spread);
  EXPECT_TRUE(wide.warning.empty()) << wide.warning;
  EXPECT_TRUE(wide.narrow_joints.empty());
  ASSERT_EQ(wide.joints.size(), 6u);
  ASSERT_EQ(wide.parameters.size(), o.parameters.size());
  for (const ParameterDetermination& p : wide.parameters) EXPECT_LT(p.std_ratio, 2.0) << p.name;

  // Joint 2 within 15 degrees (-97.5 .. -82.5), every other joint as spread as before.
  Rng rng(5);
  std::vector<Eigen::VectorXd> narrow = spread;
  for (Eigen::VectorXd& q : narrow) q[1] = rng.Uniform(-97.5 * kDeg, -82.5 * kDeg);
  const CandidateCoverage c = AnalyseCoverage(model, o, narrow);
  EXPECT_EQ(c.narrow_joints, std::vector<int>{1}) << c.warning;
  EXPECT_TRUE(c.joints[1].too_narrow);
  EXPECT_LT(c.joints[1].fraction, 15.0 / 720.0 + 1e-9);
  ASSERT_FALSE(c.poorly_determined.empty());
  EXPECT_THAT(c.warning, HasSubstr("joint 2"));
  for (int k : c.poorly_determined) {
    const ParameterDetermination& p = c.parameters[k];
    EXPECT_GT(p.std_ratio, 10.0);
    EXPECT_THAT(c.warning, HasSubstr(p.name));
    EXPECT_EQ(p.joints, std::vector<int>{1}) << p.name;
  }
  // The parameters named are those of the joints whose motion joint 2 must supply: joint 2's own site or its
  // neighbours'.
  for (int k : c.poorly_determined) {
    const std::string& name = c.parameters[k].name;
    EXPECT_TRUE(name.find("joint") != std::string::npos || name.find("base") != std::string::npos) << name;
  }
}

TEST(PoseCountTest, ThePredictedErrorFallsWithNAndTheChosenNReachesTheGoal) {
  const RobotModel model = Preset("ur5e");
  ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  PoseCountOptions options;
  options.num_configurations = {6, 8, 10, 15, 20, 30, 40};
  options.exchange.objective = ObservabilityIndex::kPredictedError;
  options.exchange.candidates.configurations = Pool(model, 400, 12);
  options.exchange.task =
      std::make_shared<const std::vector<Eigen::VectorXd>>(test::RandomConfigurations(model, 30, 77));
  const PoseCountCurve curve = PlanPoseCount(model, o, options);
  ASSERT_EQ(curve.termination, Termination::kConvergence) << curve.message;
  ASSERT_EQ(curve.points.size(), options.num_configurations.size());
  for (size_t i = 0; i < curve.points.size(); ++i) {
    const PoseCountPoint& p = curve.points[i];
    EXPECT_EQ(p.num_configurations, options.num_configurations[i]);
    ASSERT_EQ(static_cast<int>(p.candidate_indices.size()), p.num_configurations);
    EXPECT_TRUE(std::isfinite(p.predicted_error_mm));
    // The point's value is the prediction for its own set.
    EXPECT_NEAR(p.predicted_error_mm, PredictAccuracy(model, o, p.configurations, *options.exchange.task).rms_error_mm,
                1e-6 * p.predicted_error_mm);
    if (i > 0) {
      EXPECT_LT(p.predicted_error_mm, curve.points[i - 1].predicted_error_mm);
    }
  }
  EXPECT_EQ(curve.chosen, -1);  // no goal
  // A goal between the 15- and the 20-pose predictions picks 20.
  options.accuracy_goal_mm = 0.5 * (curve.points[3].predicted_error_mm + curve.points[4].predicted_error_mm);
  const PoseCountCurve goal = PlanPoseCount(model, o, options);
  ASSERT_EQ(goal.chosen, 4) << goal.message;
  EXPECT_LE(goal.points[4].predicted_error_mm, options.accuracy_goal_mm);
  EXPECT_GT(goal.points[3].predicted_error_mm, options.accuracy_goal_mm);
  EXPECT_THAT(goal.message, HasSubstr("N = 20 reaches the goal"));
  // Reproducible from the seed.
  for (size_t i = 0; i < curve.points.size(); ++i) {
    EXPECT_EQ(goal.points[i].candidate_indices, curve.points[i].candidate_indices);
  }
  // With a model error the curve flattens at it, and a goal below it is out of reach.
  o.model_error_mm = 0.05;
  options.accuracy_goal_mm = 0.049;
  const PoseCountCurve flat = PlanPoseCount(model, o, options);
  EXPECT_EQ(flat.chosen, -1);
  EXPECT_THAT(flat.message, HasSubstr("no N up to 40 reaches the goal"));
  for (const PoseCountPoint& p : flat.points) EXPECT_GT(p.predicted_error_mm, 0.05);
  EXPECT_LT(flat.points.back().predicted_error_mm - 0.05, 0.5 * (flat.points.front().predicted_error_mm - 0.05));
}

TEST(PoseCountTest, TheCurveStopsWhereTheUsableCandidatesDo) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  PoseCountOptions options;
  options.num_configurations = {6, 10, 20, 30};
  options.exchange.objective = ObservabilityIndex::kLogDet;
  options.exchange.candidates.configurations = Pool(model, 25, 12);
  const PoseCountCurve curve = PlanPoseCount(model, o, options);
  EXPECT_EQ(curve.termination, Termination::kDegraded);
  EXPECT_EQ(curve.points.size(), 3u);
  EXPECT_THAT(curve.message, HasSubstr("25 of 25 candidates usable"));
  options.num_configurations = {30};
  EXPECT_EQ(PlanPoseCount(model, o, options).termination, Termination::kFailure);
  options.exchange.candidates.configurations = nullptr;
  EXPECT_THROW(PlanPoseCount(model, o, options), std::invalid_argument);
}

}  // namespace
}  // namespace robocal
