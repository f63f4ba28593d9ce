// Fuzz target: the HTTP edge's error path. The server turns every error into
// api::ErrorBody(status, code, what(), details).dump() (server/src/http_server.cc); whatever bytes the error
// carries, that must be a valid JSON document (and so valid UTF-8) saying the same thing. Two sources of
// errors: the parsers' own, on the input as a request body, and the input's bytes taken as message, fields
// and reasons directly (an error may quote anything a client sent).
#include "fuzz_util.h"
#include "robocal/api/text.h"

namespace {

using namespace robocal;
using fuzz::Check;

// The error body as the server sends it must parse, carry the status and one entry per violation, and carry
// each text as api::SafeText makes it (unchanged when it is valid UTF-8 without control characters and short;
// text.h), never a raw control byte.
void CheckErrorBody(api::Status status, const std::string& message, const std::vector<api::FieldViolation>& details) {
  const std::string text = api::ErrorBody(status, 400, message, details).dump();
  nlohmann::json body;
  try {
    body = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error&) {
    Check(false, "the error body is valid JSON");
  }
  const nlohmann::json& error = body.at("error");
  Check(error.at("status") == api::ToString(status), "the error body carries the status");
  Check(error.at("code") == 400, "the error body carries the HTTP code");
  Check(error.at("details").size() == details.size(), "one detail per violation");
  Check(error.at("message") == api::SafeText(message), "the message is sent as SafeText makes it");
  for (const char c : error.at("message").get<std::string>()) {
    Check(static_cast<unsigned char>(c) >= 0x20 && c != 0x7F, "no control byte in a message");
  }
  for (std::size_t i = 0; i < details.size(); ++i) {
    const nlohmann::json& d = error.at("details")[i];
    Check(d.at("field") == api::SafeText(details[i].field, 256), "a field is sent as SafeText makes it");
    Check(d.at("reason") == api::SafeText(details[i].reason), "a reason is sent as SafeText makes it");
  }
}

// Runs one parser on the body and renders its error the way the server's exception handler does: ApiError with
// its own status and details, a core std::invalid_argument as INVALID_ARGUMENT with its message.
template <typename Parse>
void RenderErrorOf(Parse parse) {
  try {
    parse();
  } catch (const api::ApiError& e) {
    CheckErrorBody(e.status(), e.what(), e.details());
  } catch (const std::invalid_argument& e) {
    CheckErrorBody(api::Status::kInvalidArgument, e.what(), {});
  }
}

void ParserErrors(const std::string& text) {
  nlohmann::json body;
  RenderErrorOf([&] { body = api::ParseBody(text); });
  if (body.is_null()) return;
  const api::Limits limits;
  const RobotModel& model = fuzz::Presets().front();
  RenderErrorOf([&] { api::ParseRegisterRobotRequest(body, limits); });
  RenderErrorOf([&] { api::ParseForwardRequest(body, model, limits); });
  RenderErrorOf([&] { api::ParsePlanRequest(body, limits); });
  RenderErrorOf([&] { api::ParseCreateCampaignRequest(body); });
  RenderErrorOf([&] { api::ParseMeasurementBatchRequest(body, model, MeasurementType::kPose, limits); });
  RenderErrorOf([&] { api::ParseFitRequest(body, model, limits); });
  RenderErrorOf([&] { api::ParseCompensateRequest(body, model, limits); });
  RenderErrorOf([&] { api::ParseEvaluateRequest(body); });
}

// The input split at NUL bytes: a message, then field and reason pairs.
void DirectErrors(const std::string& text) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  for (std::size_t end; (end = text.find('\0', start)) != std::string::npos; start = end + 1) {
    parts.push_back(text.substr(start, end - start));
  }
  parts.push_back(text.substr(start));
  std::vector<api::FieldViolation> details;
  for (std::size_t i = 1; i + 1 < parts.size(); i += 2) details.push_back({parts[i], parts[i + 1]});
  CheckErrorBody(api::Status::kInvalidArgument, parts[0], details);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text = fuzz::Text(data, size);
  ParserErrors(text);
  DirectErrors(text);
  return 0;
}
