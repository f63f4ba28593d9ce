// Wire shape of the health check.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace robocal::api {

/// GET /healthz.
struct Health {
  std::string status;  // "ok"
  std::string version;
};
void to_json(nlohmann::json& j, const Health& h);
void from_json(const nlohmann::json& j, Health& h);

}  // namespace robocal::api
