// Fuzz target: the body of POST /v1/campaigns/{c}:fit (api::ParseFitRequest), against every preset, without
// and with reflectors (whose offsets a request may name).
#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace robocal;
  const std::optional<nlohmann::json> body = fuzz::Body(data, size);
  if (!body) return 0;
  const std::vector<Reflector> nests = {{"smr1", {60.0, 0.0, 20.0}, false}, {"smr2", {-30.0, 52.0, 20.0}, true}};
  for (const RobotModel& model : fuzz::Presets()) for (const bool with_nests : {false, true}) {
    const std::vector<Reflector> reflectors = with_nests ? nests : std::vector<Reflector>{};
    const auto parse = [&](const nlohmann::json& b) {
      return api::ParseFitRequest(b, model, api::Limits{}, reflectors);
    };
    const auto request = fuzz::Parsed([&] { return parse(*body); });
    if (!request) continue;
    // The identification looks each name up and indexes with the result.
    for (const std::string& name : request->parameters) {
      fuzz::Check(ParameterIndex(model, reflectors, name) >= 0, "every accepted parameter name is the fit's");
    }
    // The core's options must accept whatever the request accepted (outlier_probability above all).
    std::string error;
    const MeasurementType type = with_nests ? MeasurementType::kPosition : MeasurementType::kPose;
    fuzz::Check(api::ToIdentificationOptions(*request, model, type, MeasurementNoise{}, reflectors).IsValid(&error),
                "an accepted fit request gives valid identification options");
    fuzz::CheckRoundTrip(*request, parse);
  }
  return 0;
}
