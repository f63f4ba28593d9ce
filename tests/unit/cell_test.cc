// Cell geometry (distances, intersections, incidence) against hand-computed cases; every feasibility rule
// isolated on a hand-built arm; the report's fields; Build's validation; the planning model; the census.
#include <algorithm>
#include <cmath>
#include <set>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "robocal/core/cell.h"
#include "robocal/core/geometry.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/planning.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"

namespace robocal {
namespace {

using ::testing::Contains;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::UnorderedElementsAreArray;
using V = Eigen::Vector3d;

// ---- Geometry ------------------------------------------------------------------------------------------

TEST(GeometryTest, PointSegmentDistance) {
  EXPECT_DOUBLE_EQ(PointSegmentDistance(V(5, 3, 0), V(0, 0, 0), V(10, 0, 0)), 3.0);   // beside the middle
  EXPECT_DOUBLE_EQ(PointSegmentDistance(V(13, 4, 0), V(0, 0, 0), V(10, 0, 0)), 5.0);  // beyond the end
  EXPECT_DOUBLE_EQ(PointSegmentDistance(V(3, 4, 0), V(0, 0, 0), V(0, 0, 0)), 5.0);    // a point
}

TEST(GeometryTest, SegmentSegmentDistanceHandComputed) {
  // Crossing at right angles, 5 apart along z.
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(-1, 0, 0), V(1, 0, 0), V(0, -1, 5), V(0, 1, 5)), 5.0);
  // Intersecting.
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(-1, 0, 0), V(1, 0, 0), V(0, -1, 0), V(0, 1, 0)), 0.0);
  // Skew, closest points at ends of both: (1, 0, 0) and (2, 0, 1).
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(0, 0, 0), V(1, 0, 0), V(2, -1, 1), V(2, 1, 1)), std::sqrt(2.0));
  // Parallel and overlapping: the distance between the lines.
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(0, 0, 0), V(10, 0, 0), V(4, 3, 4), V(20, 3, 4)), 5.0);
  // Parallel, not overlapping: end to end, (10, 0, 0) to (13, 4, 0).
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(0, 0, 0), V(10, 0, 0), V(13, 4, 0), V(20, 4, 0)), 5.0);
  // Parallel, opposite directions, overlapping.
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(0, 0, 0), V(10, 0, 0), V(8, 0, 2), V(-3, 0, 2)), 2.0);
  // Collinear and apart.
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(0, 0, 0), V(1, 0, 0), V(4, 0, 0), V(9, 0, 0)), 3.0);
  // Degenerate: point-point, point-segment, segment-point.
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(0, 0, 0), V(0, 0, 0), V(3, 4, 0), V(3, 4, 0)), 5.0);
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(5, 3, 0), V(5, 3, 0), V(0, 0, 0), V(10, 0, 0)), 3.0);
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(0, 0, 0), V(10, 0, 0), V(5, 3, 0), V(5, 3, 0)), 3.0);
}

TEST(GeometryTest, SegmentSegmentDistanceAgreesWithSampling) {
  Rng rng(7);
  auto random_point = [&] { return V(rng.Uniform(-10, 10), rng.Uniform(-10, 10), rng.Uniform(-10, 10)); };
  for (int trial = 0; trial < 200; ++trial) {
    const V p0 = random_point(), p1 = random_point(), q0 = random_point(), q1 = random_point();
    const double d = SegmentSegmentDistance(p0, p1, q0, q1);
    EXPECT_NEAR(d, SegmentSegmentDistance(q1, q0, p1, p0), 1e-12);  // symmetric, direction-free
    double sampled = INFINITY;
    constexpr int kSteps = 200;
    for (int i = 0; i <= kSteps; ++i) {
      const V p = p0 + (p1 - p0) * i / kSteps;
      sampled = std::min(sampled, PointSegmentDistance(p, q0, q1));
    }
    // The exact minimum is at most the sampled one, and within the sampling step of it.
    EXPECT_LE(d, sampled + 1e-12);
    EXPECT_GE(d, sampled - (p1 - p0).norm() / kSteps);
  }
}

TEST(GeometryTest, SegmentBoxDistanceHandComputed) {
  const V lo(0, 0, 0), hi(1, 1, 1);
  EXPECT_DOUBLE_EQ(SegmentBoxDistance(V(-1, 2, 0.5), V(2, 2, 0.5), lo, hi), 1.0);            // parallel to a face
  EXPECT_DOUBLE_EQ(SegmentBoxDistance(V(-1, 0.5, 0.5), V(2, 0.5, 0.5), lo, hi), 0.0);        // through it
  EXPECT_DOUBLE_EQ(SegmentBoxDistance(V(0.2, 0.3, 0.4), V(0.6, 0.7, 0.8), lo, hi), 0.0);     // inside
  EXPECT_DOUBLE_EQ(SegmentBoxDistance(V(2, 2, 2), V(3, 3, 3), lo, hi), std::sqrt(3.0));      // off a corner
  EXPECT_DOUBLE_EQ(SegmentBoxDistance(V(3, 0, 0.5), V(0, 3, 0.5), lo, hi), std::sqrt(0.5));  // past an edge
  EXPECT_DOUBLE_EQ(SegmentBoxDistance(V(4, 5, 1), V(4, 5, 1), lo, hi), 5.0);                 // a point
  EXPECT_DOUBLE_EQ(SegmentBoxDistance(V(1, 0, 3), V(3, 0, 1), lo, hi), std::sqrt(2.0));      // past the top edge
}

TEST(GeometryTest, SegmentBoxDistanceAgreesWithSampling) {
  Rng rng(11);
  const V lo(-1, -2, -0.5), hi(2, 1, 0.5);
  for (int trial = 0; trial < 200; ++trial) {
    const V a(rng.Uniform(-5, 5), rng.Uniform(-5, 5), rng.Uniform(-5, 5));
    const V b(rng.Uniform(-5, 5), rng.Uniform(-5, 5), rng.Uniform(-5, 5));
    const double d = SegmentBoxDistance(a, b, lo, hi);
    double sampled = INFINITY;
    constexpr int kSteps = 400;
    for (int i = 0; i <= kSteps; ++i) sampled = std::min(sampled, PointBoxDistance(a + (b - a) * i / kSteps, lo, hi));
    EXPECT_LE(d, sampled + 1e-12);
    EXPECT_GE(d, sampled - (b - a).norm() / kSteps);
    EXPECT_EQ(d == 0.0, SegmentIntersectsBox(a, b, lo, hi)) << trial;
  }
}

TEST(GeometryTest, SegmentIntersectsBox) {
  const V lo(0, 0, 0), hi(1, 1, 1);
  EXPECT_TRUE(SegmentIntersectsBox(V(-1, 0.5, 0.5), V(2, 0.5, 0.5), lo, hi));     // through
  EXPECT_TRUE(SegmentIntersectsBox(V(0.5, 0.5, 0.5), V(0.6, 0.5, 0.5), lo, hi));  // inside
  EXPECT_TRUE(SegmentIntersectsBox(V(-1, 0.5, 1), V(2, 0.5, 1), lo, hi));         // along the top face
  EXPECT_FALSE(SegmentIntersectsBox(V(-1, 0.5, 1.01), V(2, 0.5, 1.01), lo, hi));
  EXPECT_FALSE(SegmentIntersectsBox(V(-2, 0.5, 0.5), V(-1, 0.5, 0.5), lo, hi));  // stops short
  EXPECT_FALSE(SegmentIntersectsBox(V(3, 0, 0.5), V(0, 3, 0.5), lo, hi));        // passes the edge
}

TEST(GeometryTest, SegmentHitsCapsuleHitMissTangent) {
  const V c0(0, 0, 0), c1(100, 0, 0);
  // Through the cylinder part.
  EXPECT_TRUE(SegmentHitsCapsule(V(50, -100, 5), V(50, 100, 5), c0, c1, 10));
  // Tangent: the segment passes at exactly the radius, (50, 0, 0) to (50, 0, 10); grazing does not block.
  EXPECT_FALSE(SegmentHitsCapsule(V(50, -100, 10), V(50, 100, 10), c0, c1, 10));
  EXPECT_TRUE(SegmentHitsCapsule(V(50, -100, 9.999), V(50, 100, 9.999), c0, c1, 10));
  // Past the end of the axis: only the spherical cap counts.
  EXPECT_TRUE(SegmentHitsCapsule(V(105, -100, 0), V(105, 100, 0), c0, c1, 10));
  EXPECT_FALSE(SegmentHitsCapsule(V(115, -100, 0), V(115, 100, 0), c0, c1, 10));
  // A beam that stops before the capsule.
  EXPECT_FALSE(SegmentHitsCapsule(V(50, -100, 0), V(50, -20, 0), c0, c1, 10));
}

TEST(GeometryTest, IncidenceAngle) {
  const V normal(0, 0, 1), reflector(10, 20, 30);
  EXPECT_NEAR(IncidenceAngle(normal, reflector, reflector + V(0, 0, 500)), 0.0, 1e-15);
  EXPECT_NEAR(IncidenceAngle(normal, reflector, reflector + V(300, 0, 300)), M_PI / 4, 1e-15);
  EXPECT_NEAR(IncidenceAngle(normal, reflector, reflector + V(0, -7, 0)), M_PI / 2, 1e-15);
  EXPECT_NEAR(IncidenceAngle(normal, reflector, reflector + V(0, 0, -1)), M_PI, 1e-15);
  EXPECT_NEAR(IncidenceAngle(normal, reflector, reflector + V(0, std::sqrt(3.0), 1)), M_PI / 3, 1e-15);
}

// ---- The hand-built arm --------------------------------------------------------------------------------
//
// Standard DH: a 1000 mm column (joint 1 vertical, alpha = 90 deg), a 300 mm upper arm and a 500 mm forearm
// turning about the horizontal axis z1 = (0, -1, 0). At q = 0 the frame origins are (0, 0, 0), (0, 0, 1000),
// (300, 0, 1000) and the flange (800, 0, 1000), with flange x = +x and flange z = -y. The reflector "smr1" sits
// 100 mm along flange z, at (800, -100, 1000), facing -y; the tracker 2000 mm in front of it.

RobotModel Arm() {
  RobotModelSpec spec;
  spec.name = "arm3";
  spec.convention = GeometryConvention::kStandardDh;
  JointSpec j;
  j.min = -M_PI;
  j.max = M_PI;
  j.name = "column";
  j.d_mm = 1000;
  j.alpha_rad = M_PI / 2;
  spec.joints.push_back(j);
  j = JointSpec{"upper", JointType::kRevolute, 300, 0, 0, 0, V::Zero(), V::Zero(), -M_PI, M_PI};
  spec.joints.push_back(j);
  j.name = "fore";
  j.a_mm = 500;
  spec.joints.push_back(j);
  return RobotModel::Build(spec);
}

ReflectorSpec Smr(const std::string& id, const V& position, const V& normal, double half_angle_rad = M_PI / 6) {
  ReflectorSpec r;
  r.id = id;
  r.position_mm = position;
  r.normal = normal;
  r.acceptance_half_angle_rad = half_angle_rad;
  return r;
}

// Feasible at q = 0: every capsule far from the others and from the floor, the beam clear.
CellSpec ArmCell() {
  CellSpec spec;
  spec.tracker.position_mm = V(800, -2100, 1000);
  spec.tracker.min_distance_mm = 1500;
  spec.tracker.max_distance_mm = 15000;
  spec.reflectors = {Smr("smr1", V(0, 0, 100), V(0, 0, 1))};
  spec.obstacles = {{"floor", V(-3000, -3000, -500), V(3000, 3000, -10)}};
  spec.link_radii_mm = {50, 40, 30};
  spec.tool_radius_mm = 20;
  spec.clearance_mm = 10;
  return spec;
}

const Eigen::VectorXd kZero = Eigen::VectorXd::Zero(3);

std::vector<CellRule> Rules(const RobotModel& model, const CellSpec& spec, const Eigen::VectorXd& q) {
  const Cell cell = Cell::Build(model, spec);
  const ConfigurationCheck check = CheckConfiguration(model, cell, q);
  EXPECT_EQ(check.feasible, IsFeasible(model, cell, q));
  EXPECT_EQ(check.feasible, check.failed_rules.empty());
  EXPECT_EQ(check.reasons.size(), check.failed_rules.size());
  return check.failed_rules;
}

TEST(CellTest, TheArmCellIsFeasibleAtZero) {
  const RobotModel model = Arm();
  EXPECT_THAT(Rules(model, ArmCell(), kZero), ElementsAre());
}

// Each rule alone: the same configuration is feasible in the cell without the one cause.

TEST(CellTest, JointRangeAloneRejects) {
  const RobotModel model = Arm();
  CellSpec spec = ArmCell();
  spec.joint_min = Eigen::Vector3d(-1, -1, 0.1);
  spec.joint_max = Eigen::Vector3d(1, 1, 1.0);
  EXPECT_THAT(Rules(model, spec, kZero), ElementsAre(CellRule::kJointRange));
  const ConfigurationCheck check = CheckConfiguration(model, Cell::Build(model, spec), kZero);
  EXPECT_EQ(check.reasons[0], "fore is at 0.0 deg, outside the cell's range [5.7, 57.3] deg");
  // The ranges bind q, nothing else: the geometry at q = 0 is the feasible one.
  EXPECT_TRUE(check.reflectors[0].measurable);
}

TEST(CellTest, ObstacleAloneRejects) {
  const RobotModel model = Arm();
  CellSpec spec = ArmCell();
  // Its top 35 mm under the forearm's axis: 5 mm from the 30 mm capsule, under the 10 mm clearance.
  spec.obstacles.push_back({"table", V(500, -50, 900), V(600, 50, 965)});
  EXPECT_THAT(Rules(model, spec, kZero), ElementsAre(CellRule::kObstacle));
  const ConfigurationCheck check = CheckConfiguration(model, Cell::Build(model, spec), kZero);
  EXPECT_NEAR(check.min_clearance_mm, 5.0, 1e-9);
  EXPECT_EQ(check.clearance_pair, "link 3 / table");
  EXPECT_EQ(check.reasons[0], "link 3 and obstacle 'table' are 5.0 mm apart, under the 10.0 mm clearance");
}

TEST(CellTest, SelfCollisionAloneRejects) {
  const RobotModel model = Arm();
  // Forearm folded back (q3 = 180 deg) across the top of the column: link 3 runs from (300, 0, 1000) to
  // (-200, 0, 1000) through the column's top end. The reflector is then at (-200, -100, 1000).
  const Eigen::VectorXd q = Eigen::Vector3d(0, 0, M_PI);
  CellSpec spec = ArmCell();
  spec.tracker.position_mm = V(-200, -2100, 1000);
  EXPECT_THAT(Rules(model, spec, q), ElementsAre(CellRule::kSelfCollision));
  const ConfigurationCheck check = CheckConfiguration(model, Cell::Build(model, spec), q);
  // The axes meet: the capsules (radii 50 and 30) overlap by 80 mm. The tool, 200 mm from the column and
  // from the upper arm, is clear.
  EXPECT_NEAR(check.min_clearance_mm, -80.0, 1e-9);
  EXPECT_EQ(check.clearance_pair, "link 1 / link 3");
  EXPECT_EQ(check.reasons[0], "link 1 and link 3 overlap by 80.0 mm, under the 10.0 mm clearance");
  EXPECT_TRUE(check.reflectors[0].measurable);
}

TEST(CellTest, DistanceWindowAloneRejects) {
  const RobotModel model = Arm();
  CellSpec spec = ArmCell();
  spec.tracker.position_mm = V(800, -1100, 1000);  // 1000 mm from the reflector, under the 1500 mm minimum
  EXPECT_THAT(Rules(model, spec, kZero), ElementsAre(CellRule::kDistance));
  spec.tracker.min_distance_mm = 900;
  EXPECT_THAT(Rules(model, spec, kZero), ElementsAre());
  spec.tracker.max_distance_mm = 950;
  EXPECT_THAT(Rules(model, spec, kZero), ElementsAre(CellRule::kDistance));
  const ConfigurationCheck check = CheckConfiguration(model, Cell::Build(model, spec), kZero);
  EXPECT_NEAR(check.reflectors[0].distance_mm, 1000.0, 1e-9);
  EXPECT_EQ(check.reasons[0], "smr1 is 1000.0 mm from the tracker, outside its window [900.0, 950.0] mm");
}

// A reflector at the tracker itself is not measurable (no distance, no direction to face), even with no
// minimum distance.
TEST(CellTest, AReflectorAtTheTrackerIsNotMeasured) {
  const RobotModel model = Arm();
  CellSpec spec = ArmCell();
  spec.tracker.min_distance_mm = 0.0;
  const Transform flange = model.T_world_base().inverse() * ForwardKinematics(model, kZero) *
                           model.T_flange_tool().inverse();
  spec.tracker.position_mm = flange * V(0, 0, 100);
  const Cell cell = Cell::Build(model, spec);
  const ConfigurationCheck check = CheckConfiguration(model, cell, kZero);
  EXPECT_FALSE(check.feasible);
  EXPECT_FALSE(check.reflectors[0].measurable);
  EXPECT_NEAR(check.reflectors[0].distance_mm, 0.0, 1e-9);
  EXPECT_THAT(check.failed_rules, Contains(CellRule::kDistance));
  EXPECT_THAT(check.reasons, Contains("smr1 is at the tracker itself"));
  EXPECT_FALSE(IsFeasible(model, cell, kZero));
}

TEST(CellTest, IncidenceAloneRejects) {
  const RobotModel model = Arm();
  CellSpec spec = ArmCell();
  spec.tracker.position_mm = V(2300, -1600, 1000);  // 45 deg off the reflector's normal (0, -1, 0)
  EXPECT_THAT(Rules(model, spec, kZero), ElementsAre(CellRule::kIncidence));
  const ConfigurationCheck check = CheckConfiguration(model, Cell::Build(model, spec), kZero);
  EXPECT_NEAR(check.reflectors[0].incidence_rad, M_PI / 4, 1e-12);
  EXPECT_EQ(check.reasons[0], "smr1 faces 45.0 deg away from the tracker, beyond its acceptance of 30.0 deg");
  spec.reflectors[0].acceptance_half_angle_rad = 46 * M_PI / 180;
  EXPECT_THAT(Rules(model, spec, kZero), ElementsAre());
}

TEST(CellTest, BlockedBeamAloneRejects) {
  const RobotModel model = Arm();
  CellSpec spec = ArmCell();
  spec.obstacles.push_back({"wall", V(700, -1200, 900), V(900, -1100, 1100)});  // across the beam, far away
  EXPECT_THAT(Rules(model, spec, kZero), ElementsAre(CellRule::kBeam));
  const ConfigurationCheck check = CheckConfiguration(model, Cell::Build(model, spec), kZero);
  EXPECT_EQ(check.reflectors[0].blocked_by, "wall");
  EXPECT_EQ(check.reasons[0], "the beam to smr1 is blocked by wall");
}

TEST(CellTest, BeamBlockersAreNamed) {
  const RobotModel model = Arm();
  CellSpec spec = ArmCell();
  // From behind the robot (+y), with a reflector that accepts every direction: the beam passes through the
  // forearm's end at (800, 0, 1000).
  spec.tracker.position_mm = V(800, 2100, 1000);
  spec.reflectors[0].acceptance_half_angle_rad = M_PI;
  ConfigurationCheck check = CheckConfiguration(model, Cell::Build(model, spec), kZero);
  EXPECT_EQ(check.reflectors[0].blocked_by, "link 3");
  EXPECT_THAT(check.failed_rules, ElementsAre(CellRule::kBeam));

  // Two reflectors: smr2 at (1000, -100, 1000), its tool capsule from the flange (800, 0, 1000). A tracker
  // along +x sees smr2, and smr1 only through smr2's tool capsule; smr1's own capsule never blocks it.
  spec.tracker.position_mm = V(2800, -100, 1000);
  spec.reflectors = {Smr("smr1", V(0, 0, 100), V(0, 0, 1), M_PI), Smr("smr2", V(200, 0, 100), V(0, 0, 1), M_PI)};
  check = CheckConfiguration(model, Cell::Build(model, spec), kZero);
  ASSERT_EQ(check.reflectors.size(), 2u);
  EXPECT_EQ(check.reflectors[0].id, "smr1");
  EXPECT_EQ(check.reflectors[0].blocked_by, "tool smr2");
  EXPECT_FALSE(check.reflectors[0].measurable);
  EXPECT_EQ(check.reflectors[1].blocked_by, "");
  EXPECT_TRUE(check.reflectors[1].measurable);
  EXPECT_NEAR(check.reflectors[1].distance_mm, 1800.0, 1e-9);
  EXPECT_NEAR(check.reflectors[1].incidence_rad, M_PI / 2, 1e-12);
  EXPECT_TRUE(check.feasible);  // one measurable reflector is enough
}

TEST(CellTest, SeveralReflectorsNameEveryConditionThatStopsOne) {
  const RobotModel model = Arm();
  CellSpec spec = ArmCell();
  // smr1 faces the tracker but is too close (1000 mm); smr2, on the far side of the forearm (1200 mm), faces
  // away (+y) and its beam crosses the forearm. No reflector is measurable, and each condition stops one.
  spec.tracker.position_mm = V(800, -1100, 1000);
  spec.tracker.min_distance_mm = 1050;
  spec.reflectors.push_back(Smr("smr2", V(0, 0, -100), V(0, 0, -1)));
  EXPECT_THAT(Rules(model, spec, kZero), ElementsAre(CellRule::kDistance, CellRule::kIncidence, CellRule::kBeam));
  const ConfigurationCheck check = CheckConfiguration(model, Cell::Build(model, spec), kZero);
  EXPECT_EQ(check.reflectors[0].blocked_by, "");
  EXPECT_EQ(check.reflectors[1].blocked_by, "link 3");
  EXPECT_EQ(check.reasons[2], "the beam to smr2 is blocked by link 3");
}

TEST(CellTest, ReportsTheClearancePairAndSkipsTheMount) {
  const RobotModel model = Arm();
  const Cell cell = Cell::Build(model, ArmCell());
  const ConfigurationCheck check = CheckConfiguration(model, cell, kZero);
  // Column / forearm: 300 mm between the axes, radii 50 and 30. The column stands on the floor (its sphere
  // at the base reaches 50 mm below z = 0, into the floor's top at -10) but never moves, so it is not
  // checked against obstacles.
  EXPECT_NEAR(check.min_clearance_mm, 220.0, 1e-9);
  EXPECT_EQ(check.clearance_pair, "link 1 / link 3");
  EXPECT_TRUE(check.feasible);
  ASSERT_EQ(check.reflectors.size(), 1u);
  EXPECT_EQ(check.reflectors[0].id, "smr1");
  EXPECT_NEAR(check.reflectors[0].distance_mm, 2000.0, 1e-9);
  EXPECT_NEAR(check.reflectors[0].incidence_rad, 0.0, 1e-12);

  // A moving link that reaches the floor is checked: raise the floor's top to 5 mm under the upper arm.
  CellSpec spec = ArmCell();
  spec.obstacles[0].max_mm.z() = 1000 - 40 - 5;
  const ConfigurationCheck raised = CheckConfiguration(model, Cell::Build(model, spec), kZero);
  EXPECT_THAT(raised.failed_rules, ElementsAre(CellRule::kObstacle));
  EXPECT_EQ(raised.clearance_pair, "link 2 / floor");
  EXPECT_NEAR(raised.min_clearance_mm, 5.0, 1e-9);
}

TEST(CellTest, PairsThatTouchByConstructionAreNotChecked) {
  // The UR5e's wrist keeps link 4 and link 6 (and link 5 and the tool) 99.7 mm apart whatever the joints:
  // with the radii of a bulky wrist they always overlap, which says nothing about a configuration.
  const RobotModel ur5e = Preset("ur5e");
  CellSpec spec;
  spec.tracker.position_mm = V(0, 0, 5000);
  spec.reflectors = {Smr("smr1", V(0, 0, 120), V(0, 0, 1), M_PI)};
  spec.link_radii_mm = {80, 70, 60, 50, 45, 40};
  spec.clearance_mm = 20;
  const Cell cell = Cell::Build(ur5e, spec);
  const FeasibilityCensus census = SampleFeasibility(ur5e, cell, 300, 5);
  EXPECT_GT(census.feasible, 0);
  Rng rng(9);
  for (int i = 0; i < 100; ++i) {
    const ConfigurationCheck check = CheckConfiguration(ur5e, cell, RandomConfiguration(ur5e, &rng));
    EXPECT_NE(check.clearance_pair, "link 4 / link 6");
    EXPECT_NE(check.clearance_pair, "link 5 / tool smr1");
  }
  // The PUMA's spherical wrist: links 5 and 6 have no length, so link 4 touches them and the tool.
  const RobotModel puma = Preset("puma560");
  spec.link_radii_mm.clear();
  const Cell puma_cell = Cell::Build(puma, spec);
  EXPECT_GT(SampleFeasibility(puma, puma_cell, 300, 5).feasible, 0);
}

TEST(CellTest, FastDecisionMatchesTheReportAndTheCensus) {
  const RobotModel model = Preset("ur5e");
  CellSpec spec;
  spec.tracker.position_mm = V(2500, -800, 300);
  spec.tracker.min_distance_mm = 1500;
  spec.tracker.max_distance_mm = 15000;
  spec.reflectors = {Smr("smr1", V(30, 0, 120), V(0, 0, 1)), Smr("smr2", V(-30, 0, 120), V(-0.5, 0, std::sqrt(0.75)))};
  spec.obstacles = {{"floor", V(-3000, -3000, -500), V(3000, 3000, -10)},
                    {"table", V(300, -600, -10), V(900, 600, 100)}};
  spec.clearance_mm = 20;
  const Cell cell = Cell::Build(model, spec);
  const RobotModel planning = cell.PlanningModel(model);
  int feasible = 0;
  for (std::uint64_t seed = 1; seed <= 1500; ++seed) {
    Rng rng(seed);
    const Eigen::VectorXd q = RandomConfiguration(planning, &rng);
    const ConfigurationCheck check = CheckConfiguration(model, cell, q);
    ASSERT_EQ(check.feasible, IsFeasible(model, cell, q)) << seed;
    feasible += check.feasible;
    // A census of one sample draws the same q: its per-rule counts are the report's rules.
    const FeasibilityCensus census = SampleFeasibility(model, cell, 1, seed);
    std::vector<CellRule> counted;
    for (const auto& [rule, count] : census.rejected_by) {
      if (count == 1) counted.push_back(rule);
    }
    ASSERT_EQ(counted, check.failed_rules) << seed;
  }
  EXPECT_GT(feasible, 0);  // the comparison saw both outcomes
  EXPECT_LT(feasible, 1500);
}

TEST(CellTest, CensusOfAFloorAtShoulderHeight) {
  // The arm facing +x (joint 1 within +-0.01 rad), joint 2 uniform in [-90, 90] deg and the forearm held
  // straight: the forearm's end is at
  // z = 1000 + 800 sin(q2) (+-5 mm for q3 in [-0.01, 0.01]). A floor whose top is at z = 900 then collides
  // (clearance 0) exactly when the 30 mm cap dips below it: sin(q2) < -70 / 800. The reflector accepts every
  // direction and the tracker is far along -y, so nothing else rejects.
  const RobotModel model = Arm();
  CellSpec spec = ArmCell();
  spec.clearance_mm = 0;
  spec.tracker = {V(0, -100000, 1000), 0.0, INFINITY};
  spec.reflectors[0].acceptance_half_angle_rad = M_PI;
  spec.obstacles = {{"floor", V(-3000, -3000, -500), V(3000, 3000, 900)}};
  spec.joint_min = Eigen::Vector3d(-0.01, -M_PI / 2, -0.01);
  spec.joint_max = Eigen::Vector3d(0.01, M_PI / 2, 0.01);
  const Cell cell = Cell::Build(model, spec);
  constexpr int kSamples = 4000;
  const FeasibilityCensus census = SampleFeasibility(model, cell, kSamples, 42);
  // Collision share (asin(-70 / 800) + pi / 2) / pi, moved by at most asin(5 / 800) / pi by the forearm.
  const double share = (std::asin(-70.0 / 800.0) + M_PI / 2) / M_PI;
  const double slack = std::asin(5.0 / 800.0) / M_PI + 4.0 * std::sqrt(share * (1 - share) / kSamples);
  EXPECT_EQ(census.samples, kSamples);
  ASSERT_EQ(census.rejected_by.size(), 6u);
  EXPECT_EQ(census.rejected_by[1].first, CellRule::kObstacle);
  const double obstacle_share = static_cast<double>(census.rejected_by[1].second) / kSamples;
  EXPECT_NEAR(obstacle_share, share, slack);
  EXPECT_EQ(census.dominant, CellRule::kObstacle);
  EXPECT_DOUBLE_EQ(census.dominant_share, obstacle_share);
  // Every rejected sample collides (a reflector under the floor's top is also blocked: counted as well).
  EXPECT_EQ(census.feasible + census.rejected_by[1].second, kSamples);
  EXPECT_EQ(census.rejected_by[0].second, 0);  // samples are drawn within the ranges
  EXPECT_LE(census.rejected_by[5].second, census.rejected_by[1].second);
  // The same seed gives the same census.
  EXPECT_EQ(SampleFeasibility(model, cell, kSamples, 42).feasible, census.feasible);
}

// ---- Build, defaults, the planning model --------------------------------------------------------------

std::vector<std::string> BuildErrorFields(const RobotModel& model, const CellSpec& spec) {
  try {
    Cell::Build(model, spec);
  } catch (const InvalidModelError& e) {
    std::vector<std::string> fields;
    for (const FieldError& error : e.errors()) fields.push_back(error.field);
    return fields;
  }
  ADD_FAILURE() << "the cell was accepted";
  return {};
}

TEST(CellBuildTest, NamesEveryBadFieldAsTheWireDoes) {
  const RobotModel model = Arm();
  CellSpec spec = ArmCell();
  spec.tracker.position_mm.x() = NAN;
  spec.tracker.min_distance_mm = -1;
  spec.reflectors = {Smr("smr1", V(0, 0, 100), V(0, 0, 2)), Smr("smr1", V(0, 0, 100), V(0, 0, 1), 0.0),
                     Smr("smr3", V(0, INFINITY, 0), V(0, 0, 1), 3.5)};
  spec.obstacles = {{"", V(0, 0, 0), V(1, 1, 1)}, {"box", V(0, 2, 0), V(1, 1, 1)}, {"box", V(0, 0, 0), V(1, 1, 1)}};
  spec.link_radii_mm = {50, 40, -5};
  spec.tool_radius_mm = NAN;
  spec.clearance_mm = -1;
  spec.joint_min = Eigen::Vector3d(-1, -4, 1);
  spec.joint_max = Eigen::Vector3d(1, 1, 1);
  EXPECT_THAT(BuildErrorFields(model, spec),
              UnorderedElementsAreArray(std::vector<std::string>{
                  "tracker.position_mm", "tracker.min_distance_mm", "reflectors[0].normal", "reflectors[1].id",
                  "reflectors[1].acceptance_half_angle_deg", "reflectors[2].position_mm",
                  "reflectors[2].acceptance_half_angle_deg", "obstacles[0].id", "obstacles[1].box", "obstacles[2].id",
                  "link_radii_mm[2]", "tool_radius_mm", "clearance_mm", "joint_ranges[1]", "joint_ranges[2]"}));
}

TEST(CellBuildTest, RefusesSizesAndPlacementsThatCannotWork) {
  const RobotModel model = Arm();
  CellSpec spec = ArmCell();
  spec.link_radii_mm = {50, 40};
  spec.joint_min = Eigen::Vector2d(-1, -1);
  spec.joint_max = Eigen::Vector2d(1, 1);
  spec.tracker.max_distance_mm = 1500;  // not above the minimum
  EXPECT_THAT(BuildErrorFields(model, spec), UnorderedElementsAreArray(std::vector<std::string>{
                                                 "link_radii_mm", "joint_ranges", "tracker.max_distance_mm"}));
  spec = ArmCell();
  spec.tracker.position_mm = V(0, 0, -100);  // in the floor
  EXPECT_THAT(BuildErrorFields(model, spec), ElementsAre("tracker.position_mm"));
  spec = ArmCell();
  spec.reflectors.push_back(Smr("smr2", V(0, 10, 200), V(0, 0, 1)));  // smr1 is 5 mm from its tool axis
  EXPECT_THAT(BuildErrorFields(model, spec), ElementsAre("reflectors[0].position_mm"));
  spec = ArmCell();
  spec.reflectors.assign(kMaxReflectors + 1, Smr("x", V(0, 0, 100), V(0, 0, 1)));
  for (int t = 0; t <= kMaxReflectors; ++t) {
    spec.reflectors[t].id = std::to_string(t);
    spec.reflectors[t].position_mm = V(400 * std::cos(t), 400 * std::sin(t), 0);
  }
  EXPECT_THAT(BuildErrorFields(model, spec), ElementsAre("reflectors"));
  // A normal a little off unit length is refused, not normalised.
  spec = ArmCell();
  spec.reflectors[0].normal = V(0, 0, 1 + 2e-6);
  EXPECT_THAT(BuildErrorFields(model, spec), ElementsAre("reflectors[0].normal"));
  spec.reflectors[0].normal = V(0, 0, 1 + 5e-7);
  EXPECT_NO_THROW(Cell::Build(model, spec));
}

TEST(CellBuildTest, FillsTheDefaults) {
  const RobotModel model = Preset("ur5e");
  const Cell cell = Cell::Build(model, CellSpec{});
  const CellSpec& spec = cell.spec();
  ASSERT_EQ(spec.reflectors.size(), 1u);
  EXPECT_EQ(spec.reflectors[0].id, "tool");
  EXPECT_TRUE(spec.reflectors[0].position_mm.isApprox(model.T_flange_tool().translation()));
  EXPECT_TRUE(spec.reflectors[0].normal.isApprox(model.T_flange_tool().linear().col(2)));
  EXPECT_EQ(spec.link_radii_mm, DefaultLinkRadii(model));
  EXPECT_EQ(spec.tool_radius_mm, spec.link_radii_mm.back());
  EXPECT_EQ(spec.joint_min, model.lower_limits());
  EXPECT_EQ(spec.joint_max, model.upper_limits());
}

TEST(CellBuildTest, DefaultLinkRadii) {
  EXPECT_EQ(DefaultLinkRadii(Preset("ur5e")), (std::vector<double>{60, 50, 40, 35, 35, 30}));
  EXPECT_EQ(DefaultLinkRadii(Preset("puma560")), (std::vector<double>{70, 60, 50, 45, 40, 35}));
  EXPECT_EQ(DefaultLinkRadii(Preset("grinder5")), (std::vector<double>{40, 40, 50, 50, 40}));
  // Other robots: the links' total length / 25, clamped to [10, 50] mm: 1800 mm of arm -> 50 mm.
  EXPECT_EQ(DefaultLinkRadii(Arm()), (std::vector<double>(3, 50.0)));
  RobotModelSpec small = Arm().spec();
  small.joints[0].d_mm = 100;
  small.joints[1].a_mm = 100;
  small.joints[2].a_mm = 50;
  EXPECT_EQ(DefaultLinkRadii(RobotModel::Build(small)), (std::vector<double>(3, 10.0)));
}

TEST(CellBuildTest, PlanningModelHasTheRanges) {
  const RobotModel model = Arm();
  CellSpec spec = ArmCell();
  spec.joint_min = Eigen::Vector3d(-1, -0.5, -M_PI - 1e-12);  // a hair outside: a degree conversion's rounding
  spec.joint_max = Eigen::Vector3d(1, 0.5, 2);
  const Cell cell = Cell::Build(model, spec);
  const RobotModel planning = cell.PlanningModel(model);
  EXPECT_EQ(planning.lower_limits(), Eigen::Vector3d(-1, -0.5, -M_PI));
  EXPECT_EQ(planning.upper_limits(), Eigen::Vector3d(1, 0.5, 2));
  EXPECT_EQ(planning.name(), model.name());
  // Same kinematics.
  const Eigen::VectorXd q = Eigen::Vector3d(0.3, -0.2, 1.1);
  EXPECT_TRUE(ForwardKinematics(planning, q).isApprox(ForwardKinematics(model, q)));
  EXPECT_THROW(cell.PlanningModel(Preset("ur5e")), std::invalid_argument);
  EXPECT_THROW(IsFeasible(Preset("ur5e"), cell, Eigen::VectorXd::Zero(6)), std::invalid_argument);
  EXPECT_THROW(CheckConfiguration(model, cell, Eigen::VectorXd::Zero(2)), std::invalid_argument);
  EXPECT_THROW(SampleFeasibility(Preset("ur5e"), cell, 10, 1), std::invalid_argument);
  EXPECT_THROW(SampleFeasibility(model, cell, 0, 1), std::invalid_argument);
}

TEST(CellBuildTest, RuleNames) {
  EXPECT_STREQ(ToString(CellRule::kJointRange), "joint_range");
  EXPECT_STREQ(ToString(CellRule::kObstacle), "obstacle");
  EXPECT_STREQ(ToString(CellRule::kSelfCollision), "self_collision");
  EXPECT_STREQ(ToString(CellRule::kDistance), "distance");
  EXPECT_STREQ(ToString(CellRule::kIncidence), "incidence");
  EXPECT_STREQ(ToString(CellRule::kBeam), "beam");
}

// ---- Preset cells -------------------------------------------------------------------------------------

// docs/cells.md's band: each preset cell leaves 3 % .. 7 % of its joint ranges feasible (the 30 degree
// acceptance cone is 6.7 % of all directions, the ceiling for a reflector whose normal the joints spread evenly).
class PresetCellTest : public ::testing::TestWithParam<std::string> {};

TEST_P(PresetCellTest, LeavesADocumentedShareFeasible) {
  const RobotModel model = Preset(GetParam());
  const Cell cell = Cell::Build(model, PresetCellSpec(GetParam()));
  const FeasibilityCensus census = SampleFeasibility(model, cell, 4000, 11);
  const double share = static_cast<double>(census.feasible) / census.samples;
  EXPECT_GE(share, 0.03) << GetParam();
  EXPECT_LE(share, 0.07) << GetParam();
  // The tracker is placed so that its distance window never rejects: the reach stays beyond 1.5 m.
  EXPECT_EQ(census.rejected_by[static_cast<int>(CellRule::kDistance)].second, 0);
  // Every obstacle and the default reflector are there.
  EXPECT_EQ(cell.spec().obstacles.front().id, "floor");
  ASSERT_EQ(cell.spec().reflectors.size(), 1u);
  EXPECT_EQ(cell.spec().reflectors[0].id, "tool");
}

TEST_P(PresetCellTest, PlannersFindFeasiblePlans) {
  const RobotModel nominal = Preset(GetParam());
  const Cell cell = Cell::Build(nominal, PresetCellSpec(GetParam()));
  const RobotModel model = cell.PlanningModel(nominal);
  ObservabilityOptions o;
  o.measurement_type = MeasurementType::kPose;
  o.parameters = FindIdentifiableParameters(model, o.measurement_type).identifiable;
  const FeasibilityPredicate feasible = [&](const Eigen::VectorXd& q) { return IsFeasible(nominal, cell, q); };
  SolisWetsOptions s = SolisWetsOptions::Paper();
  s.feasible = feasible;
  ExchangeOptions e;
  e.num_candidates = 200;
  e.feasible = feasible;
  for (const Plan& plan : {PlanSolisWets(model, 10, o, s), PlanExchange(model, 10, o, e)}) {
    EXPECT_NE(plan.summary.termination, Termination::kFailure) << plan.summary.message;
    ASSERT_EQ(plan.configurations.size(), 10u);
    // Re-checked with the full report rather than the predicate the planner used.
    for (const Eigen::VectorXd& q : plan.configurations) EXPECT_TRUE(CheckConfiguration(nominal, cell, q).feasible);
  }
}

INSTANTIATE_TEST_SUITE_P(Presets, PresetCellTest, ::testing::Values("grinder5", "puma560", "ur5e"));

TEST(PresetCellSpecTest, UnknownRobotThrows) { EXPECT_THROW(PresetCellSpec("nope"), std::invalid_argument); }

}  // namespace
}  // namespace robocal
