// Calibrated URDF out (see urdf_export.h). The chain is read with liburdfdom as on import; the document is
// edited with tinyxml2, which keeps every element it is not asked to change (liburdfdom's own writer prints six
// significant digits, too few for a calibration).
#include "robocal/urdf/urdf_export.h"

#include <tinyxml2.h>

#include <cstdio>
#include <vector>

#include "robocal/api/error.h"
#include "robocal/core/kinematics.h"
#include "urdf_internal.h"

namespace robocal::urdf {
namespace {

[[noreturn]] void Stale(const std::string& reason) {
  throw api::ApiError(api::Status::kFailedPrecondition, "cannot export the calibrated URDF: " + reason,
                      {{"format", reason}});
}

std::string Numbers(const Eigen::Vector3d& v) {
  char text[128];
  std::snprintf(text, sizeof text, "%.17g %.17g %.17g", v.x(), v.y(), v.z());
  return text;
}

// Sets `joint`'s <origin> (creating it) to `t` (mm) in URDF units (m, rpy rad).
void SetOrigin(tinyxml2::XMLDocument* doc, tinyxml2::XMLElement* joint, const Transform& t) {
  tinyxml2::XMLElement* origin = joint->FirstChildElement("origin");
  if (origin == nullptr) {
    origin = doc->NewElement("origin");
    joint->InsertFirstChild(origin);
  }
  origin->SetAttribute("xyz", Numbers(t.translation() / 1000.0).c_str());
  origin->SetAttribute("rpy", Numbers(RpyFromRotation(t.linear())).c_str());
}

tinyxml2::XMLElement* AddLink(tinyxml2::XMLDocument* doc, tinyxml2::XMLElement* robot, const std::string& name) {
  tinyxml2::XMLElement* link = doc->NewElement("link");
  link->SetAttribute("name", name.c_str());
  robot->InsertEndChild(link);
  return link;
}

tinyxml2::XMLElement* AddJoint(tinyxml2::XMLDocument* doc, tinyxml2::XMLElement* robot, const std::string& name,
                               const char* type, const std::string& parent, const std::string& child,
                               const Transform& origin) {
  tinyxml2::XMLElement* joint = doc->NewElement("joint");
  joint->SetAttribute("name", name.c_str());
  joint->SetAttribute("type", type);
  tinyxml2::XMLElement* p = doc->NewElement("parent");
  p->SetAttribute("link", parent.c_str());
  tinyxml2::XMLElement* c = doc->NewElement("child");
  c->SetAttribute("link", child.c_str());
  joint->InsertEndChild(p);
  joint->InsertEndChild(c);
  robot->InsertEndChild(joint);
  SetOrigin(doc, joint, origin);
  return joint;
}

std::string RegistrationNote(const std::string& base_link, const Transform& T_world_base) {
  return " Calibrated by robocal: the joint origins carry the identified geometric errors; " +
         std::string(kToolLink) + " is the calibrated tool. The tracker -> " + base_link +
         " registration: xyz " + Numbers(T_world_base.translation() / 1000.0) + " m, rpy " +
         Numbers(RpyFromRotation(T_world_base.linear())) + " rad. ";
}

std::string Print(const tinyxml2::XMLDocument& doc) {
  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  return printer.CStr();
}

}  // namespace

std::string GenerateCalibratedUrdf(const RobotModel& model, const Eigen::VectorXd& errors,
                                   const Transform& T_world_base) {
  if (errors.size() != model.num_error_parameters()) Stale("the calibration does not match the robot's model");
  const auto error = [&](int site) { return ErrorTransform(errors.data() + 6 * site); };
  tinyxml2::XMLDocument doc;
  doc.InsertEndChild(doc.NewDeclaration());
  tinyxml2::XMLElement* robot = doc.NewElement("robot");
  robot->SetAttribute("name", model.name().c_str());
  doc.InsertEndChild(robot);
  robot->InsertEndChild(doc.NewComment(RegistrationNote("base_link", T_world_base).c_str()));
  AddLink(&doc, robot, "base_link");
  std::string parent = "base_link";
  for (int i = 0; i < model.num_joints(); ++i) {
    const std::string child = model.joint_name(i) + "_link";
    AddLink(&doc, robot, child);
    Transform origin = model.fixed_transform(i) * error(i + 1);
    if (i == 0) origin = error(0) * origin;
    const bool revolute = model.joint_type(i) == JointType::kRevolute;
    tinyxml2::XMLElement* joint =
        AddJoint(&doc, robot, model.joint_name(i), revolute ? "revolute" : "prismatic", parent, child, origin);
    tinyxml2::XMLElement* axis = doc.NewElement("axis");
    axis->SetAttribute("xyz", "0 0 1");
    joint->InsertEndChild(axis);
    tinyxml2::XMLElement* limit = doc.NewElement("limit");
    const double scale = revolute ? 1.0 : 1e-3;  // rad, or mm -> m
    char value[32];
    std::snprintf(value, sizeof value, "%.17g", model.lower_limits()[i] * scale);
    limit->SetAttribute("lower", value);
    std::snprintf(value, sizeof value, "%.17g", model.upper_limits()[i] * scale);
    limit->SetAttribute("upper", value);
    limit->SetAttribute("effort", "0");
    limit->SetAttribute("velocity", "0");
    joint->InsertEndChild(limit);
    parent = child;
  }
  AddLink(&doc, robot, "flange");
  AddJoint(&doc, robot, "robocal_flange_joint", "fixed", parent, "flange", model.T_lastjoint_flange());
  AddLink(&doc, robot, kToolLink);
  AddJoint(&doc, robot, kToolJoint, "fixed", "flange", kToolLink,
           model.T_flange_tool() * error(model.num_joints() + 1));
  return Print(doc);
}

std::string ExportCalibratedUrdf(const api::UrdfSource& source, const RobotModel& model, const Eigen::VectorXd& errors,
                                 const Transform& T_world_base) {
  if (errors.size() != model.num_error_parameters()) Stale("the calibration does not match the robot's model");
  const internal::ParsedModel parsed_model(internal::Parse(source.xml));
  const ::urdf::ModelInterfaceSharedPtr& parsed = parsed_model.get();
  if (parsed->getLink(kToolLink)) Stale(std::string("the URDF already has a link \"") + kToolLink + "\"");
  const auto error = [&](int site) { return ErrorTransform(errors.data() + 6 * site); };

  // The chain as the import walked it: each moving joint, and the fixed joints before the first.
  if (!parsed->getLink(source.tip_link) || !parsed->getLink(source.base_link)) {
    Stale("the URDF's base or tip link is gone");
  }
  const std::vector<::urdf::JointConstSharedPtr> chain =
      internal::Chain(*parsed, source.base_link, source.tip_link);

  tinyxml2::XMLDocument doc;
  if (doc.Parse(source.xml.c_str(), source.xml.size()) != tinyxml2::XML_SUCCESS) Stale(doc.ErrorStr());
  tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  if (robot == nullptr) Stale("no <robot> element");
  const auto element = [&](const std::string& name) {
    for (tinyxml2::XMLElement* e = robot->FirstChildElement("joint"); e; e = e->NextSiblingElement("joint")) {
      if (const char* n = e->Attribute("name"); n && name == n) return e;
    }
    Stale("no <joint name=\"" + name + "\"> in the document");
  };

  Transform before_first = Transform::Identity();  // base link -> parent of the first moving joint
  int site = 1;                                     // error sites: 0 base, 1..n joints, n + 1 tool
  for (const ::urdf::JointConstSharedPtr& joint : chain) {
    const Transform origin = internal::ToTransform(joint->parent_to_joint_origin_transform);
    if (joint->type == ::urdf::Joint::FIXED) {
      if (site == 1) before_first = before_first * origin;
      continue;
    }
    if (site > model.num_joints()) Stale("the URDF's chain has more moving joints than the robot");
    const Eigen::Vector3d raw(joint->axis.x, joint->axis.y, joint->axis.z);
    const Eigen::Vector3d axis = (raw / raw.cwiseAbs().maxCoeff()).normalized();  // as the import scales it
    const Transform align = Rotation(internal::AxisAlignment(axis));
    // The model's joint frame is origin * align (after the fixed joints before it); its site error follows it.
    // Written back in the URDF's joint frame: origin' = origin * align * E * align^-1. The base site's error
    // sits before the first joint's fixed joints: moved past them, it joins the first origin.
    Transform calibrated = origin * align * error(site) * align.inverse();
    if (site == 1) calibrated = before_first.inverse() * error(0) * before_first * calibrated;
    SetOrigin(&doc, element(joint->name), calibrated);
    ++site;
  }
  if (site != model.num_joints() + 1) Stale("the URDF's chain has fewer moving joints than the robot");

  // The calibrated tool: tip link (the flange) -> measured point.
  AddLink(&doc, robot, kToolLink);
  AddJoint(&doc, robot, kToolJoint, "fixed", source.tip_link, kToolLink,
           model.T_flange_tool() * error(model.num_joints() + 1));
  robot->InsertFirstChild(doc.NewComment(RegistrationNote(source.base_link, T_world_base).c_str()));
  return Print(doc);
}

}  // namespace robocal::urdf
