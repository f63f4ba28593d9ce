// Logging in text or json format.
#include "robocal/server/logging.h"

#include <atomic>

#include <spdlog/sinks/stdout_color_sinks.h>

namespace robocal::server {
namespace {
std::atomic<bool> json_format{false};
}  // namespace

void SetupLogging(const std::string& level, const std::string& format) {
  auto logger = spdlog::get("robocal");
  if (!logger) logger = spdlog::stderr_color_mt("robocal");
  spdlog::set_default_logger(logger);
  spdlog::set_level(spdlog::level::from_str(level));
  json_format = format == "json";
  // In json format the message itself is the rest of a JSON object (see LogEvent).
  spdlog::set_pattern(json_format ? R"({"time":"%Y-%m-%dT%H:%M:%S.%e%z","level":"%l",%v})"
                                  : "%Y-%m-%d %H:%M:%S.%e %^%l%$ %v");
}

void LogEvent(spdlog::level::level_enum level, const std::string& message, const nlohmann::json& fields) {
  if (!spdlog::should_log(level)) return;
  std::string text;
  if (json_format) {
    text = "\"msg\":" + nlohmann::json(message).dump();
    if (fields.is_object()) {
      for (auto it = fields.begin(); it != fields.end(); ++it) {
        text += "," + nlohmann::json(it.key()).dump() + ":" +
                it->dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
      }
    }
  } else {
    text = message;
    if (fields.is_object()) {
      for (auto it = fields.begin(); it != fields.end(); ++it) {
        text += " " + it.key() + "=" +
                (it->is_string() ? it->get<std::string>()
                                 : it->dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
      }
    }
  }
  spdlog::log(level, "{}", text);
}

}  // namespace robocal::server
