// What the fuzz targets share: the request text read as the server reads it, the outcomes a parser may
// legitimately have (a result, or an ApiError naming fields), the presets that model-bound parsers are fed
// with, and properties that abort. Anything a target does not expect (another exception, a sanitizer report, a
// failed property) must crash, so that libFuzzer and the replay both stop and name the input.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "robocal/api/error.h"
#include "robocal/api/json_reader.h"
#include "robocal/api/calibration.h"
#include "robocal/api/campaigns.h"
#include "robocal/api/plans.h"
#include "robocal/api/robots.h"
#include "robocal/api/wire.h"
#include "robocal/core/presets.h"
#include "robocal/core/robot_model.h"

namespace robocal::fuzz {

/// Aborts with `what` when a property does not hold: to the fuzzer a broken property is a crash.
inline void Check(bool holds, const char* what) {
  if (!holds) {
    std::fprintf(stderr, "fuzz property failed: %s\n", what);
    std::abort();
  }
}

inline std::string Text(const std::uint8_t* data, std::size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

/// Runs a request parser. A refusal is an expected outcome only as the documented ApiError: INVALID_ARGUMENT
/// naming at least one field (the client is told what to fix). Returns the parsed request, or nullopt when
/// refused; any other exception escapes and crashes the target.
template <typename Parse>
auto Parsed(Parse parse) -> std::optional<decltype(parse())> {
  try {
    return parse();
  } catch (const api::ApiError& e) {
    Check(e.status() == api::Status::kInvalidArgument, "a refused request is INVALID_ARGUMENT");
    Check(!e.details().empty(), "a refused request names at least one field");
    return std::nullopt;
  }
}

/// The body as the server's routes read it (api::ParseBody), or nullopt when ParseBody refuses it.
inline std::optional<nlohmann::json> Body(const std::uint8_t* data, std::size_t size) {
  return Parsed([&] { return api::ParseBody(Text(data, size)); });
}

/// The presets, built once: the robots a model-bound parser is checked against (every joint count and both
/// joint types occur among them).
inline const std::vector<RobotModel>& Presets() {
  static const std::vector<RobotModel> models = [] {
    std::vector<RobotModel> result;
    for (const std::string& name : PresetNames()) result.push_back(Preset(name));
    return result;
  }();
  return models;
}

/// Equal JSON, numbers within a relative 1e-12: a parser may renormalise a quaternion it reads back, which
/// moves the last bit, and that is not a difference a client could notice.
inline bool SameJson(const nlohmann::json& a, const nlohmann::json& b) {
  if (a.is_number() && b.is_number()) {
    const double x = a.get<double>(), y = b.get<double>();
    return std::abs(x - y) <= 1e-12 * std::max({1.0, std::abs(x), std::abs(y)});
  }
  if (a.type() != b.type() || a.size() != b.size()) return false;
  if (a.is_object()) {
    for (auto it = a.begin(); it != a.end(); ++it) {
      if (!b.contains(it.key()) || !SameJson(it.value(), b.at(it.key()))) return false;
    }
    return true;
  }
  if (a.is_array()) {
    for (std::size_t i = 0; i < a.size(); ++i) {
      if (!SameJson(a[i], b[i])) return false;
    }
    return true;
  }
  return a == b;
}

/// The client sends ToJson(request) and the server parses it; the server also stores ToJson(request) and
/// parses it again later. So whatever a parser accepts must serialise to text that it accepts again, with the
/// same meaning. `parse` reads a JSON value.
template <typename Request, typename Parse>
void CheckRoundTrip(const Request& request, Parse parse) {
  const nlohmann::json written = nlohmann::json(request);
  // Through text, as on the wire: dump() also proves every string in it is valid UTF-8.
  const auto again = Parsed([&] { return parse(api::ParseBody(written.dump())); });
  Check(again.has_value(), "a parsed request's ToJson parses again");
  Check(SameJson(nlohmann::json(*again), written), "a parsed request's ToJson reads back the same");
  // The strict structural reader (what a stored or echoed request goes through) reads it back the same too.
  Check(SameJson(nlohmann::json(api::FromWire<Request>(written)), written),
        "a parsed request's JSON reads back the same through from_json");
}

}  // namespace robocal::fuzz
