// URDF import (see urdf_import.h). The document is parsed by liburdfdom; this file only maps the parsed chain
// onto robocal's joint model.
#include "robocal/urdf/urdf_import.h"

#include "urdf_internal.h"

#include <console_bridge/console.h>
#include <tinyxml.h>
#include <tinyxml2.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>
#include <set>
#include <vector>

#include "robocal/api/error.h"
#include "robocal/core/transforms.h"
#include "robocal/core/units.h"

namespace robocal::urdf {
namespace internal {

constexpr double kMmPerM = 1000.0;
// The longest offset a joint origin (or a prismatic joint's travel) may have: no robot cell is a kilometre.
constexpr double kMaxOffsetM = 1000.0;
constexpr double kMaxOffsetMm = kMaxOffsetM * kMmPerM;

[[noreturn]] void Refuse(const std::string& field, const std::string& reason) {
  throw api::ApiError(api::Status::kInvalidArgument, "invalid URDF robot: " + field + ": " + reason,
                      {{field, reason}});
}

// liburdfdom reports why a document is refused through console_bridge's global log only; this handler
// collects the messages of one parse (parses are serialised: the handler is process-wide).
class Collector : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR) messages.push_back(text);
  }
  std::vector<std::string> messages;
};

// The deepest element nesting in `xml`, counted up to `limit` + 1. Written here because liburdfdom's XML
// parser (TinyXML) descends recursively with no depth limit of its own: a document of a few MB nested a
// million deep would overflow the server thread's stack. A URDF nests four deep (robot, joint, limit); this
// scan only has to be conservative: comments, CDATA, declarations and processing instructions are skipped, a
// quoted attribute value may hold '>', an empty element (<x/>) does not nest.
int NestingDepth(const std::string& xml, int limit) {
  int depth = 0, deepest = 0;
  size_t i = 0;
  const auto skip_past = [&](const char* end) {
    const size_t at = xml.find(end, i);
    i = at == std::string::npos ? xml.size() : at + std::strlen(end);
  };
  while ((i = xml.find('<', i)) != std::string::npos) {
    if (xml.compare(i, 4, "<!--") == 0) {
      skip_past("-->");
    } else if (xml.compare(i, 9, "<![CDATA[") == 0) {
      skip_past("]]>");
    } else if (xml.compare(i, 2, "<?") == 0) {
      skip_past("?>");
    } else if (xml.compare(i, 2, "<!") == 0 || xml.compare(i, 2, "</") == 0) {
      if (xml[i + 1] == '/') --depth;
      skip_past(">");
    } else {
      // A start tag: to its '>' outside quotes; "/>" closes it at once.
      char quote = 0;
      size_t j = i + 1;
      for (; j < xml.size(); ++j) {
        if (quote) {
          if (xml[j] == quote) quote = 0;
        } else if (xml[j] == '"' || xml[j] == '\'') {
          quote = xml[j];
        } else if (xml[j] == '>') {
          break;
        }
      }
      if (j < xml.size() && xml[j - 1] != '/') deepest = std::max(deepest, ++depth);
      if (deepest > limit) return deepest;
      i = j + 1;
    }
  }
  return deepest;
}

constexpr int kMaxXmlDepth = 64;

// liburdfdom links every joint's parent and child links (shared pointers, parent to child) before it checks the
// tree, and drops the model when a check fails later: links that a cycle of joints has linked (a joint whose
// parent is its own child, or one further down) keep each other alive, and every such request would leak them.
// So cycles are refused here before it parses, from the document as liburdfdom reads it: with the same reader
// (TinyXML, whose reading of a damaged document differs from tinyxml2's) and each joint's first <parent> and
// <child>. The walk is iterative: a document may hold tens of thousands of joints. The document must also read
// with tinyxml2, which the calibrated export edits it with.
void RefuseJointCycles(const std::string& xml) {
  tinyxml2::XMLDocument doc2;
  if (doc2.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS) {
    Refuse("urdf", std::string("not a valid URDF document: not well-formed XML (") + doc2.ErrorStr() + ")");
  }
  TiXmlDocument doc;
  doc.Parse(xml.c_str());
  if (doc.Error()) return;  // liburdfdom reports it
  const TiXmlElement* robot = doc.FirstChildElement("robot");
  if (robot == nullptr) return;
  std::map<std::string, std::vector<std::pair<std::string, std::string>>> children;  // parent -> (child, joint)
  for (const TiXmlElement* j = robot->FirstChildElement("joint"); j; j = j->NextSiblingElement("joint")) {
    const TiXmlElement* parent = j->FirstChildElement("parent");
    const TiXmlElement* child = j->FirstChildElement("child");
    const char* parent_link = parent ? parent->Attribute("link") : nullptr;
    const char* child_link = child ? child->Attribute("link") : nullptr;
    if (parent_link == nullptr || child_link == nullptr) continue;
    const char* name = j->Attribute("name");
    children[parent_link].emplace_back(child_link, name ? name : "");
  }
  // Depth-first from every link, colouring links on the current path; an edge back onto the path is a cycle.
  std::map<std::string, int> state;  // 1: on the path, 2: done
  for (const auto& start : children) {
    if (state[start.first] != 0) continue;
    std::vector<std::pair<std::string, std::size_t>> stack = {{start.first, 0}};
    state[start.first] = 1;
    while (!stack.empty()) {
      auto& [link, next] = stack.back();
      const auto edges = children.find(link);
      if (edges == children.end() || next == edges->second.size()) {
        state[link] = 2;
        stack.pop_back();
        continue;
      }
      const auto& [child, joint] = edges->second[next++];
      const int seen = state[child];
      if (seen == 1) {
        Refuse("urdf", "joint \"" + joint + "\" makes link \"" + child + "\" its own ancestor: the joints form a cycle");
      }
      if (seen == 0) {
        state[child] = 1;
        stack.emplace_back(child, 0);
      }
    }
  }
}

::urdf::ModelInterfaceSharedPtr Parse(const std::string& xml) {
  if (NestingDepth(xml, kMaxXmlDepth) > kMaxXmlDepth) {
    Refuse("urdf", "elements nest deeper than " + std::to_string(kMaxXmlDepth) + " levels (a URDF needs 4)");
  }
  RefuseJointCycles(xml);
  static std::mutex mutex;
  const std::lock_guard<std::mutex> lock(mutex);
  Collector collector;
  console_bridge::useOutputHandler(&collector);
  ::urdf::ModelInterfaceSharedPtr model;
  try {
    model = ::urdf::parseURDF(xml);
  } catch (const std::exception& e) {  // liburdfdom throws for some malformed numbers
    collector.messages.push_back(e.what());
  }
  console_bridge::noOutputHandler();
  if (!model) {
    std::string why;
    for (const std::string& m : collector.messages) why += (why.empty() ? "" : "; ") + m;
    Refuse("urdf", "not a valid URDF document: " + (why.empty() ? std::string("no <robot> element") : why));
  }
  return model;
}

Transform ToTransform(const ::urdf::Pose& pose) {
  Transform t = Transform::Identity();
  double x = 0, y = 0, z = 0, w = 1;
  pose.rotation.getQuaternion(x, y, z, w);
  t.linear() = Eigen::Quaterniond(w, x, y, z).normalized().toRotationMatrix();
  t.translation() = Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z) * kMmPerM;
  return t;
}

// The fixed rotation that turns z onto `axis` (unit): the identity for +z, half a turn about x for -z, else
// the shortest turn about z x axis. A joint moving about / along `axis` is then this rotation, the motion
// about / along z, and its inverse (which the next transform takes over).
Eigen::Matrix3d AxisAlignment(const Eigen::Vector3d& axis) {
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  if (axis.z() >= 0.0) return Eigen::Quaterniond::FromTwoVectors(z, axis).toRotationMatrix();
  // Towards -z the shortest turn is nearly half a turn, where its construction loses digits: turn z onto -z
  // exactly (half a turn about x), then -z onto the axis by a small turn.
  return Eigen::Quaterniond::FromTwoVectors(-z, axis).toRotationMatrix() *
         Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
}

std::string JointPath(const ::urdf::Joint& joint) { return "<joint name=\"" + joint.name + "\">"; }

// The robot id a URDF's name gives: lower case, each run of other characters one '_', none at either end, at
// most 64 characters (IsValidId decides).
std::string IdFromName(const std::string& name) {
  std::string id;
  bool gap = false;
  for (char c : name) {
    const char l = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    const bool kept = (l >= 'a' && l <= 'z') || (l >= '0' && l <= '9') || l == '_' || l == '.' || l == '-';
    if (!kept) {
      gap = true;
      continue;
    }
    if (gap && !id.empty()) id += '_';
    gap = false;
    id += l;
  }
  return id.substr(0, 64);
}

std::vector<::urdf::JointConstSharedPtr> Chain(const ::urdf::ModelInterface& model, const std::string& base_link,
                                               const std::string& tip_link) {
  // From the tip up to the base, then in chain order.
  const ::urdf::LinkConstSharedPtr base = model.getLink(base_link);
  std::vector<::urdf::JointConstSharedPtr> chain;
  std::set<std::string> visited;
  for (::urdf::LinkConstSharedPtr link = model.getLink(tip_link); link != base;) {
    if (!visited.insert(link->name).second) {
      Refuse("urdf", "the joints above link \"" + tip_link + "\" form a cycle through link \"" + link->name +
                         "\" (" + JointPath(*link->parent_joint) + "): a URDF is a tree");
    }
    if (!link->parent_joint) {
      Refuse("tip_link", "link \"" + tip_link + "\" is not below base_link \"" + base_link +
                             "\" (its chain ends at the root link \"" + link->name + "\")");
    }
    chain.push_back(link->parent_joint);
    link = model.getLink(link->parent_joint->parent_link_name);
  }
  std::reverse(chain.begin(), chain.end());
  return chain;
}

// The mass (kg) and first moment (kg mm, in `link`'s frame) of `link` and of every link fixed to it (through
// fixed joints, recursively): the body a moving joint carries up to the next moving joint, side branches included.
void BodyMass(const ::urdf::Link& link, const Transform& T_body_link, double* mass, Eigen::Vector3d* moment) {
  if (link.inertial) {
    const double m = link.inertial->mass;
    if (!std::isfinite(m) || m < 0.0) {
      Refuse("urdf", "<link name=\"" + link.name + "\">: <inertial> <mass> must be a finite number >= 0 (kg)");
    }
    const Eigen::Vector3d com = T_body_link * ToTransform(link.inertial->origin).translation();
    if (!com.allFinite() || !(com.norm() <= kMaxOffsetMm)) {
      Refuse("urdf", "<link name=\"" + link.name + "\">: <inertial> <origin> must be finite and within 1000 m");
    }
    *mass += m;
    *moment += m * com;
  }
  for (const ::urdf::JointSharedPtr& joint : link.child_joints) {
    if (!joint || joint->type != ::urdf::Joint::FIXED) continue;
    for (const ::urdf::LinkSharedPtr& child : link.child_links) {
      if (child && child->name == joint->child_link_name) {
        BodyMass(*child, T_body_link * ToTransform(joint->parent_to_joint_origin_transform), mass, moment);
      }
    }
  }
}

}  // namespace internal

using namespace internal;

namespace {

// The model's link names for a message: sorted, the first 20.
std::string UrdfLinkNames(const ::urdf::ModelInterface& model) {
  std::vector<::urdf::LinkSharedPtr> links;
  model.getLinks(links);
  std::vector<std::string> names;
  for (const auto& l : links) names.push_back(l->name);
  std::sort(names.begin(), names.end());
  std::string out;
  for (size_t i = 0; i < names.size() && i < 20; ++i) out += (i ? ", " : "") + names[i];
  return out + (names.size() > 20 ? ", ..." : "");
}

// liburdfdom keeps one parent joint per link and does not look for cycles: a link that is the child of two
// joints would silently lose one, and a cycle would make the walk below endless.
void RefuseLinksWithTwoParents(const ::urdf::ModelInterface& model) {
  std::map<std::string, std::string> parent_of;  // child link -> joint
  for (const auto& [name, joint] : model.joints_) {
    const auto [at, fresh] = parent_of.emplace(joint->child_link_name, name);
    if (!fresh) {
      Refuse("urdf", "link \"" + joint->child_link_name + "\" is the child of two joints (\"" + at->second +
                         "\" and \"" + name + "\"): a URDF is a tree");
    }
  }
}

// A joint robocal can move on its own: revolute, continuous or prismatic, no mimic; its unit axis.
Eigen::Vector3d MovingJointAxis(const ::urdf::Joint& joint) {
  if (joint.type == ::urdf::Joint::FLOATING || joint.type == ::urdf::Joint::PLANAR) {
    Refuse("urdf", JointPath(joint) + " is " + (joint.type == ::urdf::Joint::FLOATING ? "floating" : "planar") +
                       ": an arm's chain has revolute, continuous, prismatic and fixed joints only");
  }
  if (joint.type != ::urdf::Joint::REVOLUTE && joint.type != ::urdf::Joint::CONTINUOUS &&
      joint.type != ::urdf::Joint::PRISMATIC) {
    Refuse("urdf", JointPath(joint) + " has an unknown type");
  }
  if (joint.mimic) {
    Refuse("urdf", JointPath(joint) + " mimics \"" + joint.mimic->joint_name +
                       "\": a calibrated chain needs joints that move on their own");
  }
  Eigen::Vector3d axis(joint.axis.x, joint.axis.y, joint.axis.z);
  // Scaled by its largest component first, so that neither huge nor tiny components under- or overflow.
  const double largest = axis.cwiseAbs().maxCoeff();
  if (!std::isfinite(largest)) Refuse("urdf", JointPath(joint) + ": <axis> must be finite");
  if (!(largest > 0.0)) Refuse("urdf", JointPath(joint) + ": <axis> is zero");
  return (axis / largest).normalized();
}

// A revolute or prismatic joint's limits in wire units (a continuous joint's: two turns either way).
void SetUrdfJointLimits(const ::urdf::Joint& joint, api::JointWire* j) {
  if (joint.type == ::urdf::Joint::CONTINUOUS) {
    j->min = -360.0;
    j->max = 360.0;
    return;
  }
  if (!joint.limits) Refuse("urdf", JointPath(joint) + " has no <limit>");
  const double scale = j->type == JointType::kPrismatic ? kMmPerM : kDegPerRad;
  j->min = joint.limits->lower * scale;
  j->max = joint.limits->upper * scale;
  const double bound = j->type == JointType::kPrismatic ? kMaxOffsetMm : 8.0 * 180.0;  // mm; four turns
  if (!(std::abs(j->min) <= bound) || !(std::abs(j->max) <= bound)) {
    Refuse("urdf",
           JointPath(joint) + ": <limit> lower and upper must lie within " +
               (j->type == JointType::kPrismatic ? std::string("1000 m") : std::string("four turns (25.13 rad)")));
  }
  if (!(j->min < j->max)) {
    Refuse("urdf", JointPath(joint) + ": <limit> lower must be below upper (lower " +
                       std::to_string(joint.limits->lower) + ", upper " + std::to_string(joint.limits->upper) + ")");
  }
}

// A moving joint as robocal's: `fixed` before its motion, the body it moves (aligned by `align`), its limits.
api::JointWire UrdfMovingJoint(const ::urdf::ModelInterface& model, const ::urdf::Joint& joint, const Transform& fixed,
                               const Eigen::Matrix3d& align) {
  api::JointWire j;
  j.name = joint.name;
  // The body this joint moves, in robocal's joint frame after the motion: the URDF child link's frame is that
  // frame turned back by the axis alignment (child = after-motion * align', as `pending` says).
  if (const ::urdf::LinkConstSharedPtr child = model.getLink(joint.child_link_name)) {
    double mass = 0.0;
    Eigen::Vector3d moment = Eigen::Vector3d::Zero();
    BodyMass(*child, Rotation(align.transpose()), &mass, &moment);
    if (mass > 0.0) {
      const Eigen::Vector3d com = moment / mass;
      j.mass_kg = mass;
      j.com_mm = {com.x(), com.y(), com.z()};
    }
  }
  j.type = joint.type == ::urdf::Joint::PRISMATIC ? JointType::kPrismatic : JointType::kRevolute;
  const Eigen::Vector3d rpy = RpyFromRotation(fixed.linear()) * kDegPerRad;
  j.xyz_mm = {fixed.translation().x(), fixed.translation().y(), fixed.translation().z()};
  j.rpy_deg = {rpy.x(), rpy.y(), rpy.z()};
  SetUrdfJointLimits(joint, &j);
  return j;
}

// The chain's moving joints appended to *joints; returns what follows the last one (its axis alignment inverted,
// then fixed joints): the flange.
Transform AppendUrdfChain(const ::urdf::ModelInterface& model, const std::vector<::urdf::JointConstSharedPtr>& chain,
                          std::vector<api::JointWire>* joints) {
  // What lies between the previous moving joint's frame (after its motion) and the next joint's origin: fixed
  // joints and the previous joint's axis alignment, inverted.
  Transform pending = Transform::Identity();
  for (const ::urdf::JointConstSharedPtr& joint : chain) {
    const Transform origin = ToTransform(joint->parent_to_joint_origin_transform);
    if (!origin.matrix().allFinite() || !(origin.translation().norm() <= kMaxOffsetMm)) {
      Refuse("urdf", JointPath(*joint) + ": <origin> must be finite and within 1000 m of its parent");
    }
    if (joint->type == ::urdf::Joint::FIXED) {
      pending = pending * origin;
      continue;
    }
    const Eigen::Vector3d axis = MovingJointAxis(*joint);
    const Eigen::Matrix3d align = AxisAlignment(axis);
    const Transform fixed = pending * origin * Rotation(align);
    pending = Rotation(align.transpose());
    joints->push_back(UrdfMovingJoint(model, *joint, fixed, align));
  }
  return pending;
}

// The core's checks (names robocal reserves or cannot use, limits) name joints[i]; say which URDF joint that is.
void CheckImportedRobot(const api::RegisterRobotRequest& out) {
  try {
    (void)RobotModel::Build(api::ToSpec(out));
  } catch (const InvalidModelError& e) {
    std::vector<api::FieldViolation> details;
    std::string message;
    for (const FieldError& f : e.errors()) {
      std::string field = f.field;
      if (field.rfind("joints[", 0) == 0) {
        const size_t i = std::stoul(field.substr(7));
        field = "urdf";
        details.push_back({field, "<joint name=\"" + out.joints.at(i).name + "\">: " + f.reason});
      } else {
        details.push_back({field, f.reason});
      }
      message += (message.empty() ? "" : "; ") + details.back().field + ": " + details.back().reason;
    }
    throw api::ApiError(api::Status::kInvalidArgument, "invalid URDF robot: " + message, details);
  }
}

}  // namespace

api::RegisterRobotRequest ImportUrdf(const api::ImportUrdfRequest& request) {
  const ParsedModel parsed(Parse(request.urdf));
  const ::urdf::ModelInterfaceSharedPtr& model = parsed.get();
  const ::urdf::LinkConstSharedPtr base = model->getLink(request.base_link);
  if (!base) {
    Refuse("base_link", "no link \"" + request.base_link + "\" in the URDF (links: " + UrdfLinkNames(*model) + ")");
  }
  const ::urdf::LinkConstSharedPtr tip = model->getLink(request.tip_link);
  if (!tip) {
    Refuse("tip_link", "no link \"" + request.tip_link + "\" in the URDF (links: " + UrdfLinkNames(*model) + ")");
  }
  RefuseLinksWithTwoParents(*model);
  const std::vector<::urdf::JointConstSharedPtr> chain = Chain(*model, request.base_link, request.tip_link);

  api::RegisterRobotRequest out;
  out.id = request.id.empty() ? IdFromName(model->getName()) : request.id;
  if (!api::IsValidId(out.id)) {
    Refuse("id", "the URDF's robot name \"" + model->getName() + "\" gives no valid id; give one (" +
                     std::string(api::kIdRule) + ")");
  }
  out.description = request.description.empty() ? "imported from the URDF robot \"" + model->getName() + "\" (" +
                                                      request.base_link + " -> " + request.tip_link + ")"
                                                : request.description;
  out.convention = GeometryConvention::kTransform;
  out.base = request.base;
  out.tool = request.tool;
  out.urdf = api::UrdfSource{{request.base_link, request.tip_link}, request.urdf};

  const Transform flange = AppendUrdfChain(*model, chain, &out.joints);
  if (out.joints.empty()) {
    Refuse("tip_link", "no revolute, continuous or prismatic joint between \"" + request.base_link + "\" and \"" +
                           request.tip_link + "\"");
  }
  if (out.joints.size() > static_cast<size_t>(kMaxJoints)) {
    Refuse("tip_link", std::to_string(out.joints.size()) + " moving joints between \"" + request.base_link +
                           "\" and \"" + request.tip_link + "\"; robocal takes at most " + std::to_string(kMaxJoints));
  }
  out.flange = api::TransformToPose(flange);
  CheckImportedRobot(out);
  return out;
}

}  // namespace robocal::urdf
