// The API's error model: a canonical status, a message and per-field violations. HTTP codes are chosen by the
// server (one mapping there); this part knows only the statuses and the JSON shape of an error body.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace robocal::api {

/// Canonical error statuses (the names of Google's API design guide).
enum class Status {
  kInvalidArgument,
  kFailedPrecondition,
  kNotFound,
  kAlreadyExists,
  /// A concurrent change won (a stored document's version moved on); read it again and retry (HTTP 409).
  kAborted,
  kUnauthenticated,
  kPermissionDenied,
  kResourceExhausted,
  kInternal,
  kUnavailable,
  /// The client did not send its request within the server's deadline (HTTP 408).
  kDeadlineExceeded,
};

/// "INVALID_ARGUMENT", "NOT_FOUND", ...
const char* ToString(Status status);
/// Inverse of ToString; false if unknown.
bool ParseStatus(const std::string& text, Status* status);
/// The HTTP status code of a canonical status: the one mapping, used by the server for every reply and by the
/// services for the errors of operations.
int HttpStatusOf(Status status);

/// One problem with one field of a request, e.g. {"measurements[3].joints", "expected 6 values, got 5"}.
struct FieldViolation {
  std::string field;
  std::string reason;
};

/// An error the server turns into an error body. Thrown by validation and by the services. The message and
/// every detail pass through SafeText (text.h), so request bytes echoed in them are always valid UTF-8.
class ApiError : public std::runtime_error {
 public:
  ApiError(Status status, const std::string& message, std::vector<FieldViolation> details = {});
  Status status() const { return status_; }
  const std::vector<FieldViolation>& details() const { return details_; }

 private:
  Status status_;
  std::vector<FieldViolation> details_;
};

/// The "error" object of an error body, and the error of a FAILED operation (its field table: wire.h).
struct ErrorInfo {
  /// The HTTP status code.
  int code = 0;
  Status status = Status::kInternal;
  std::string message;
  std::vector<FieldViolation> details;
};
/// The ErrorInfo of `status`, with message, fields and reasons passed through SafeText (always serialisable).
ErrorInfo MakeErrorInfo(Status status, int http_code, const std::string& message,
                        const std::vector<FieldViolation>& details = {});

/// {"error":{"code":http_code,"status":"...","message":"...","details":[{"field":"...","reason":"..."}]}}
/// Message, fields and reasons pass through SafeText: the body can always be serialised.
nlohmann::json ErrorBody(Status status, int http_code, const std::string& message,
                         const std::vector<FieldViolation>& details = {});

/// Collects every violation found in a request before failing, so that a client sees all of them at once (the
/// first kMaxDetails of them in detail, with the count of the rest: a request of a million bad keys must not
/// make an error reply a hundred times its size).
class Problems {
 public:
  static constexpr std::size_t kMaxDetails = 100;
  void Add(const std::string& field, const std::string& reason) {
    if (list_.size() < kMaxDetails) list_.push_back({field, reason});
    ++count_;
  }
  bool empty() const { return count_ == 0; }
  /// All violations found, including those beyond kMaxDetails.
  std::size_t size() const { return count_; }
  const std::vector<FieldViolation>& list() const { return list_; }
  /// Throws ApiError(kInvalidArgument) listing every violation if there is any. `what` names the request,
  /// e.g. "invalid measurement batch".
  void ThrowIfAny(const std::string& what) const;

 private:
  std::vector<FieldViolation> list_;
  std::size_t count_ = 0;
};

}  // namespace robocal::api
