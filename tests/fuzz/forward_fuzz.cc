// Fuzz target: the body of POST /v1/robots/{r}:forward and /v1/campaigns/{c}:forward
// (api::ParseForwardRequest), against every preset.
#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace robocal;
  const std::optional<nlohmann::json> body = fuzz::Body(data, size);
  if (!body) return 0;
  const api::Limits limits;
  for (const RobotModel& model : fuzz::Presets()) {
    const auto parse = [&](const nlohmann::json& b) { return api::ParseForwardRequest(b, model, limits); };
    const auto request = fuzz::Parsed([&] { return parse(*body); });
    if (!request) continue;
    fuzz::Check(!request->joints.empty() && request->joints.size() <= limits.max_array_length,
                "the number of joint vectors within 1..max_array_length");
    // The service converts each vector to the core's units; a size the parser let through would throw there.
    for (const std::vector<double>& joints : request->joints) (void)api::JointsToCore(model, joints);
    fuzz::CheckRoundTrip(*request, parse);
  }
  return 0;
}
