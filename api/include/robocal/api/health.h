// Wire shape of the health check.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "robocal/api/wire.h"

namespace robocal::api {

/// GET /healthz.
struct Health {
  std::string status;  // "ok"
  std::string version;
};
template <>
struct WireFields<Health> {
  using S = Health;
  static constexpr auto fields = std::make_tuple(
      Field{"status", &S::status},
      Field{"version", &S::version});
};
ROBOCAL_WIRE_DECLARE(Health);

}  // namespace robocal::api
