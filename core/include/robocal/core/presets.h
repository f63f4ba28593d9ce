// Robot presets: grinder5 (the paper's PPPRR grinding robot), puma560 (Corke's DH), ur5e (manufacturer's DH).
#pragma once

#include <string>
#include <vector>

#include "robocal/core/robot_model.h"

namespace robocal {

/// Names of the built-in presets, in a fixed order: "grinder5", "puma560", "ur5e".
std::vector<std::string> PresetNames();

/// One-line description of a preset (geometry source, tool). Throws std::invalid_argument if unknown.
std::string PresetDescription(const std::string& name);

/// The spec of a preset, to build as is or to edit first (e.g. another tool). Throws std::invalid_argument
/// if `name` is not a preset.
RobotModelSpec PresetSpec(const std::string& name);

/// The built preset model.
RobotModel Preset(const std::string& name);

}  // namespace robocal
