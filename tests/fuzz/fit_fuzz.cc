// Fuzz target: the body of POST /v1/campaigns/{c}:fit (api::ParseFitRequest), against every preset.
#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace robocal;
  const std::optional<nlohmann::json> body = fuzz::Body(data, size);
  if (!body) return 0;
  for (const RobotModel& model : fuzz::Presets()) {
    const auto parse = [&](const nlohmann::json& b) { return api::ParseFitRequest(b, model, api::Limits{}); };
    const auto request = fuzz::Parsed([&] { return parse(*body); });
    if (!request) continue;
    // The identification looks each name up and indexes with the result.
    for (const std::string& name : request->parameters) {
      fuzz::Check(model.ParameterIndex(name) >= 0, "every accepted parameter name is the model's");
    }
    // The core's options must accept whatever the request accepted (outlier_probability above all).
    std::string error;
    fuzz::Check(api::ToIdentificationOptions(*request, model, MeasurementType::kPose, MeasurementNoise{}).IsValid(&error),
                "an accepted fit request gives valid identification options");
    fuzz::CheckRoundTrip(*request, parse);
  }
  return 0;
}
