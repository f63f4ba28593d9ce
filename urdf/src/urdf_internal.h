// What the URDF import and export share: parsing (liburdfdom, errors collected), poses in mm, axis alignment.
#pragma once

#include <urdf_parser/urdf_parser.h>

#include <string>
#include <vector>

#include <Eigen/Core>

#include "robocal/core/transforms.h"

namespace robocal::urdf::internal {

/// Throws api::ApiError kInvalidArgument naming `field`.
[[noreturn]] void Refuse(const std::string& field, const std::string& reason);
/// The parsed document (nesting checked first); refuses naming "urdf" with liburdfdom's messages.
::urdf::ModelInterfaceSharedPtr Parse(const std::string& xml);
/// Holds a parsed model and, when it goes, breaks its links' shared pointers to each other: a document with a
/// cycle of joints (which liburdfdom accepts and the import refuses) would otherwise keep its links alive.
class ParsedModel {
 public:
  explicit ParsedModel(::urdf::ModelInterfaceSharedPtr model) : model_(std::move(model)) {}
  ~ParsedModel() {
    for (auto& [name, link] : model_->links_) {
      link->child_links.clear();
      link->child_joints.clear();
      link->parent_joint.reset();
    }
  }
  ParsedModel(const ParsedModel&) = delete;
  ParsedModel& operator=(const ParsedModel&) = delete;
  const ::urdf::ModelInterfaceSharedPtr& operator->() const { return model_; }
  const ::urdf::ModelInterfaceSharedPtr& get() const { return model_; }

 private:
  ::urdf::ModelInterfaceSharedPtr model_;
};

/// The joints from link `base` down to link `tip` (both in the model), in chain order. Refuses a tip not below
/// the base (naming tip_link) and a cycle of joints above the tip (naming urdf).
std::vector<::urdf::JointConstSharedPtr> Chain(const ::urdf::ModelInterface& model, const std::string& base,
                                               const std::string& tip);

/// A URDF pose (m) as a transform (mm).
Transform ToTransform(const ::urdf::Pose& pose);
/// The fixed rotation that turns z onto `axis` (unit).
Eigen::Matrix3d AxisAlignment(const Eigen::Vector3d& axis);

}  // namespace robocal::urdf::internal
