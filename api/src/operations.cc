// Operations and the health check on the wire.
#include "robocal/api/operations.h"

#include "robocal/api/health.h"

namespace robocal::api {

void to_json(nlohmann::json& j, const Operation& op) {
  j = {{"id", op.id},
       {"kind", op.kind},
       {"state", op.state},
       {"done", op.done},
       {"progress", Num(op.progress)},
       {"created_unix_ms", op.created_unix_ms},
       {"updated_unix_ms", op.updated_unix_ms},
       {"cancel_requested", op.cancel_requested}};
  if (op.campaign) j["campaign"] = *op.campaign;
  if (op.plan_request) j["request"] = *op.plan_request;
  if (op.fit_request) j["request"] = *op.fit_request;
  if (op.plan) j["result"] = {{"plan", *op.plan}};
  if (op.fit) j["result"] = *op.fit;
  if (op.error) j["error"] = *op.error;
}

void from_json(const nlohmann::json& j, Operation& op) {
  const WireReader r(j);
  r.Required("id", &op.id);
  r.Required("kind", &op.kind);
  r.Required("state", &op.state);
  r.Required("done", &op.done);
  r.Required("progress", &op.progress);
  r.Required("created_unix_ms", &op.created_unix_ms);
  r.Required("updated_unix_ms", &op.updated_unix_ms);
  r.Required("cancel_requested", &op.cancel_requested);
  r.Optional("campaign", &op.campaign);
  if (op.kind == OperationKind::kPlan) {
    r.Optional("request", &op.plan_request);
    if (r.Has("result")) {
      std::string plan;
      WireReader(r.Member("result"), "result").Required("plan", &plan);
      op.plan = plan;
    }
  } else {
    r.Optional("request", &op.fit_request);
    r.Optional("result", &op.fit);
  }
  r.Optional("error", &op.error);
}

}  // namespace robocal::api
