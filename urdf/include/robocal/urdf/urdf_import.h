// URDF import: the chain of a robot description from a base link down to a tip link as a robocal robot
// definition (transform convention), read with liburdfdom (docs/formats.md).
#pragma once

#include <string>

#include "robocal/api/robots.h"

namespace robocal::urdf {

/// The robot definition of `request`'s chain: one transform-convention joint per revolute, continuous or
/// prismatic URDF joint (its name kept), fixed joints folded into the next moving joint's transform and those
/// after the last one into the flange (so that the flange is the tip link's frame), an axis other than +z
/// turned onto z by a fixed rotation that the next transform undoes, limits in degrees and mm (a continuous
/// joint gets -360..360 degrees). The URDF document is kept in the definition for the calibrated export.
///
/// Throws api::ApiError (kInvalidArgument) naming the field ("urdf", "base_link", "tip_link", "id") and, for
/// the document, the element: malformed XML, an unknown link, a tip not below the base, a joint without
/// limits, a mimic, floating or planar joint, a joint name robocal cannot use.
api::RegisterRobotRequest ImportUrdf(const api::ImportUrdfRequest& request);

}  // namespace robocal::urdf
