// robocal::Client against a server that answers canned bodies: a response without a field its resource requires
// is a ProtocolError naming the field (never a default), a body that is not JSON or not the API's error body is
// reported as such, and the request_id derived from a batch keeps its digits. Needs no robocal server.
#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include "robocal/api/wire.h"
#include "robocal/client/client.h"

// After Eigen (through the api headers): httplib pulls in <resolv.h>, whose `res` macro breaks Eigen's headers.
#include <httplib.h>

namespace robocal {
namespace {

using nlohmann::json;

// An HTTP server on a free loopback port answering every request with the reply set last.
class CannedServer {
 public:
  CannedServer() {
    auto handler = [this](const httplib::Request&, httplib::Response& res) {
      std::lock_guard<std::mutex> lock(mutex_);
      res.status = status_;
      res.set_content(body_, content_type_);
    };
    server_.Get(".*", handler);
    server_.Post(".*", handler);
    server_.Delete(".*", handler);
    port_ = server_.bind_to_any_port("127.0.0.1");
    if (port_ <= 0) throw std::runtime_error("cannot bind a port");
    thread_ = std::thread([this] { server_.listen_after_bind(); });
    while (!server_.is_running()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ~CannedServer() {
    server_.stop();
    thread_.join();
  }

  void Answer(int status, const std::string& body, const std::string& content_type = "application/json") {
    std::lock_guard<std::mutex> lock(mutex_);
    status_ = status;
    body_ = body;
    content_type_ = content_type;
  }
  void Answer(const json& body) { Answer(200, body.dump()); }

  ClientOptions Options() const {
    ClientOptions o;
    o.server_url = "http://127.0.0.1:" + std::to_string(port_);
    o.max_retries = 0;
    return o;
  }

 private:
  httplib::Server server_;
  int port_ = -1;
  std::thread thread_;
  std::mutex mutex_;
  int status_ = 200;
  std::string body_ = "{}";
  std::string content_type_ = "application/json";
};

api::Campaign SomeCampaign() {
  api::Campaign c;
  c.id = "c1";
  c.robot = "grinder5";
  c.plan = "plan-1";
  c.counts = {20, 10};
  c.calibrated = true;
  return c;
}

api::CalibrationResult SomeFit() {
  api::CalibrationResult fit;
  fit.campaign = "c1";
  fit.robot = "grinder5";
  fit.stored = true;
  fit.parameters = {{"X.dx", "mm", 0.1, 0.01}};
  fit.summary.termination = Termination::kConvergence;
  return fit;
}

// Erases the member at `path` (dots and [i]) from `body`.
json Without(json body, const std::string& path) {
  json* at = &body;
  std::string rest = path;
  for (;;) {
    const std::size_t dot = rest.find('.');
    std::string key = rest.substr(0, dot);
    std::size_t index = std::string::npos;
    if (const std::size_t bracket = key.find('['); bracket != std::string::npos) {
      index = std::stoul(key.substr(bracket + 1));
      key = key.substr(0, bracket);
    }
    if (dot == std::string::npos && index == std::string::npos) {
      at->erase(key);
      return body;
    }
    at = &(*at)[key];
    if (index != std::string::npos) at = &(*at)[index];
    rest = rest.substr(dot + 1);
  }
}

// The ProtocolError's message of `call` (fails the test if the call throws anything else or nothing).
std::string ProtocolErrorOf(const std::function<void()>& call) {
  try {
    call();
  } catch (const client::ProtocolError& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("not a ProtocolError: ") + e.what();
  }
  return "no error";
}

TEST(ProtocolTest, EveryFieldOfACampaignIsRequired) {
  CannedServer server;
  Client c(server.Options());
  const json full = SomeCampaign();
  server.Answer(full);
  const api::Campaign read = c.GetCampaign("c1");
  EXPECT_EQ(read.counts.calibration, 20);
  EXPECT_TRUE(read.calibrated);
  EXPECT_EQ(json(read), full);
  for (const std::string field : {"id", "description", "robot", "measurement_type", "plan", "noise",
                                  "created_unix_ms", "counts", "counts.calibration", "counts.validation",
                                  "calibrated", "noise.position_mm"}) {
    server.Answer(Without(full, field));
    const std::string message = ProtocolErrorOf([&] { c.GetCampaign("c1"); });
    EXPECT_NE(message.find("campaign response: " + field + ": required"), std::string::npos)
        << field << ": " << message;
  }
  // The request's measurement type is optional; a campaign's is not, not even as null.
  json no_type = full;
  no_type["measurement_type"] = nullptr;
  server.Answer(no_type);
  const std::string message = ProtocolErrorOf([&] { c.GetCampaign("c1"); });
  EXPECT_NE(message.find("campaign response: measurement_type: expected a string"), std::string::npos) << message;
}

// The defect of the first client: list items without calibrated and counts read as "not calibrated". Now an
// item without them is refused, naming the item and the field.
TEST(ProtocolTest, CampaignListItemsNeedCountsAndCalibrated) {
  CannedServer server;
  Client c(server.Options());
  api::CampaignList list;
  list.campaigns = {SomeCampaign(), SomeCampaign()};
  list.campaigns[1].id = "c2";
  list.campaigns[1].calibrated = false;
  server.Answer(json(list));
  const auto campaigns = c.ListCampaigns();
  ASSERT_EQ(campaigns.size(), 2u);
  EXPECT_TRUE(campaigns[0].calibrated);
  EXPECT_FALSE(campaigns[1].calibrated);
  for (const std::string field : {"campaigns[1].calibrated", "campaigns[0].counts"}) {
    server.Answer(Without(json(list), field));
    const std::string message = ProtocolErrorOf([&] { c.ListCampaigns(); });
    EXPECT_NE(message.find(field + ": required"), std::string::npos) << message;
  }
}

// stored and deadline_exceeded come from the server: a fit without them is refused, not read as a default.
TEST(ProtocolTest, AFitSaysWhetherItWasStored) {
  CannedServer server;
  Client c(server.Options());
  server.Answer(json(SomeFit()));
  EXPECT_TRUE(c.GetCalibration("c1").stored);
  for (const std::string field : {"stored", "summary.deadline_exceeded", "summary.termination", "parameters[0].std"}) {
    server.Answer(Without(json(SomeFit()), field));
    const std::string message = ProtocolErrorOf([&] { c.Fit("c1"); });
    EXPECT_NE(message.find("fit response: " + field + ": required"), std::string::npos) << message;
  }
  json unknown_termination = SomeFit();
  unknown_termination["summary"]["termination"] = "ALMOST";
  server.Answer(unknown_termination);
  EXPECT_NE(ProtocolErrorOf([&] { c.GetCalibration("c1"); }).find("summary.termination: unknown value \"ALMOST\""),
            std::string::npos);
}

TEST(ProtocolTest, OtherResourcesNameTheirFields) {
  CannedServer server;
  Client c(server.Options());
  api::Operation op;
  op.id = "op-1";
  op.kind = api::OperationKind::kFit;
  op.state = api::OperationState::kSucceeded;
  op.done = true;
  op.fit = SomeFit();
  server.Answer(Without(json(op), "result.stored"));
  EXPECT_NE(ProtocolErrorOf([&] { c.GetOperation("op-1"); }).find("operation response: result.stored: required"),
            std::string::npos);
  server.Answer(Without(json(op), "state"));
  EXPECT_NE(ProtocolErrorOf([&] { c.GetOperation("op-1"); }).find("state: required"), std::string::npos);

  api::CompensatedTargets compensated;
  compensated.campaign = "c1";
  compensated.results.resize(2);
  server.Answer(Without(json(compensated), "results[1].free_rotation_deg"));
  EXPECT_NE(ProtocolErrorOf([&] { c.CompensateJoints("c1", {{0, 0, 0, 0, 0}}); })
                .find("results[1].free_rotation_deg: required"),
            std::string::npos);

  server.Answer(json{{"status", "ok"}});
  EXPECT_NE(ProtocolErrorOf([&] { c.GetHealth(); }).find("version: required"), std::string::npos);
}

TEST(ProtocolTest, NotJsonIsAProtocolError) {
  CannedServer server;
  Client c(server.Options());
  server.Answer(200, "<html>hello</html>", "text/html");
  EXPECT_NE(ProtocolErrorOf([&] { c.GetCampaign("c1"); }).find("not JSON"), std::string::npos);
  server.Answer(200, "[1, 2]");
  EXPECT_NE(ProtocolErrorOf([&] { c.GetCampaign("c1"); }).find("campaign response"), std::string::npos);
}

TEST(ProtocolTest, ErrorBodies) {
  CannedServer server;
  Client c(server.Options());
  server.Answer(404, api::ErrorBody(api::Status::kNotFound, 404, "campaign \"c9\" not found", {{"campaign", "?"}})
                         .dump());
  try {
    c.GetCampaign("c9");
    FAIL() << "a 404 must throw";
  } catch (const client::ServiceError& e) {
    EXPECT_EQ(e.http_status(), 404);
    EXPECT_EQ(e.status(), api::Status::kNotFound);
    EXPECT_EQ(e.message(), "campaign \"c9\" not found");
    ASSERT_EQ(e.details().size(), 1u);
    EXPECT_EQ(e.details()[0].field, "campaign");
    EXPECT_NE(std::string(e.what()).find("NOT_FOUND"), std::string::npos);
  }
  // A gateway's own page: the status its code stands for, the body's start as the message.
  server.Answer(503, "<html>upstream down</html>", "text/html");
  try {
    c.GetCampaign("c9");
    FAIL() << "a 503 must throw";
  } catch (const client::ServiceError& e) {
    EXPECT_EQ(e.http_status(), 503);
    EXPECT_EQ(e.status(), api::Status::kUnavailable);
    EXPECT_NE(e.message().find("upstream down"), std::string::npos);
  }
}

// ContentRequestId hashes the batch's JSON (request_id empty) as the first client wrote it: a cell that
// uploaded a batch before keeps the same request_id, so the upload stays idempotent across client versions.
TEST(ProtocolTest, ContentRequestIdKeepsItsDigits) {
  api::MeasurementBatchRequest batch;
  batch.request_id = "ignored";
  batch.role = api::MeasurementRole::kValidation;
  api::MeasurementWire shot;
  shot.joints = {400.0, 300.0, 200.0, 10.0, -20.5};
  shot.pose.position_mm = {1.0, 2.0, 3.5};
  shot.pose.quaternion = {1.0, 0.0, 0.0, 0.0};
  batch.measurements = {shot};
  const std::string text =
      R"({"measurements":[{"joints":[400.0,300.0,200.0,10.0,-20.5],"pose":{"position_mm":[1.0,2.0,3.5],)"
      R"("quaternion":[1.0,0.0,0.0,0.0]}}],"request_id":"","role":"validation"})";
  EXPECT_EQ(client::ContentRequestId(batch), "auto-" + api::ContentHash(text));
  EXPECT_EQ(client::ContentRequestId(batch), "auto-1600b3456f572baa");
}

}  // namespace
}  // namespace robocal
