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
/// The "result" of a plan operation.
struct PlanOperationResult {
  std::string plan;
};
template <>
struct WireFields<PlanOperationResult> {
  static constexpr auto fields = std::make_tuple(Field{"plan", &PlanOperationResult::plan});
};
ROBOCAL_WIRE_DECLARE(PlanOperationResult);
template <>
struct WireFields<Operation> {
  using S = Operation;
  static constexpr bool (*kPlanKind)(const S&) = +[](const S& op) { return op.kind == OperationKind::kPlan; };
  static constexpr bool (*kFitKind)(const S&) = +[](const S& op) { return op.kind != OperationKind::kPlan; };
  static constexpr auto fields = std::make_tuple(
      Field{"id", &S::id},
      Field{"kind", &S::kind},
      Field{"state", &S::state},
      Field{"done", &S::done},
      Field{"progress", &S::progress},
      Field{"created_unix_ms", &S::created_unix_ms},
      Field{"updated_unix_ms", &S::updated_unix_ms},
      Field{"cancel_requested", &S::cancel_requested},
      Field{"campaign", &S::campaign, Presence::kOmitEmpty},
      // The request and the result of the operation's kind.
      Field{"request", &S::plan_request, Presence::kOmitEmpty}.When(kPlanKind),
      Field{"request", &S::fit_request, Presence::kOmitEmpty}.When(kFitKind),
      Computed<S>{"result",
                  +[](const S& op, nlohmann::json* value) {
                    if (op.plan) *value = PlanOperationResult{*op.plan};
                    return op.plan.has_value();
                  },
                  +[](const nlohmann::json* value, const std::string& path, S* op) {
                    if (value == nullptr || op->kind != OperationKind::kPlan) return;
                    PlanOperationResult result;
                    ReadWire(*value, path, &result);
                    op->plan = result.plan;
                  }},
      Field{"result", &S::fit, Presence::kOmitEmpty}.When(kFitKind),
      Field{"error", &S::error, Presence::kOmitEmpty});
};
ROBOCAL_WIRE_DECLARE(Operation);

}  // namespace robocal::api
