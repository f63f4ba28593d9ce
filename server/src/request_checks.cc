// Error replies and request head checks.
#include "request_checks.h"

#include <cctype>

#include "http_edge.h"

namespace robocal::server {

using api::Status;

void WriteError(httplib::Response& res, Status status, const std::string& message,
                const std::vector<api::FieldViolation>& details, int code) {
  if (code == 0) code = HttpStatusOf(status);
  try {
    res.status = code;
    res.set_content(api::ErrorBody(status, code, message, details).dump(), "application/json");
  } catch (...) {
    res.status = 500;
    res.set_content(kInternalErrorBody, "application/json");
  }
}

// A client's X-Request-Id is kept if it is short and of safe characters (it goes into logs and replies);
// otherwise the server makes its own.
bool UsableRequestId(const std::string& id) {
  if (id.empty() || id.size() > 128) return false;
  for (const char c : id) {
    const bool ok = std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.' || c == ':' ||
                    c == '/' || c == '+' || c == '=' || c == '@';
    if (!ok) return false;
  }
  return true;
}

// The member of a header as received, all of it (the library's get_header_value stops at a NUL byte).
const std::string* RawHeader(const httplib::Request& req, const char* name) {
  const auto it = req.headers.find(name);
  return it == req.headers.end() ? nullptr : &it->second;
}

namespace {

bool HasControlBytes(const std::string& text) {
  for (const char c : text) {
    const auto b = static_cast<unsigned char>(c);
    if ((b < 0x20 && b != '\t') || b == 0x7F) return true;
  }
  return false;
}

}  // namespace

// No robocal reply is a byte-range resource, and the library would cut every reply, error bodies included, to
// the ranges a client names (building thousands of ranges in memory). HTTP lets a server ignore Range: the
// parsed ranges are dropped. The request object is the library's own non-const local; only its view here is
// const.
void IgnoreRanges(const httplib::Request& req) { const_cast<httplib::Request&>(req).ranges.clear(); }

// "application/json" or "application/json; charset=utf-8" (any case).
namespace {

bool IsJsonMediaType(const std::string& content_type) {
  std::string media = content_type.substr(0, content_type.find(';'));
  while (!media.empty() && (media.back() == ' ' || media.back() == '\t')) media.pop_back();
  for (char& c : media) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return media == "application/json";
}

}  // namespace

// Checks of the request head that the library leaves to the application, made before it reads any body:
// header bytes, body framing and size, and the media type. Returns false after writing the error reply.
bool CheckHead(const httplib::Request& req, httplib::Response& res, std::int64_t max_body_bytes) {
  for (const auto& [name, value] : req.headers) {
    if (HasControlBytes(name) || HasControlBytes(value)) {
      WriteError(res, Status::kInvalidArgument, "a request header holds control characters",
                 {{"header " + name, "control characters (such as NUL) are not allowed in header values"}});
      return false;
    }
  }
  const bool may_carry_body = req.method == "POST" || req.method == "PUT" || req.method == "PATCH" ||
                              req.method == "DELETE" || req.method == "PRI";
  const std::string* length = RawHeader(req, "Content-Length");
  const std::string* encoding = RawHeader(req, "Transfer-Encoding");
  if (!may_carry_body) {
    // The library never reads a GET's body, so one would be parsed as the next request on the connection: a
    // request smuggled past whatever checked the first.
    if (encoding != nullptr || (length != nullptr && *length != "0")) {
      WriteError(res, Status::kInvalidArgument, req.method + " requests carry no body",
                 {{"body", "not allowed on " + req.method + " (no Content-Length or Transfer-Encoding)"}});
      return false;
    }
    return true;
  }
  if (const std::string* coding = RawHeader(req, "Content-Encoding"); coding != nullptr && *coding != "identity") {
    WriteError(res, Status::kInvalidArgument, "compressed request bodies are not accepted",
               {{"Content-Encoding", "send the body uncompressed (got \"" + *coding + "\")"}});
    edge::CloseAfterResponse();
    return false;
  }
  if (encoding != nullptr && (length != nullptr || *encoding != "chunked")) {
    WriteError(res, Status::kInvalidArgument, "unsupported body framing",
               {{"Transfer-Encoding", length != nullptr ? "not allowed together with Content-Length"
                                                        : "only chunked is accepted"}});
    edge::CloseAfterResponse();
    return false;
  }
  if (length != nullptr) {
    const bool digits = !length->empty() && length->size() <= 18 &&
                        length->find_first_not_of("0123456789") == std::string::npos;
    if (!digits) {
      WriteError(res, Status::kInvalidArgument, "malformed Content-Length",
                 {{"Content-Length", "expected a decimal byte count"}});
      edge::CloseAfterResponse();
      return false;
    }
    if (std::stoll(*length) > max_body_bytes) {
      WriteError(res, Status::kResourceExhausted, "request body larger than max_body_bytes",
                 {{"body", "Content-Length " + *length + " exceeds the max_body_bytes limit (" +
                               std::to_string(max_body_bytes) + ")"}});
      edge::CloseAfterResponse();
      return false;
    }
  }
  if (length == nullptr && encoding == nullptr) {
    if (req.method == "POST") {
      WriteError(res, Status::kInvalidArgument, "a POST needs a body",
                 {{"body", "missing: send a JSON object ({} for the defaults) with Content-Length or chunked"}});
      return false;
    }
    edge::NoBody();
    return true;
  }
  if (req.method == "POST") {
    const std::string* type = RawHeader(req, "Content-Type");
    if (type == nullptr || !IsJsonMediaType(*type)) {
      WriteError(res, Status::kInvalidArgument, "request bodies are JSON",
                 {{"Content-Type", type == nullptr ? "missing: send Content-Type: application/json"
                                                   : "expected application/json, got \"" + *type + "\""}});
      edge::CloseAfterResponse();
      return false;
    }
  }
  return true;
}

}  // namespace robocal::server
