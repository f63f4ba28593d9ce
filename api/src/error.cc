// The API's error model.
#include "robocal/api/error.h"

#include <array>
#include <utility>

namespace robocal::api {
namespace {

constexpr std::array<std::pair<Status, const char*>, 9> kStatusNames = {{
    {Status::kInvalidArgument, "INVALID_ARGUMENT"},
    {Status::kFailedPrecondition, "FAILED_PRECONDITION"},
    {Status::kNotFound, "NOT_FOUND"},
    {Status::kAlreadyExists, "ALREADY_EXISTS"},
    {Status::kUnauthenticated, "UNAUTHENTICATED"},
    {Status::kPermissionDenied, "PERMISSION_DENIED"},
    {Status::kResourceExhausted, "RESOURCE_EXHAUSTED"},
    {Status::kInternal, "INTERNAL"},
    {Status::kUnavailable, "UNAVAILABLE"},
}};

}  // namespace

const char* ToString(Status status) {
  for (const auto& [s, name] : kStatusNames) {
    if (s == status) return name;
  }
  return "INTERNAL";
}

bool ParseStatus(const std::string& text, Status* status) {
  for (const auto& [s, name] : kStatusNames) {
    if (text == name) {
      *status = s;
      return true;
    }
  }
  return false;
}

ApiError::ApiError(Status status, const std::string& message, std::vector<FieldViolation> details)
    : std::runtime_error(message), status_(status), details_(std::move(details)) {}

nlohmann::json ErrorBody(Status status, int http_code, const std::string& message,
                         const std::vector<FieldViolation>& details) {
  nlohmann::json detail_list = nlohmann::json::array();
  for (const FieldViolation& d : details) detail_list.push_back({{"field", d.field}, {"reason", d.reason}});
  return {{"error",
           {{"code", http_code}, {"status", ToString(status)}, {"message", message}, {"details", detail_list}}}};
}

void Problems::ThrowIfAny(const std::string& what) const {
  if (list_.empty()) return;
  std::string message = what + ": " + list_.front().field + ": " + list_.front().reason;
  if (list_.size() > 1) message += " (and " + std::to_string(list_.size() - 1) + " more)";
  throw ApiError(Status::kInvalidArgument, message, list_);
}

}  // namespace robocal::api
