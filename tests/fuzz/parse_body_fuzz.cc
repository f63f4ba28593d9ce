// Fuzz target: api::ParseBody, the first thing every route does with a request's bytes.
#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using robocal::fuzz::Check;
  const std::optional<nlohmann::json> body = robocal::fuzz::Body(data, size);
  if (!body) return 0;
  Check(body->is_object(), "ParseBody returns an object");
  // What the server accepted it can write back (responses echo ids and names), and that text reads back
  // as the same document.
  const std::optional<nlohmann::json> again =
      robocal::fuzz::Parsed([&] { return robocal::api::ParseBody(body->dump()); });
  Check(again.has_value() && *again == *body, "an accepted body dumps to text that parses to the same body");
  return 0;
}
