// The ISO 9283 pose test's geometry and characteristics against hand-computed cases.
#include "robocal/core/iso9283.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "robocal/core/compensation.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/transforms.h"

namespace robocal {
namespace {

Iso9283Shot Shot(int pose, int cycle, const Eigen::Vector3d& attained, const Eigen::Vector3d& commanded,
                 double attained_rz = 0.0) {
  Iso9283Shot s;
  s.pose = pose;
  s.cycle = cycle;
  s.attained = Translation(attained.x(), attained.y(), attained.z()) * Rotation(RotZ(attained_rz));
  s.commanded = Translation(commanded.x(), commanded.y(), commanded.z());
  return s;
}

TEST(Iso9283Test, PosesLieOnTheDiagonalPlaneAtATenthOfTheDiagonalFromTheCorners) {
  const Iso9283Cube cube{Eigen::Vector3d(100, 200, 300), 100.0};
  const auto p = Iso9283Positions(cube);
  EXPECT_TRUE(p[0].isApprox(Eigen::Vector3d(100, 200, 300)));
  // P2 = centre + 0.8 * 50 * (-1, -1, 1), by hand.
  EXPECT_TRUE(p[1].isApprox(Eigen::Vector3d(60, 160, 340)));
  EXPECT_TRUE(p[2].isApprox(Eigen::Vector3d(60, 240, 340)));
  EXPECT_TRUE(p[3].isApprox(Eigen::Vector3d(140, 240, 260)));
  EXPECT_TRUE(p[4].isApprox(Eigen::Vector3d(140, 160, 260)));
  // Each at 10 % of the diagonal (100 sqrt 3) from its corner, and the corners on one plane: x + z = 400.
  const auto corners = CubeCorners(cube);
  const Eigen::Vector3d c2 = corners[4];  // (-,-,+)
  EXPECT_NEAR((p[1] - c2).norm(), 0.1 * 100.0 * std::sqrt(3.0), 1e-9);
  for (int k = 0; k < 5; ++k) EXPECT_NEAR(p[k].x() + p[k].z(), 400.0, 1e-9) << k;
  // P2 and P4 face each other across P1.
  EXPECT_TRUE((p[1] + p[3]).isApprox(2.0 * p[0]));
  EXPECT_TRUE((p[2] + p[4]).isApprox(2.0 * p[0]));
  EXPECT_THROW(Iso9283Positions({Eigen::Vector3d(0, 0, 0), 0.0}), std::invalid_argument);
  EXPECT_EQ(Iso9283PoseName(2), "P3");
  EXPECT_EQ(Iso9283PoseIndex("P5"), 4);
  EXPECT_EQ(Iso9283PoseIndex("P6"), -1);
}

TEST(Iso9283Test, PoseAccuracyAndRepeatabilityAsComputedByHand) {
  const Eigen::Vector3d c(0, 0, 0);
  // Deviations (0,0,0), (3,0,0), (0,0,0): mean (1,0,0); l = 1, 2, 1; mean l 4/3, S_l = sqrt(1/3).
  const std::vector<Iso9283Shot> shots = {Shot(0, 1, {0, 0, 0}, c, 0.001), Shot(0, 2, {3, 0, 0}, c, 0.003),
                                          Shot(0, 3, {0, 0, 0}, c, 0.002)};
  const Iso9283Result r = Iso9283Analyse(shots, true);
  ASSERT_EQ(r.poses.size(), 1u);
  const Iso9283PoseFigures& f = r.poses[0];
  EXPECT_EQ(f.cycles, 3);
  EXPECT_EQ(r.cycles, 3);
  EXPECT_TRUE(f.ap_xyz_mm.isApprox(Eigen::Vector3d(1, 0, 0)));
  EXPECT_NEAR(f.ap_mm, 1.0, 1e-12);
  EXPECT_NEAR(f.mean_l_mm, 4.0 / 3.0, 1e-12);
  EXPECT_NEAR(f.s_l_mm, std::sqrt(1.0 / 3.0), 1e-12);
  EXPECT_NEAR(f.rp_l_mm, 4.0 / 3.0 + 3.0 * std::sqrt(1.0 / 3.0), 1e-12);
  // About z: 1, 3, 2 mrad: AP_c 2 mrad, S_c 1 mrad, RP_c 3 mrad; nothing about x and y.
  EXPECT_NEAR(f.ap_abc_rad.z(), 0.002, 1e-12);
  EXPECT_NEAR(f.rp_abc_rad.z(), 0.003, 1e-12);
  EXPECT_NEAR(f.ap_abc_rad.x(), 0.0, 1e-15);
  EXPECT_NEAR(f.rp_abc_rad.y(), 0.0, 1e-15);
  // Without orientation no orientation figure; one cycle has no repeatability.
  const Iso9283Result positions = Iso9283Analyse(shots, false);
  EXPECT_TRUE(std::isnan(positions.poses[0].ap_abc_rad.z()));
  const Iso9283Result once = Iso9283Analyse({shots[1]}, true);
  EXPECT_NEAR(once.poses[0].ap_mm, 3.0, 1e-12);
  EXPECT_TRUE(std::isnan(once.poses[0].rp_l_mm));
  EXPECT_TRUE(std::isnan(once.poses[0].rp_abc_rad.z()));
}

TEST(Iso9283Test, DistanceAccuracyAndRepeatabilityAsComputedByHand) {
  const Eigen::Vector3d c1(0, 0, 0), c2(100, 0, 0);
  std::vector<Iso9283Shot> shots = {Shot(0, 1, {0, 0, 0}, c1),     Shot(0, 2, {3, 0, 0}, c1),
                                    Shot(0, 3, {0, 0, 0}, c1),     Shot(1, 1, {100.5, 0, 0}, c2),
                                    Shot(1, 2, {101, 0, 0}, c2),   Shot(1, 3, {100, 0, 0}, c2),
                                    Shot(2, 1, {0, 50, 0}, {0, 50, 0})};
  const Iso9283Result r = Iso9283Analyse(shots, false);
  ASSERT_EQ(r.poses.size(), 3u);
  // P1-P2 only: P4 was not measured. |D| - |D_c| per cycle: 0.5, -2, 0.
  ASSERT_EQ(r.distances.size(), 1u);
  const Iso9283Distance& d = r.distances[0];
  EXPECT_EQ(d.from, 0);
  EXPECT_EQ(d.to, 1);
  EXPECT_EQ(d.cycles, 3);
  EXPECT_NEAR(d.command_mm, 100.0, 1e-12);
  EXPECT_NEAR(d.ad_mm, -0.5, 1e-12);
  EXPECT_NEAR(d.rd_mm, 3.0 * std::sqrt(1.75), 1e-12);
  // D - D_c along x per cycle: -0.5, 2, 0.
  EXPECT_TRUE(d.ad_xyz_mm.isApprox(Eigen::Vector3d(0.5, 0, 0)));
}

TEST(Iso9283Test, RefusesWhatIsNoTest) {
  const Eigen::Vector3d c(0, 0, 0);
  EXPECT_THROW(Iso9283Analyse({}, true), std::invalid_argument);
  EXPECT_THROW(Iso9283Analyse({Shot(5, 1, c, c)}, true), std::invalid_argument);
  EXPECT_THROW(Iso9283Analyse({Shot(0, 0, c, c)}, true), std::invalid_argument);
  EXPECT_THROW(Iso9283Analyse({Shot(0, 1, c, c), Shot(0, 1, c, c)}, true), std::invalid_argument);
  Iso9283Shot bad = Shot(0, 1, c, c);
  bad.attained.translation().x() = std::nan("");
  EXPECT_THROW(Iso9283Analyse({bad}, true), std::invalid_argument);
}

TEST(Iso9283Test, LargestCubeHoldsEveryPoseAndCornerOnOneBranch) {
  for (const char* name : {"puma560", "ur5e"}) {
    SCOPED_TRACE(name);
    const RobotModel model = Preset(name);
    const Eigen::Matrix3d down = RotX(M_PI);  // the tool pointing down
    Iso9283CubeSearchOptions options;
    options.centres = 40;
    options.seed = 7;
    const Iso9283CubeSearch search = LargestIso9283Cube(model, down, options);
    ASSERT_TRUE(search.found) << search.message;
    EXPECT_GT(search.cube.size_mm, 100.0);
    EXPECT_EQ(search.cube.size_mm, std::floor(search.cube.size_mm));
    // Every pose is reached on the nominal robot on the search's branch, exactly.
    const Calibration nominal = NominalCalibration(model);
    for (const Transform& pose : Iso9283Poses(search.cube, down)) {
      CompensationTarget target;
      target.pose = pose;
      target.frame = TargetFrame::kBase;
      target.configuration = search.configuration;
      const CompensationResult r = Compensate(nominal, model, target);
      ASSERT_EQ(r.termination, Termination::kConvergence) << r.message;
      EXPECT_TRUE(r.configuration && *r.configuration == search.configuration);
      const Transform reached = model.T_world_base().inverse() * ForwardKinematics(model, r.joints);
      EXPECT_LT((reached.translation() - pose.translation()).norm(), 1e-6);
    }
    // The same seed finds the same cube; a cell that allows nothing, none.
    const Iso9283CubeSearch again = LargestIso9283Cube(model, down, options);
    EXPECT_EQ(again.cube.size_mm, search.cube.size_mm);
    EXPECT_TRUE(again.cube.center_mm == search.cube.center_mm);
    options.feasible = [](const Eigen::VectorXd&) { return false; };
    EXPECT_FALSE(LargestIso9283Cube(model, down, options).found);
  }
  EXPECT_THROW(LargestIso9283Cube(Preset("grinder5"), Eigen::Matrix3d::Identity()), std::invalid_argument);
}

}  // namespace
}  // namespace robocal
