// Error replies and the checks of a request's head that the HTTP library leaves to the application.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <httplib.h>

#include "robocal/api/error.h"

namespace robocal::server {

// A fixed body for when writing the real one fails: it cannot fail itself.
constexpr const char* kInternalErrorBody =
    R"({"error":{"code":500,"status":"INTERNAL","message":"internal error","details":[]}})";

/// Writes the API's error body. `code` overrides the status's HTTP code where HTTP has a more precise one (414,
/// 431). Cannot throw: if the body cannot be written, kInternalErrorBody is.
void WriteError(httplib::Response& res, api::Status status, const std::string& message,
                const std::vector<api::FieldViolation>& details = {}, int code = 0);

/// A client's X-Request-Id is kept if it is short and of safe characters (it goes into logs and replies);
/// otherwise the server makes its own.
bool UsableRequestId(const std::string& id);

/// The member of a header as received, all of it (the library's get_header_value stops at a NUL byte).
const std::string* RawHeader(const httplib::Request& req, const char* name);

/// Drops the parsed byte ranges of a request (no robocal reply is a byte-range resource).
void IgnoreRanges(const httplib::Request& req);

/// Checks of the request head made before any body is read: header bytes, body framing and size, and the media
/// type. Returns false after writing the error reply.
bool CheckHead(const httplib::Request& req, httplib::Response& res, std::int64_t max_body_bytes);

}  // namespace robocal::server
