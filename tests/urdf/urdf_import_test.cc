// URDF import: forward kinematics of the imported robot against the URDF's own kinematics (computed here from
// liburdfdom's parsed joints, independently of the importer's mapping), for URDFs written to cover each case
// and for public robot descriptions; and every refusal naming its field and element.
#include "robocal/urdf/urdf_import.h"
#include "robocal/urdf/urdf_export.h"

#include <urdf_parser/urdf_parser.h>

#include <Eigen/Geometry>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "robocal/api/error.h"
#include "robocal/core/joint_errors.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"

namespace robocal {
namespace {

using ::testing::HasSubstr;

// Two fixed joints before the first moving one, axes along z, -y, x (prismatic) and a tilted one (continuous),
// a fixed joint between two moving ones and two after the last (the flange, then the tip).
const char* const kCoverage = R"(<?xml version="1.0"?>
<robot name="Cover_Bot 1">
  <link name="world"/>
  <link name="base_link"/>
  <link name="plate"/>
  <link name="l1"/> <link name="l2"/> <link name="l2b"/> <link name="l3"/> <link name="l4"/>
  <link name="flange"/> <link name="tool0"/>
  <joint name="world_joint" type="fixed"><parent link="world"/><child link="base_link"/>
    <origin xyz="1 2 3" rpy="0.1 0.2 0.3"/></joint>
  <joint name="plate_joint" type="fixed"><parent link="base_link"/><child link="plate"/>
    <origin xyz="0 0 0.05" rpy="0 0 1.5707963267948966"/></joint>
  <joint name="shoulder" type="revolute"><parent link="plate"/><child link="l1"/>
    <origin xyz="0 0 0.3" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3.14159" upper="3.14159" effort="1" velocity="1"/></joint>
  <joint name="elbow" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.1 0.2 0.4" rpy="1.5707963267948966 0 0.4"/><axis xyz="0 -1 0"/>
    <limit lower="-1.5" upper="2.0" effort="1" velocity="1"/></joint>
  <joint name="offset" type="fixed"><parent link="l2"/><child link="l2b"/>
    <origin xyz="0.35 0 0.02" rpy="0 -0.3 0"/></joint>
  <joint name="slide" type="prismatic"><parent link="l2b"/><child link="l3"/>
    <origin xyz="0 0.05 0" rpy="0 0 0"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.5" effort="1" velocity="1"/></joint>
  <joint name="wrist" type="continuous"><parent link="l3"/><child link="l4"/>
    <origin xyz="0.05 0 0.1" rpy="0.2 -0.1 0.7"/><axis xyz="0 0.6 0.8"/></joint>
  <joint name="to_flange" type="fixed"><parent link="l4"/><child link="flange"/>
    <origin xyz="0 0 0.08" rpy="3.141592653589793 0 0"/></joint>
  <joint name="to_tool0" type="fixed"><parent link="flange"/><child link="tool0"/>
    <origin xyz="0.01 0 0.02" rpy="0 1.5707963267948966 0"/></joint>
</robot>
)";

// Axes next to -z (their alignment is nearly half a turn), origins next to the gimbal lock, a huge axis.
const char* const kNearSingular = R"(<robot name="near">
  <link name="l0"/><link name="l1"/><link name="l2"/><link name="l3"/><link name="l4"/><link name="l5"/>
  <joint name="a" type="revolute"><parent link="l0"/><child link="l1"/>
    <origin xyz="0.1 0 0.2" rpy="0.3 1.5707962267948965 0.5"/><axis xyz="0 1e-5 -1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="b" type="prismatic"><parent link="l1"/><child link="l2"/>
    <origin xyz="0 0.3 1" rpy="0 -1.5707964267948966 0"/><axis xyz="0 1e-9 -1"/>
    <limit lower="0" upper="0.4" effort="1" velocity="1"/></joint>
  <joint name="c" type="revolute"><parent link="l2"/><child link="l3"/>
    <origin xyz="0.2 0 0" rpy="0 0 0"/><axis xyz="1e154 1e154 0"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="d" type="continuous"><parent link="l3"/><child link="l4"/>
    <origin xyz="0 0 0.3" rpy="0 0 0"/><axis xyz="3e-154 0 0"/></joint>
  <joint name="e" type="fixed"><parent link="l4"/><child link="l5"/><origin xyz="0 0 1" rpy="0 0 0"/></joint>
</robot>
)";

api::ImportUrdfRequest Request(const std::string& xml, const std::string& base, const std::string& tip) {
  api::ImportUrdfRequest r;
  r.urdf = xml;
  r.base_link = base;
  r.tip_link = tip;
  return r;
}

Transform PoseOf(const ::urdf::Pose& p) {
  double x, y, z, w;
  p.rotation.getQuaternion(x, y, z, w);
  Transform t = Transform::Identity();
  t.linear() = Eigen::Quaterniond(w, x, y, z).toRotationMatrix();
  t.translation() = 1000.0 * Eigen::Vector3d(p.position.x, p.position.y, p.position.z);
  return t;
}

// The URDF's kinematics from base to tip: origin, then the motion about / along the axis, joint by joint.
// q in robocal's units (rad, mm), one value per moving joint in chain order.
Transform UrdfForward(const ::urdf::ModelInterface& model, const std::string& base, const std::string& tip,
                      const Eigen::VectorXd& q) {
  std::vector<::urdf::JointConstSharedPtr> chain;
  for (::urdf::LinkConstSharedPtr l = model.getLink(tip); l->name != base; l = model.getLink(l->parent_joint->parent_link_name)) {
    chain.insert(chain.begin(), l->parent_joint);
  }
  Transform t = Transform::Identity();
  int i = 0;
  for (const auto& j : chain) {
    t = t * PoseOf(j->parent_to_joint_origin_transform);
    if (j->type == ::urdf::Joint::FIXED) continue;
    const Eigen::Vector3d raw(j->axis.x, j->axis.y, j->axis.z);
    const Eigen::Vector3d axis = (raw / raw.cwiseAbs().maxCoeff()).normalized();  // 1e154 and 3e-154 too
    Transform motion = Transform::Identity();
    if (j->type == ::urdf::Joint::PRISMATIC) {
      motion.translation() = axis * q[i];
    } else {
      motion.linear() = Eigen::AngleAxisd(q[i], axis).toRotationMatrix();
    }
    t = t * motion;
    ++i;
  }
  return t;
}

// Largest position (mm) and rotation (rad) difference between the imported robot and the URDF over random
// configurations within the limits.
std::pair<double, double> CompareForward(const std::string& xml, const std::string& base, const std::string& tip,
                                         int* joints = nullptr) {
  const api::RegisterRobotRequest definition = urdf::ImportUrdf(Request(xml, base, tip));
  const RobotModel robot = api::BuildModel(definition);
  if (joints) *joints = robot.num_joints();
  const ::urdf::ModelInterfaceSharedPtr model = ::urdf::parseURDF(xml);
  Rng rng(7);
  KinematicsWorkspace ws(robot);
  double position = 0.0, rotation = 0.0;
  for (int n = 0; n < 200; ++n) {
    const Eigen::VectorXd q = RandomConfiguration(robot, &rng);
    const Transform ours = ForwardKinematics(robot, q, Eigen::VectorXd(), &ws);
    const Transform theirs = UrdfForward(*model, base, tip, q);
    position = std::max(position, (ours.translation() - theirs.translation()).norm());
    rotation = std::max(rotation, Eigen::AngleAxisd(ours.linear().transpose() * theirs.linear()).angle());
  }
  return {position, rotation};
}

TEST(UrdfImportTest, ForwardKinematicsEqualTheUrdfsOnEveryKindOfJoint) {
  int joints = 0;
  const auto [position, rotation] = CompareForward(kCoverage, "world", "tool0", &joints);
  EXPECT_EQ(joints, 4);
  EXPECT_LT(position, 1e-9);
  EXPECT_LT(rotation, 1e-12);
  const auto [near_position, near_rotation] = CompareForward(kNearSingular, "l0", "l5", &joints);
  EXPECT_EQ(joints, 4);
  EXPECT_LT(near_position, 1e-9);
  EXPECT_LT(near_rotation, 1e-12);
  // From an inner link down to another: the chain between them only.
  const auto [inner_position, inner_rotation] = CompareForward(kCoverage, "l1", "l4", &joints);
  EXPECT_EQ(joints, 3);
  EXPECT_LT(inner_position, 1e-9);
  EXPECT_LT(inner_rotation, 1e-12);
}

std::string ReadData(const std::string& name) {
  std::ifstream in(std::string(ROBOCAL_URDF_DATA) + "/" + name);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// Public robot descriptions (licences beside the files in tests/data/urdf): the UR5 (axes along y, rotated
// origins, a root link above base_link) and the ABB IRB 2400 (axes along x and y, a rotated tool0).
TEST(UrdfImportTest, PublicRobotDescriptionsMatchTheirKinematics) {
  for (const auto& [file, base, tip] : {std::tuple{"ur5_robot.urdf", "base_link", "tool0"},
                                        std::tuple{"ur5_robot.urdf", "world", "ee_link"},
                                        std::tuple{"irb2400.urdf", "base_link", "tool0"}}) {
    SCOPED_TRACE(file);
    const std::string xml = ReadData(file);
    ASSERT_FALSE(xml.empty());
    int joints = 0;
    const auto [position, rotation] = CompareForward(xml, base, tip, &joints);
    EXPECT_EQ(joints, 6);
    RecordProperty(std::string(file) + "_" + tip + "_position_mm", std::to_string(position));
    EXPECT_LT(position, 1e-9);
    EXPECT_LT(rotation, 1e-12);
  }
  const api::RegisterRobotRequest ur5 = urdf::ImportUrdf(Request(ReadData("ur5_robot.urdf"), "base_link", "tool0"));
  EXPECT_EQ(ur5.id, "ur5");
  EXPECT_EQ(ur5.joints[0].name, "shoulder_pan_joint");
  EXPECT_EQ(ur5.joints[5].name, "wrist_3_joint");
  EXPECT_NEAR(ur5.joints[0].max, 360.0, 1e-5);  // 6.2831853 rad
}

// The gravity torques of an imported robot are minus the derivatives of the potential energy of the URDF's own
// links (each <inertial> mass at its <origin>, placed by the URDF's kinematics): the masses, centres of mass and
// frames the import wrote hold.
TEST(UrdfImportTest, InertialsGiveTheGravityTorquesOfTheUrdfsLinks) {
  for (const char* file : {"ur10_robot.urdf", "ur5_robot.urdf"}) {
    SCOPED_TRACE(file);
    const std::string xml = ReadData(file);
    const RobotModel robot = api::BuildModel(urdf::ImportUrdf(Request(xml, "base_link", "tool0")));
    ASSERT_TRUE(robot.has_masses());
    const ::urdf::ModelInterfaceSharedPtr model = ::urdf::parseURDF(xml);
    std::vector<::urdf::LinkSharedPtr> links;
    model->getLinks(links);
    const auto below_base = [&](const ::urdf::Link& link) {
      for (::urdf::LinkConstSharedPtr l = model->getLink(link.name); l; ) {
        if (l->name == "base_link") return true;
        if (!l->parent_joint) return false;
        l = model->getLink(l->parent_joint->parent_link_name);
      }
      return false;
    };
    const auto potential = [&](const Eigen::VectorXd& q) {  // N*mm
      double v = 0.0;
      for (const auto& link : links) {
        if (!link->inertial || link->name == "base_link" || !below_base(*link)) continue;
        const Eigen::Vector3d com = UrdfForward(*model, "base_link", link->name, q) * PoseOf(link->inertial->origin).translation();
        v += link->inertial->mass * kStandardGravity * com.z();
      }
      return v;
    };
    Rng rng(4);
    for (int k = 0; k < 10; ++k) {
      const Eigen::VectorXd q = RandomConfiguration(robot, &rng);
      const Eigen::VectorXd tau = GravityTorques(robot, q, Payload());
      for (int i = 0; i < 6; ++i) {
        Eigen::VectorXd plus = q, minus = q;
        plus[i] += 1e-6;
        minus[i] -= 1e-6;
        const double expected = -(potential(plus) - potential(minus)) / 2e-6 / 1000.0;
        EXPECT_NEAR(tau[i], expected, 1e-5 * (1.0 + tau.cwiseAbs().maxCoeff())) << "joint " << i;
      }
    }
  }
}

TEST(UrdfImportTest, KeepsNamesAndConvertsLimitsAndUnits) {
  const api::RegisterRobotRequest d = urdf::ImportUrdf(Request(kCoverage, "world", "tool0"));
  EXPECT_EQ(d.id, "cover_bot_1");  // from <robot name="Cover_Bot 1">
  EXPECT_EQ(d.convention, GeometryConvention::kTransform);
  ASSERT_EQ(d.joints.size(), 4u);
  EXPECT_EQ(d.joints[0].name, "shoulder");
  EXPECT_EQ(d.joints[1].name, "elbow");
  EXPECT_EQ(d.joints[2].name, "slide");
  EXPECT_EQ(d.joints[3].name, "wrist");
  EXPECT_NEAR(d.joints[1].min, -1.5 * 180.0 / M_PI, 1e-12);
  EXPECT_NEAR(d.joints[1].max, 2.0 * 180.0 / M_PI, 1e-12);
  EXPECT_EQ(d.joints[2].type, JointType::kPrismatic);
  EXPECT_DOUBLE_EQ(d.joints[2].min, 0.0);
  EXPECT_DOUBLE_EQ(d.joints[2].max, 500.0);
  EXPECT_DOUBLE_EQ(d.joints[3].min, -360.0);  // continuous
  EXPECT_DOUBLE_EQ(d.joints[3].max, 360.0);
  // The first joint's transform holds both fixed joints before it: 1 + 2 + 3 m of world offset and more.
  EXPECT_GT(std::hypot(d.joints[0].xyz_mm[0], d.joints[0].xyz_mm[1], d.joints[0].xyz_mm[2]), 3000.0);
  ASSERT_TRUE(d.urdf);
  EXPECT_EQ(d.urdf->tip_link, "tool0");
  // The definition survives its stored form.
  const api::RegisterRobotRequest stored = nlohmann::json(d).get<api::RegisterRobotRequest>();
  ASSERT_TRUE(stored.urdf && stored.flange);
  EXPECT_EQ(stored.urdf->xml, kCoverage);
  KinematicsWorkspace ws(api::BuildModel(d));
  const Eigen::VectorXd q = Eigen::Vector4d(0.3, -0.2, 120.0, 2.0);
  EXPECT_TRUE(ForwardKinematics(api::BuildModel(stored), q, Eigen::VectorXd(), &ws)
                  .isApprox(ForwardKinematics(api::BuildModel(d), q, Eigen::VectorXd(), &ws), 1e-15));
}

// The calibrated URDF: random geometric errors of calibration size on every site (base, joints, tool),
// exported, imported again down to the added tool link: its kinematics are the calibrated robot's in its base
// frame, to round-off; the rest of the document is kept.
TEST(UrdfExportTest, TheCalibratedUrdfReproducesTheCalibratedKinematics) {
  for (const auto& [name, xml, base, tip] :
       {std::tuple{"coverage", std::string(kCoverage), "world", "tool0"},
        std::tuple{"ur5", ReadData("ur5_robot.urdf"), "base_link", "tool0"},
        std::tuple{"irb2400", ReadData("irb2400.urdf"), "base_link", "tool0"}}) {
    SCOPED_TRACE(name);
    api::ImportUrdfRequest request = Request(xml, base, tip);
    api::PoseWire tool;
    tool.position_mm = {10.0, -5.0, 150.0};
    tool.quaternion = {0.9238795325112867, 0.0, 0.3826834323650898, 0.0};  // 45 deg about y
    request.tool = tool;
    api::PoseWire registered;
    registered.position_mm = {2500.0, -800.0, 300.0};
    request.base = registered;
    const api::RegisterRobotRequest definition = urdf::ImportUrdf(request);
    const RobotModel model = api::BuildModel(definition);
    Rng rng(11);
    Eigen::VectorXd errors(model.num_error_parameters());
    for (int k = 0; k < errors.size(); ++k) {
      errors[k] = (RobotModel::IsTranslationParameter(k) ? 0.3 : 1e-3) * rng.Normal();
    }
    const std::string exported = urdf::ExportCalibratedUrdf(*definition.urdf, model, errors, model.T_world_base());
    EXPECT_THAT(exported, HasSubstr("Calibrated by robocal"));
    EXPECT_THAT(exported, HasSubstr("<link name=\"robocal_tool\"/>"));
    const RobotModel back = api::BuildModel(urdf::ImportUrdf(Request(exported, base, urdf::kToolLink)));
    ASSERT_EQ(back.num_joints(), model.num_joints());
    KinematicsWorkspace ws(model), ws_back(back);
    double position = 0.0, rotation = 0.0;
    for (int n = 0; n < 100; ++n) {
      const Eigen::VectorXd q = RandomConfiguration(model, &rng);
      const Transform calibrated = model.T_world_base().inverse() * ForwardKinematics(model, q, errors, &ws);
      const Transform& reloaded = ForwardKinematics(back, q, Eigen::VectorXd(), &ws_back);
      position = std::max(position, (calibrated.translation() - reloaded.translation()).norm());
      rotation = std::max(rotation, Eigen::AngleAxisd(calibrated.linear().transpose() * reloaded.linear()).angle());
    }
    RecordProperty(std::string(name) + "_position_mm", std::to_string(position * 1e9) + "e-9");
    EXPECT_LT(position, 1e-9);
    EXPECT_LT(rotation, 1e-12);
    // The errors are in it: the nominal robot (with its tool) is off the reloaded one by tenths of a mm.
    const Eigen::VectorXd q = RandomConfiguration(model, &rng);
    EXPECT_GT((ForwardKinematics(back, q, Eigen::VectorXd(), &ws_back).translation() -
               (model.T_world_base().inverse() * ForwardKinematics(model, q, Eigen::VectorXd(), &ws)).translation())
                  .norm(),
              0.05);
  }
}

// Robots that came from a table (presets: DH, and a transform table with prismatic joints) get a generated URDF
// with the same property.
TEST(UrdfExportTest, AGeneratedUrdfReproducesTheCalibratedKinematicsOfATableRobot) {
  for (const char* preset : {"ur5e", "puma560", "grinder5"}) {
    SCOPED_TRACE(preset);
    const RobotModel model = Preset(preset);
    Rng rng(12);
    Eigen::VectorXd errors(model.num_error_parameters());
    for (int k = 0; k < errors.size(); ++k) {
      errors[k] = (RobotModel::IsTranslationParameter(k) ? 0.3 : 1e-3) * rng.Normal();
    }
    const std::string generated = urdf::GenerateCalibratedUrdf(model, errors, model.T_world_base());
    const RobotModel back = api::BuildModel(urdf::ImportUrdf(Request(generated, "base_link", urdf::kToolLink)));
    ASSERT_EQ(back.num_joints(), model.num_joints());
    EXPECT_EQ(back.joint_name(0), model.joint_name(0));
    EXPECT_NEAR(back.upper_limits()[0], model.upper_limits()[0], 1e-12);
    KinematicsWorkspace ws(model), ws_back(back);
    double position = 0.0;
    for (int n = 0; n < 100; ++n) {
      const Eigen::VectorXd q = RandomConfiguration(model, &rng);
      const Transform calibrated = model.T_world_base().inverse() * ForwardKinematics(model, q, errors, &ws);
      position = std::max(position, (calibrated.translation() -
                                     ForwardKinematics(back, q, Eigen::VectorXd(), &ws_back).translation())
                                        .norm());
    }
    EXPECT_LT(position, 1e-9);
  }
}

// Refusals: the field, and the element in the reason.
std::pair<std::string, std::string> Refusal(const std::string& xml, const std::string& base = "world",
                                            const std::string& tip = "tool0") {
  try {
    urdf::ImportUrdf(Request(xml, base, tip));
  } catch (const api::ApiError& e) {
    EXPECT_EQ(e.status(), api::Status::kInvalidArgument);
    if (e.details().empty()) return {"", e.what()};
    return {e.details()[0].field, e.details()[0].reason};
  }
  return {"accepted", ""};
}

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

TEST(UrdfImportTest, BadDocumentsAndChainsAreNamed) {
  auto [field, reason] = Refusal("<robot name='x'><link name='a'></robot>");
  EXPECT_EQ(field, "urdf");
  EXPECT_THAT(reason, HasSubstr("not a valid URDF document"));
  std::tie(field, reason) = Refusal("not xml at all");
  EXPECT_EQ(field, "urdf");
  std::tie(field, reason) = Refusal(kCoverage, "nowhere");
  EXPECT_EQ(field, "base_link");
  EXPECT_THAT(reason, HasSubstr("no link \"nowhere\""));
  EXPECT_THAT(reason, HasSubstr("tool0"));  // the links are listed
  std::tie(field, reason) = Refusal(kCoverage, "world", "nowhere");
  EXPECT_EQ(field, "tip_link");
  std::tie(field, reason) = Refusal(kCoverage, "l3", "l1");
  EXPECT_EQ(field, "tip_link");
  EXPECT_THAT(reason, HasSubstr("is not below base_link \"l3\""));
  std::tie(field, reason) = Refusal(kCoverage, "flange", "tool0");
  EXPECT_EQ(field, "tip_link");
  EXPECT_THAT(reason, HasSubstr("no revolute, continuous or prismatic joint"));
  // A revolute joint without <limit>: liburdfdom's reason names the joint.
  std::tie(field, reason) =
      Refusal(Replace(kCoverage, R"(<limit lower="-1.5" upper="2.0" effort="1" velocity="1"/>)", ""));
  EXPECT_EQ(field, "urdf");
  EXPECT_THAT(reason, HasSubstr("elbow"));
  std::tie(field, reason) = Refusal(Replace(kCoverage, R"(<axis xyz="1 0 0"/>)",
                                            R"(<axis xyz="1 0 0"/><mimic joint="elbow" multiplier="2"/>)"));
  EXPECT_EQ(field, "urdf");
  EXPECT_THAT(reason, HasSubstr("<joint name=\"slide\"> mimics \"elbow\""));
  std::tie(field, reason) = Refusal(Replace(kCoverage, R"(name="wrist" type="continuous")", R"(name="wrist" type="floating")"));
  EXPECT_EQ(field, "urdf");
  EXPECT_THAT(reason, HasSubstr("<joint name=\"wrist\"> is floating"));
  std::tie(field, reason) = Refusal(Replace(kCoverage, R"(name="wrist" type="continuous")", R"(name="wrist" type="planar")"));
  EXPECT_THAT(reason, HasSubstr("<joint name=\"wrist\"> is planar"));
  // Names robocal reserves or cannot use are named with the URDF joint.
  std::tie(field, reason) = Refusal(Replace(kCoverage, R"(name="shoulder")", R"(name="tool")"));
  EXPECT_EQ(field, "urdf");
  EXPECT_THAT(reason, HasSubstr("<joint name=\"tool\">: 'tool' is reserved"));
  std::tie(field, reason) = Refusal(Replace(kCoverage, R"(name="shoulder")", R"(name="a.b")"));
  EXPECT_THAT(reason, HasSubstr("<joint name=\"a.b\">: must not contain '.'"));
  std::tie(field, reason) = Refusal(Replace(kCoverage, R"(<limit lower="-1.5" upper="2.0")", R"(<limit lower="2.0" upper="-1.5")"));
  EXPECT_THAT(reason, HasSubstr("<joint name=\"elbow\">: <limit> lower must be below upper"));
  std::tie(field, reason) = Refusal(Replace(kCoverage, R"(<axis xyz="0 -1 0"/>)", R"(<axis xyz="0 0 0"/>)"));
  EXPECT_THAT(reason, HasSubstr("elbow"));
  // Nesting that would take the XML parser's recursion through the stack is refused before it parses; the
  // coverage URDF itself, with comments and quoted '>' added, is not.
  std::string deep = "<robot name='x'>";
  for (int i = 0; i < 200000; ++i) deep += "<a>";
  std::tie(field, reason) = Refusal(deep);
  EXPECT_EQ(field, "urdf");
  EXPECT_THAT(reason, HasSubstr("elements nest deeper than 64 levels"));
  EXPECT_EQ(Refusal(Replace(kCoverage, "<link name=\"world\"/>",
                            "<!-- <a><b><c> --><link name=\"world\"/><![CDATA[<x><y>]]>"))
                .first,
            "accepted");
  // Not a tree: a link with two parents, cycles through the chain (liburdfdom accepts them).
  const std::string two_links = R"(<robot name="t"><link name="l0"/><link name="l1"/><link name="l2"/>
    <joint name="j1" type="revolute"><parent link="l0"/><child link="l1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
    <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>)";
  std::tie(field, reason) = Refusal(two_links + R"(<joint name="j3" type="fixed"><parent link="l0"/><child link="l2"/></joint></robot>)", "l0", "l2");
  EXPECT_EQ(field, "urdf");
  EXPECT_THAT(reason, HasSubstr("link \"l2\" is the child of two joints"));
  for (const char* loop : {R"(<joint name="j3" type="fixed"><parent link="l2"/><child link="l2"/></joint></robot>)",
                           R"(<joint name="j3" type="fixed"><parent link="l1"/><child link="l1"/></joint></robot>)"}) {
    std::tie(field, reason) = Refusal(two_links + loop, "l0", "l2");
    EXPECT_EQ(field, "urdf") << reason;
    EXPECT_THAT(reason, ::testing::AnyOf(HasSubstr("form a cycle"), HasSubstr("child of two joints")));
  }
  // A cycle in a document liburdfdom refuses for another reason (a joint without links): refused as a cycle
  // before liburdfdom links it (it would leak the linked links; the sanitizer build checks that).
  std::tie(field, reason) = Refusal(R"(<robot name="t"><link name="m"/><joint name="j" type="fixed"><child link="m"/>)"
                                    R"(<parent link="m"/></joint><joint name="k" type="fixed"></joint></robot>)",
                                    "m", "m");
  EXPECT_EQ(field, "urdf");
  EXPECT_EQ(reason, "joint \"j\" makes link \"m\" its own ancestor: the joints form a cycle");
  std::tie(field, reason) = Refusal(Replace(kCoverage, R"(<origin xyz="0 0.05 0" rpy="0 0 0"/>)",
                                            R"(<origin xyz="0 0 1.7e305" rpy="0 0 0"/>)"));
  EXPECT_THAT(reason, HasSubstr("<joint name=\"slide\">: <origin> must be finite and within 1000 m"));
  std::tie(field, reason) = Refusal(Replace(kCoverage, R"(<limit lower="0" upper="0.5")", R"(<limit lower="0" upper="1e306")"));
  EXPECT_THAT(reason, HasSubstr("<joint name=\"slide\">: <limit> lower and upper must lie within 1000 m"));
  // A robot name that gives no id.
  std::tie(field, reason) = Refusal(Replace(kCoverage, R"(name="Cover_Bot 1")", R"(name="!!!")"));
  EXPECT_EQ(field, "id");
  EXPECT_EQ(urdf::ImportUrdf(Request(Replace(kCoverage, R"(name="Cover_Bot 1")", R"(name="  My Robot!! (v2) ")"),
                                     "world", "tool0"))
                .id,
            "my_robot_v2");
}

}  // namespace
}  // namespace robocal
