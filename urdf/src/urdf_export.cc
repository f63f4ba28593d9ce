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

}  // namespace

std::string ExportCalibratedUrdf(const api::UrdfSource& source, const RobotModel& model, const Eigen::VectorXd& errors,
                                 const Transform& T_world_base) {
  if (errors.size() != model.num_error_parameters()) Stale("the calibration does not match the robot's model");
  const ::urdf::ModelInterfaceSharedPtr parsed = internal::Parse(source.xml);
  if (parsed->getLink(kToolLink)) Stale(std::string("the URDF already has a link \"") + kToolLink + "\"");
  const auto error = [&](int site) { return ErrorTransform(errors.data() + 6 * site); };

  // The chain as the import walked it: each moving joint, and the fixed joints before the first.
  std::vector<::urdf::JointConstSharedPtr> chain;
  ::urdf::LinkConstSharedPtr link = parsed->getLink(source.tip_link);
  const ::urdf::LinkConstSharedPtr base = parsed->getLink(source.base_link);
  if (!link || !base) Stale("the URDF's base or tip link is gone");
  for (; link != base; link = parsed->getLink(link->parent_joint->parent_link_name)) {
    if (!link->parent_joint) Stale("the tip link is no longer below the base link");
    chain.insert(chain.begin(), link->parent_joint);
  }

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
    const Eigen::Vector3d axis = Eigen::Vector3d(joint->axis.x, joint->axis.y, joint->axis.z).normalized();
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
  tinyxml2::XMLElement* tool_link = doc.NewElement("link");
  tool_link->SetAttribute("name", kToolLink);
  robot->InsertEndChild(tool_link);
  tinyxml2::XMLElement* tool_joint = doc.NewElement("joint");
  tool_joint->SetAttribute("name", kToolJoint);
  tool_joint->SetAttribute("type", "fixed");
  tinyxml2::XMLElement* parent = doc.NewElement("parent");
  parent->SetAttribute("link", source.tip_link.c_str());
  tinyxml2::XMLElement* child = doc.NewElement("child");
  child->SetAttribute("link", kToolLink);
  tool_joint->InsertEndChild(parent);
  tool_joint->InsertEndChild(child);
  robot->InsertEndChild(tool_joint);
  SetOrigin(&doc, tool_joint, model.T_flange_tool() * error(model.num_joints() + 1));

  const std::string note = " Calibrated by robocal: the chain " + source.base_link + " -> " + source.tip_link +
                           " carries the identified geometric errors; " + kToolLink +
                           " is the calibrated tool. The tracker -> " + source.base_link + " registration: xyz " +
                           Numbers(T_world_base.translation() / 1000.0) + " m, rpy " +
                           Numbers(RpyFromRotation(T_world_base.linear())) + " rad. ";
  robot->InsertFirstChild(doc.NewComment(note.c_str()));
  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  return printer.CStr();
}

}  // namespace robocal::urdf
