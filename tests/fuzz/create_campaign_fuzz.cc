// Fuzz target: the body of POST /v1/campaigns (api::ParseCreateCampaignRequest).
#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace robocal;
  const std::optional<nlohmann::json> body = fuzz::Body(data, size);
  if (!body) return 0;
  const auto parse = [](const nlohmann::json& b) { return api::ParseCreateCampaignRequest(b); };
  if (const auto request = fuzz::Parsed([&] { return parse(*body); })) {
    // A campaign id becomes a storage key and a path segment; only the documented id syntax may pass.
    fuzz::Check(request->id.empty() || api::IsValidId(request->id), "a given campaign id is a valid id");
    // The fit builds its noise from these: whatever is accepted must be a noise the core takes.
    std::string error;
    fuzz::Check(api::NoiseOf(*request).IsValid(&error),
                "an accepted tracker model and repeatability are a valid core noise");
    fuzz::CheckRoundTrip(*request, parse);
  }
  return 0;
}
