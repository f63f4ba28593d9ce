// Core results -> wire JSON (mm and degrees). Non-finite numbers (an infinite condition number of a singular
// set) are written as null, since JSON has no Inf.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "robocal/api/types.h"
#include "robocal/core/accuracy.h"
#include "robocal/core/compensation.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/identification.h"
#include "robocal/core/observability.h"
#include "robocal/core/planning.h"
#include "robocal/core/robot_model.h"
#include "robocal/core/transforms.h"

namespace robocal::api {

/// A number, or null if not finite.
nlohmann::json Num(double value);

/// {"position_mm":[...],"quaternion":[w,x,y,z],"rpy_deg":[...]}.
nlohmann::json PoseToJson(const Transform& pose);
Transform PoseToTransform(const PoseWire& pose);
PoseWire TransformToPose(const Transform& pose);

/// The robot resource: id, name, preset flag, convention, joints (type, unit, limits), base, tool, and
/// error parameter names.
nlohmann::json RobotToJson(const std::string& id, const RobotModel& model, bool preset,
                           const std::string& description);

nlohmann::json IndicesToJson(const ObservabilityIndices& indices);
nlohmann::json PlanSummaryToJson(const PlanSummary& summary);
nlohmann::json PredictedAccuracyToJson(const PredictedAccuracy& accuracy);
nlohmann::json DroppedToJson(const std::vector<DroppedParameter>& dropped);
nlohmann::json NoiseToJson(const NoiseWire& noise);

/// Residual statistics in mm and degrees.
nlohmann::json ResidualsToJson(const ResidualStatistics& stats);
/// Parameters with std in mm (translations) or degrees (rotations), base, tool, residuals, summary.
nlohmann::json CalibrationToJson(const Calibration& calibration);
nlohmann::json CompensationResultToJson(const RobotModel& model, const CompensationResult& result);
/// Statistics in mm (E_xyz, E_tot) and degrees (E_cos).
nlohmann::json AccuracyReportToJson(const AccuracyReport& report);

}  // namespace robocal::api
