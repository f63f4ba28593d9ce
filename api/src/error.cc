// The API's error model.
#include "robocal/api/error.h"

#include <array>
#include <utility>

#include "robocal/api/text.h"
#include "robocal/api/wire.h"

namespace robocal::api {
namespace {

constexpr std::array<std::pair<Status, const char*>, 11> kStatusNames = {{
    {Status::kInvalidArgument, "INVALID_ARGUMENT"},
    {Status::kFailedPrecondition, "FAILED_PRECONDITION"},
    {Status::kNotFound, "NOT_FOUND"},
    {Status::kAlreadyExists, "ALREADY_EXISTS"},
    {Status::kAborted, "ABORTED"},
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

ErrorInfo MakeErrorInfo(Status status, int http_code, const std::string& message,
                        const std::vector<FieldViolation>& details) {
  return {http_code, status, SafeText(message), SafeDetails(details)};
}

nlohmann::json ErrorBody(Status status, int http_code, const std::string& message,
                         const std::vector<FieldViolation>& details) {
  return {{"error", MakeErrorInfo(status, http_code, message, details)}};
}

int HttpStatusOf(Status status) {
  switch (status) {
    case Status::kInvalidArgument:
      return 400;
    case Status::kFailedPrecondition:
      return 400;
    case Status::kNotFound:
      return 404;
    case Status::kAlreadyExists:
      return 409;
    case Status::kAborted:
      return 409;
    case Status::kUnauthenticated:
      return 401;
    case Status::kPermissionDenied:
      return 403;
    case Status::kResourceExhausted:
      return 413;
    case Status::kInternal:
      return 500;
    case Status::kUnavailable:
      return 503;
    case Status::kDeadlineExceeded:
      return 408;
  }
  return 500;
}

void Problems::ThrowIfAny(const std::string& what) const {
  if (list_.empty()) return;
  std::string message = what + ": " + list_.front().field + ": " + list_.front().reason;
  if (count_ > 1) message += " (and " + std::to_string(count_ - 1) + " more)";
  if (count_ > list_.size()) message += "; the first " + std::to_string(list_.size()) + " are listed";
  throw ApiError(Status::kInvalidArgument, message, list_);
}

}  // namespace robocal::api
