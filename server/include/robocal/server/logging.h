// Logging through spdlog in two formats: text (human) and json (one object per line, for log collectors).
#pragma once

#include <string>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

namespace robocal::server {

/// Sets the default logger's level (trace|debug|info|warn|error) and format (text|json).
void SetupLogging(const std::string& level, const std::string& format);

/// Logs `message` with structured `fields`: appended as key=value in text format, as members in json format.
void LogEvent(spdlog::level::level_enum level, const std::string& message, const nlohmann::json& fields = {});

}  // namespace robocal::server
