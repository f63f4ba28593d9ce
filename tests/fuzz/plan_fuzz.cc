// Fuzz target: the body of POST /v1/plans (api::ParsePlanRequest) under the default limits.
#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace robocal;
  const std::optional<nlohmann::json> body = fuzz::Body(data, size);
  if (!body) return 0;
  const api::Limits limits;
  const auto parse = [&](const nlohmann::json& b) { return api::ParsePlanRequest(b, limits); };
  if (const auto request = fuzz::Parsed([&] { return parse(*body); })) {
    // The planner sizes its work from these; the limits are the server's protection against huge plans.
    fuzz::Check(request->num_configurations >= 1 && request->num_configurations <= limits.max_plan_configurations,
                "num_configurations within the limit");
    fuzz::Check(request->options.k_max <= limits.max_plan_evaluations &&
                    request->options.max_evaluations <= limits.max_plan_evaluations,
                "the optimiser's budget within the limit");
    // Nests: few, and only with position measurements (the planner's rows per configuration and its memory).
    fuzz::Check(request->reflectors.size() <= static_cast<std::size_t>(api::kMaxPlanReflectors) &&
                    (request->reflectors.empty() || request->measurement_type == MeasurementType::kPosition),
                "reflectors few and with position measurements only");
    fuzz::CheckRoundTrip(*request, parse);
  }
  return 0;
}
