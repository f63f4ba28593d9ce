// Preset robot specs. Dimensions and their sources are documented in docs/robots.md.
#include "robocal/core/presets.h"

#include <cmath>
#include <stdexcept>
#include <vector>

#include "robocal/core/units.h"

namespace robocal {
namespace {


JointSpec DhJoint(const std::string& name, double a_mm, double alpha_rad, double d_mm, double theta_rad,
                  double min_deg, double max_deg) {
  JointSpec j;
  j.name = name;
  j.type = JointType::kRevolute;
  j.a_mm = a_mm;
  j.alpha_rad = alpha_rad;
  j.d_mm = d_mm;
  j.theta_rad = theta_rad;
  j.min = min_deg * kRadPerDeg;
  j.max = max_deg * kRadPerDeg;
  return j;
}

// Plausible mass properties (documented as such in docs/robots.md): link i's mass at the midpoint between its
// joint's origin and the next joint's (the flange for the last), in link frame i. Enough for the compliance model,
// whose compliances absorb an error of scale in the masses; a real robot's figures come from its URDF or datasheet.
void SetLinkMassesAtMidpoints(RobotModelSpec* spec, const std::vector<double>& masses_kg) {
  const RobotModel model = RobotModel::Build(*spec);
  const int n = model.num_joints();
  for (int i = 0; i < n; ++i) {
    // Link frame i in joint i's frame after its motion is model.link_frame(i); the next joint's origin there is
    // the next fixed transform's (or the flange's) translation.
    const Transform to_link = model.link_frame(i).inverse();
    const Eigen::Vector3d next = (i + 1 < n ? model.fixed_transform(i + 1) : model.T_lastjoint_flange()).translation();
    spec->joints[i].mass_kg = masses_kg[i];
    spec->joints[i].com_mm = 0.5 * (to_link * Eigen::Vector3d::Zero() + to_link * next);
  }
}

// The tool used for calibration on the 6R presets: a reflector nest 120 mm out along the flange z axis and
// 30 mm off it, so that every wrist joint moves the measured point (a point on the last axis would leave
// joint 6 unobservable from positions).
Transform CalibrationTool6R() { return Translation(30.0, 0.0, 120.0); }

RobotModelSpec Puma560() {
  // Peter Corke, Robotics Toolbox, mdl_puma560 (standard DH, metres there, mm here; joint limits qlim).
  RobotModelSpec s;
  s.name = "puma560";
  s.convention = GeometryConvention::kStandardDh;
  s.joints = {
      DhJoint("joint1", 0.0, M_PI / 2, 0.0, 0.0, -160, 160),     DhJoint("joint2", 431.8, 0.0, 0.0, 0.0, -45, 225),
      DhJoint("joint3", 20.3, -M_PI / 2, 150.05, 0.0, -225, 45), DhJoint("joint4", 0.0, M_PI / 2, 431.8, 0.0, -110, 170),
      DhJoint("joint5", 0.0, -M_PI / 2, 0.0, 0.0, -100, 100),    DhJoint("joint6", 0.0, 0.0, 0.0, 0.0, -266, 266),
  };
  s.T_flange_tool = CalibrationTool6R();
  // Link masses and centres of mass of the same model (Armstrong, Khatib & Burdick 1986, as Corke tabulates
  // them; DH frame i, mm).
  const double mass[6] = {0.0, 17.4, 4.8, 0.82, 0.34, 0.09};
  const double com[6][3] = {{0, 0, 0}, {-363.8, 6, 227.5}, {-20.3, -14.1, 70}, {0, 19, 0}, {0, 0, 0}, {0, 0, 32}};
  for (int i = 0; i < 6; ++i) {
    s.joints[i].mass_kg = mass[i];
    s.joints[i].com_mm = Eigen::Vector3d(com[i][0], com[i][1], com[i][2]);
  }
  return s;
}

RobotModelSpec Ur5e() {
  // Universal Robots' published DH parameters for the UR5e (standard DH).
  RobotModelSpec s;
  s.name = "ur5e";
  s.convention = GeometryConvention::kStandardDh;
  s.joints = {
      DhJoint("joint1", 0.0, M_PI / 2, 162.5, 0.0, -360, 360),  DhJoint("joint2", -425.0, 0.0, 0.0, 0.0, -360, 360),
      DhJoint("joint3", -392.2, 0.0, 0.0, 0.0, -360, 360),      DhJoint("joint4", 0.0, M_PI / 2, 133.3, 0.0, -360, 360),
      DhJoint("joint5", 0.0, -M_PI / 2, 99.7, 0.0, -360, 360),  DhJoint("joint6", 0.0, 0.0, 99.6, 0.0, -360, 360),
  };
  s.T_flange_tool = CalibrationTool6R();
  // Universal Robots' published link masses (kg); centres of mass at the links' midpoints (plausible).
  SetLinkMassesAtMidpoints(&s, {3.761, 8.058, 2.846, 1.37, 1.3, 0.365});
  return s;
}

RobotModelSpec Grinder5() {
  // A gantry grinding robot as in the paper: prismatic X, Y, Z (mutually perpendicular), then a C axis about
  // the vertical and an A axis about the horizontal X direction whose axes intersect perpendicularly. The
  // paper gives no dimensions; these are plausible for a cell of this kind (docs/robots.md).
  // Joint frames are placed in the world at q = 0, and each fixed transform is the relative transform.
  struct Frame {
    const char* name;
    JointType type;
    Eigen::Vector3d origin_mm;
    Eigen::Matrix3d rotation;  // its z column is the joint axis
    double min, max;
  };
  const Frame frames[] = {
      {"X", JointType::kPrismatic, {0, 0, 0}, RotY(M_PI / 2), 0.0, 800.0},
      {"Y", JointType::kPrismatic, {0, 0, 200}, RotX(-M_PI / 2), 0.0, 600.0},
      {"Z", JointType::kPrismatic, {0, 150, 200}, Eigen::Matrix3d::Identity(), 0.0, 400.0},
      {"C", JointType::kRevolute, {0, 150, -100}, Eigen::Matrix3d::Identity(), -180 * kRadPerDeg, 180 * kRadPerDeg},
      {"A", JointType::kRevolute, {0, 150, -220}, RotY(M_PI / 2), -110 * kRadPerDeg, 110 * kRadPerDeg},
  };
  RobotModelSpec s;
  s.name = "grinder5";
  s.convention = GeometryConvention::kTransform;
  Transform previous = Transform::Identity();
  for (const Frame& f : frames) {
    Transform world = Rotation(f.rotation);
    world.translation() = f.origin_mm;
    const Transform fixed = previous.inverse() * world;
    JointSpec j;
    j.name = f.name;
    j.type = f.type;
    j.xyz_mm = fixed.translation();
    j.rpy_rad = RpyFromRotation(fixed.linear());
    j.min = f.min;
    j.max = f.max;
    s.joints.push_back(j);
    previous = world;
  }
  // Spindle: tool centre point 150 mm below the A axis at q = 0 and 20 mm off the C axis, tool z pointing down.
  Transform world_tool = Rotation(RotX(M_PI));
  world_tool.translation() = Eigen::Vector3d(20, 150, -370);
  s.T_flange_tool = previous.inverse() * world_tool;
  // Plausible masses (kg) of the carriages, the C head and the spindle; the spindle's centre of mass halfway to
  // the tool centre point, so that gravity loads the A axis.
  SetLinkMassesAtMidpoints(&s, {120.0, 80.0, 60.0, 25.0, 15.0});
  s.joints[4].com_mm = 0.5 * s.T_flange_tool.translation();
  return s;
}

}  // namespace

std::vector<std::string> PresetNames() { return {"grinder5", "puma560", "ur5e"}; }

std::string PresetDescription(const std::string& name) {
  if (name == "grinder5") {
    return "5-axis grinding robot of the paper (PPPRR: X, Y, Z slides, C and A rotary axes), plausible "
           "dimensions, 150 mm spindle tool";
  }
  if (name == "puma560") return "PUMA 560, standard DH after Corke's Robotics Toolbox, 120 mm calibration tool";
  if (name == "ur5e") return "Universal Robots UR5e, manufacturer's standard DH, 120 mm calibration tool";
  throw std::invalid_argument("unknown preset '" + name + "'");
}

RobotModelSpec PresetSpec(const std::string& name) {
  if (name == "grinder5") return Grinder5();
  if (name == "puma560") return Puma560();
  if (name == "ur5e") return Ur5e();
  throw std::invalid_argument("unknown preset '" + name + "' (presets: grinder5, puma560, ur5e)");
}

RobotModel Preset(const std::string& name) { return RobotModel::Build(PresetSpec(name)); }

}  // namespace robocal
