// Wire shape of long-running operations (async plans and fits).
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "robocal/api/calibration.h"
#include "robocal/api/error.h"
#include "robocal/api/plans.h"
#include "robocal/api/wire.h"

namespace robocal::api {

/// GET /v1/operations/{op}, the reply of an async POST /v1/plans or :fit, and of :cancel.
struct Operation {
  std::string id;
  OperationKind kind = OperationKind::kPlan;
  OperationState state = OperationState::kRunning;
  bool done = false;
  /// 0..1.
  double progress = 0.0;
  std::int64_t created_unix_ms = 0;
  std::int64_t updated_unix_ms = 0;
  /// A cancel was asked for and the work has not stopped yet.
  bool cancel_requested = false;
  /// Fits: the campaign.
  std::optional<std::string> campaign;
  /// The request that started it (the one matching `kind`).
  std::optional<PlanRequest> plan_request;
  std::optional<FitRequest> fit_request;
  /// Plans, once SUCCEEDED or CANCELLED (a best-so-far plan): the plan's id (result {"plan": id}).
  std::optional<std::string> plan;
  /// Fits, once SUCCEEDED (stored as the calibration) or CANCELLED (best so far, not stored).
  std::optional<CalibrationResult> fit;
  /// FAILED: why.
  std::optional<ErrorInfo> error;
};
void to_json(nlohmann::json& j, const Operation& op);
void from_json(const nlohmann::json& j, Operation& op);

}  // namespace robocal::api
