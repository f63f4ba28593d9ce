// Fuzz target: the body of POST /v1/campaigns/{c}:evaluate (api::ParseEvaluateRequest).
#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace robocal;
  const std::optional<nlohmann::json> body = fuzz::Body(data, size);
  if (!body) return 0;
  const auto parse = [](const nlohmann::json& b) { return api::ParseEvaluateRequest(b); };
  if (const auto request = fuzz::Parsed([&] { return parse(*body); })) {
    fuzz::Check(request->h_mm > 0.0 && std::isfinite(request->h_mm), "h_mm is positive and finite");
    fuzz::CheckRoundTrip(*request, parse);
  }
  return 0;
}
