// The operation and health shapes' to_json / from_json (their field tables: operations.h, health.h).
#include "robocal/api/health.h"
#include "robocal/api/operations.h"

namespace robocal::api {

// The shapes' to_json / from_json, instantiated here once (ROBOCAL_WIRE_DECLARE).
ROBOCAL_WIRE_DEFINE(Health);
ROBOCAL_WIRE_DEFINE(PlanOperationResult);
ROBOCAL_WIRE_DEFINE(Operation);

}  // namespace robocal::api
