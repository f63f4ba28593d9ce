// The API's error model.
#include "robocal/api/error.h"

#include <array>
#include <utility>

#include "robocal/api/text.h"

namespace robocal::api {
namespace {

constexpr std::array<std::pair<Status, const char*>, 10> kStatusNames = {{
    {Status::kInvalidArgument, "INVALID_ARGUMENT"},
    {Status::kFailedPrecondition, "FAILED_PRECONDITION"},
    {Status::kNotFound, "NOT_FOUND"},
    {Status::kAlreadyExists, "ALREADY_EXISTS"},
    {Status::kUnauthenticated, "UNAUTHENTICATED"},
    {Status::kPermissionDenied, "PERMISSION_DENIED"},
    {Status::kResourceExhausted, "RESOURCE_EXHAUSTED"},
    {Status::kInternal, "INTERNAL"},
    {Status::kUnavailable, "UNAVAILABLE"},
    {Status::kDeadlineExceeded, "DEADLINE_EXCEEDED"},
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

namespace {
std::vector<FieldViolation> SafeDetails(std::vector<FieldViolation> details) {
  for (FieldViolation& d : details) {
    d.field = SafeText(d.field, 256);
    d.reason = SafeText(d.reason);
  }
  return details;
}
}  // namespace

ApiError::ApiError(Status status, const std::string& message, std::vector<FieldViolation> details)
    : std::runtime_error(SafeText(message)), status_(status), details_(SafeDetails(std::move(details))) {}

nlohmann::json ErrorBody(Status status, int http_code, const std::string& message,
                         const std::vector<FieldViolation>& details) {
  nlohmann::json detail_list = nlohmann::json::array();
  for (const FieldViolation& d : details) {
    detail_list.push_back({{"field", SafeText(d.field, 256)}, {"reason", SafeText(d.reason)}});
  }
  return {{"error",
           {{"code", http_code},
            {"status", ToString(status)},
            {"message", SafeText(message)},
            {"details", detail_list}}}};
}

void Problems::ThrowIfAny(const std::string& what) const {
  if (list_.empty()) return;
  std::string message = what + ": " + list_.front().field + ": " + list_.front().reason;
  if (count_ > 1) message += " (and " + std::to_string(count_ - 1) + " more)";
  if (count_ > list_.size()) message += "; the first " + std::to_string(list_.size()) + " are listed";
  throw ApiError(Status::kInvalidArgument, message, list_);
}

}  // namespace robocal::api
