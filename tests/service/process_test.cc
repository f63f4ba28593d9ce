// The robocal-server binary as an operator runs it: HTTPS with a certificate and bearer tokens, one JSON log
// line per request, a graceful SIGTERM that cancels running operations and exits 0, and the refusals to start
// (non-loopback without tokens, unreadable TLS or token files, bad flags).
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <httplib.h>
#include <nlohmann/json.hpp>

#include "server/storage/storage.h"
#include "server_process.h"
// clang-format off
#include "raw_http.h"
// clang-format on

namespace robocal::server::testing {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

// A fresh directory for one test, removed at the end.
class TempDir {
 public:
  explicit TempDir(const std::string& name)
      : path_(fs::path(::testing::TempDir()) / (name + "_" + std::to_string(getpid()))) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string File(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

TEST(ProcessTest, ServesHttpsWithBearerTokens) {
  if (std::system("command -v openssl >/dev/null 2>&1") != 0) GTEST_SKIP() << "the openssl binary is not installed";
  TempDir dir("robocal_tls");
  const std::string cert = dir.File("cert.pem"), key = dir.File("key.pem"), tokens = dir.File("tokens");
  // A self-signed certificate for 127.0.0.1 (an EC key: generated in milliseconds).
  const std::string openssl =
      "openssl req -x509 -nodes -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -days 1"
      " -subj /CN=127.0.0.1 -addext subjectAltName=IP:127.0.0.1 -keyout " +
      key + " -out " + cert + " >/dev/null 2>&1";
  ASSERT_EQ(std::system(openssl.c_str()), 0) << openssl;
  std::ofstream(tokens) << "# test token\ntls-test-token\n";

  ServerProcess server({"--db", dir.File("robocal.db"), "--tls-cert", cert, "--tls-key", key, "--tokens-file", tokens,
                        "--log-level", "error", "--request-read-timeout-s", "1"});
  ASSERT_EQ(server.scheme(), "https");
  httplib::SSLClient client("127.0.0.1", server.port());
  // The client trusts only this certificate, so a successful call proves the server presented it.
  client.set_ca_cert_path(cert.c_str());
  client.enable_server_certificate_verification(true);

  auto health = client.Get("/healthz");
  ASSERT_TRUE(health) << httplib::to_string(health.error());
  EXPECT_EQ(health->status, 200);
  auto anonymous = client.Get("/v1/robots");
  ASSERT_TRUE(anonymous);
  EXPECT_EQ(anonymous->status, 401);
  EXPECT_EQ(json::parse(anonymous->body)["error"]["status"], "UNAUTHENTICATED");
  auto robots = client.Get("/v1/robots", {{"Authorization", "Bearer tls-test-token"}});
  ASSERT_TRUE(robots);
  EXPECT_EQ(robots->status, 200);
  EXPECT_EQ(json::parse(robots->body)["robots"].size(), 3u);

  // Plain HTTP to the HTTPS port gets no answer.
  httplib::Client plain("127.0.0.1", server.port());
  plain.set_read_timeout(5, 0);
  auto refused = plain.Get("/healthz");
  EXPECT_FALSE(refused && refused->status == 200);

  // A client that never completes its handshake is closed at the request deadline, not kept forever.
  RawConnection silent(server.port());
  RawConnection partial(server.port());
  partial.Send(std::string("\x16\x03\x01\x02\x00", 5));  // the start of a ClientHello, then nothing
  EXPECT_TRUE(silent.ClosedByServer(std::chrono::seconds(30)));
  EXPECT_TRUE(partial.ClosedByServer(std::chrono::seconds(30)));
  auto still = client.Get("/healthz");
  ASSERT_TRUE(still) << httplib::to_string(still.error());
  EXPECT_EQ(still->status, 200);
}

// The exit code of the server binary run with `args` (it is expected to refuse to start), and its stderr.
int RunToExit(const std::string& args, const std::string& log, std::string* err) {
  const std::string command = std::string(ROBOCAL_SERVER_BINARY) + " " + args + " >/dev/null 2>" + log;
  const int status = std::system(command.c_str());
  std::ostringstream text;
  for (const std::string& line : ReadLines(log)) text << line << "\n";
  *err = text.str();
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(ProcessTest, RefusesUnsafeOrBrokenStartups) {
  TempDir dir("robocal_refuse");
  const std::string db = " --port 0 --db " + dir.File("robocal.db");
  std::string err;
  EXPECT_EQ(RunToExit("--host 0.0.0.0" + db, dir.File("a.log"), &err), 2);
  EXPECT_NE(err.find("--tokens-file"), std::string::npos) << err;
  // A name that starts like a loopback address is not one.
  EXPECT_EQ(RunToExit("--host 127.evil.invalid" + db, dir.File("a2.log"), &err), 2);
  EXPECT_NE(err.find("--tokens-file"), std::string::npos) << err;
  EXPECT_EQ(RunToExit("--tls-cert " + dir.File("none.pem") + " --tls-key " + dir.File("none.key") + db,
                      dir.File("b.log"), &err),
            2);
  EXPECT_NE(err.find("TLS"), std::string::npos) << err;
  EXPECT_EQ(RunToExit("--tokens-file " + dir.File("none") + db, dir.File("c.log"), &err), 2);
  EXPECT_EQ(RunToExit("--port 80000", dir.File("d.log"), &err), 2);
  EXPECT_EQ(RunToExit("--help", dir.File("e.log"), &err), 0);
}

TEST(ProcessTest, APortInUseIsRefusedAtStart) {
  // Two servers on one port would both listen (SO_REUSEPORT) and the kernel would split the connections between
  // their databases: the second must refuse to start instead.
  TempDir dir("robocal_port_in_use");
  ServerProcess first({"--db", dir.File("first.db")});
  ASSERT_GT(first.port(), 0);
  // `timeout` only ends a second server that wrongly started (exit 124), so that the test fails instead of hanging.
  const std::string log = dir.File("second.log");
  const int status =
      std::system(("timeout 60 " + std::string(ROBOCAL_SERVER_BINARY) + " --port " + std::to_string(first.port()) +
                   " --db " + dir.File("second.db") + " >/dev/null 2>" + log)
                      .c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 1);
  std::ostringstream err;
  for (const std::string& line : ReadLines(log)) err << line << "\n";
  EXPECT_NE(err.str().find("cannot bind 127.0.0.1:" + std::to_string(first.port())), std::string::npos) << err.str();
  httplib::Client client = GuardedClient(first.port());
  const auto health = client.Get("/healthz");
  ASSERT_TRUE(health);
  EXPECT_EQ(health->status, 200);
}

TEST(ProcessTest, JsonLogHasOneLinePerRequest) {
  TempDir dir("robocal_log");
  const std::string log = dir.File("server.log");
  ServerProcess server({"--db", dir.File("robocal.db"), "--log-format", "json", "--log-level", "info"}, log);
  httplib::Client client = GuardedClient(server.port());
  auto r = client.Get("/v1/robots/ur5e", {{"X-Request-Id", "log-test-1"}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->get_header_value("X-Request-Id"), "log-test-1");
  auto missing = client.Get("/v1/campaigns/nothing-here", {{"X-Request-Id", "log-test-2"}});
  ASSERT_TRUE(missing);
  EXPECT_EQ(missing->status, 404);
  EXPECT_EQ(server.Terminate(), 0);  // the log is complete once the process has exited

  int request_lines = 0;
  json ok_line, not_found_line;
  for (const std::string& line : ReadLines(log)) {
    const json j = json::parse(line, nullptr, false);
    ASSERT_TRUE(j.is_object()) << "not one JSON object: " << line;
    EXPECT_TRUE(j.contains("time") && j.contains("level") && j.contains("msg")) << line;
    if (j.value("msg", "") != "request") continue;
    ++request_lines;
    if (j.value("request_id", "") == "log-test-1") ok_line = j;
    if (j.value("request_id", "") == "log-test-2") not_found_line = j;
  }
  EXPECT_EQ(request_lines, 2);
  ASSERT_TRUE(ok_line.is_object());
  EXPECT_EQ(ok_line["method"], "GET");
  EXPECT_EQ(ok_line["path"], "/v1/robots/ur5e");
  EXPECT_EQ(ok_line["status"], 200);
  ASSERT_TRUE(ok_line["ms"].is_number());
  EXPECT_GE(ok_line["ms"].get<double>(), 0.0);
  ASSERT_TRUE(not_found_line.is_object());
  EXPECT_EQ(not_found_line["status"], 404);
  EXPECT_EQ(not_found_line["path"], "/v1/campaigns/nothing-here");
}

// A line of /proc/PID/status ("VmHWM", "VmRSS") in kB; -1 if absent.
long StatusKb(pid_t pid, const std::string& key) {
  for (const std::string& line : ReadLines("/proc/" + std::to_string(pid) + "/status")) {
    if (line.rfind(key + ":", 0) == 0) return std::stol(line.substr(key.size() + 1));
  }
  return -1;
}

// The work limits reach the service from the command line, each refusal naming its limit's value.
TEST(ProcessTest, WorkLimitsComeFromTheFlags) {
  TempDir dir("robocal_limits");
  ServerProcess server({"--db", dir.File("robocal.db"), "--log-level", "error", "--max-plan-evaluations", "5000",
                        "--max-plan-jacobians", "6000", "--max-plan-candidates", "300", "--max-fit-jacobian-entries",
                        "100"});
  httplib::Client client = GuardedClient(server.port());
  auto reason = [&](const std::string& path, const std::string& body) {
    auto r = client.Post(path, body, "application/json");
    EXPECT_TRUE(r && r->status == 400) << path << " " << body;
    return r ? json::parse(r->body)["error"]["details"][0]["reason"].get<std::string>() : std::string();
  };
  EXPECT_NE(reason("/v1/plans", R"({"robot":"ur5e","options":{"k_max":2500}})").find("max_plan_evaluations = 5000"),
            std::string::npos);
  EXPECT_NE(reason("/v1/plans", R"({"robot":"ur5e","num_configurations":30,"options":{"k_max":100}})")
                .find("max_plan_jacobians = 6000"),
            std::string::npos);
  EXPECT_NE(reason("/v1/plans", R"({"robot":"ur5e","optimiser":"exchange","options":{"num_candidates":301}})")
                .find("max_plan_candidates = 300"),
            std::string::npos);
  ASSERT_EQ(client.Post("/v1/campaigns", R"({"id":"c","robot":"ur5e"})", "application/json")->status, 200);
  json batch = {{"request_id", "one"}, {"measurements", json::array()}};
  batch["measurements"].push_back(
      {{"joints", {0, -90, 90, 0, 90, 0}}, {"pose", {{"position_mm", {0, 0, 0}}, {"quaternion", {1, 0, 0, 0}}}}});
  ASSERT_EQ(client.Post("/v1/campaigns/c/measurements", batch.dump(), "application/json")->status, 200);
  EXPECT_NE(reason("/v1/campaigns/c:fit", "{}").find("max_fit_jacobian_entries = 100"), std::string::npos);
}

// An exchange plan at the candidate limit keeps the server well under 100 MB. Storing every candidate's L x L
// contribution, as the optimiser once did, took 8.7 kB per candidate (174 MB for this pool, 850 MB for 100,000).
TEST(ProcessTest, AnExchangePlanAtTheCandidateLimitStaysSmall) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "resident memory under AddressSanitizer (shadow memory, quarantine) says nothing of the server's";
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
  GTEST_SKIP() << "resident memory under AddressSanitizer (shadow memory, quarantine) says nothing of the server's";
#endif
#endif
  TempDir dir("robocal_memory");
  ServerProcess server({"--db", dir.File("robocal.db"), "--log-level", "error"});
  httplib::Client client("127.0.0.1", server.port());
  client.set_read_timeout(300, 0);
  const long before_kb = StatusKb(server.pid(), "VmRSS");
  auto plan = client.Post("/v1/plans",
                          R"({"robot":"ur5e","optimiser":"exchange","num_validation":5,)"
                          R"("options":{"num_candidates":20000,"max_evaluations":1000000}})",
                          "application/json");
  ASSERT_TRUE(plan && plan->status == 200) << (plan ? plan->body : httplib::to_string(plan.error()));
  EXPECT_LE(json::parse(plan->body)["summary"]["evaluations"].get<int>(), 1000000);
  const long peak_kb = StatusKb(server.pid(), "VmHWM");
  ASSERT_GT(before_kb, 0);
  EXPECT_LT(peak_kb - before_kb, 100 * 1024) << "peak " << peak_kb << " kB, before " << before_kb << " kB";
}

TEST(ProcessTest, SigtermCancelsOperationsAndExitsZero) {
  TempDir dir("robocal_term");
  const std::string db = dir.File("robocal.db"), log = dir.File("server.log");
  std::string operation;
  {
    ServerProcess server({"--db", db, "--log-format", "json"}, log);
    httplib::Client client = GuardedClient(server.port());
    auto op = client.Post("/v1/plans",
                          R"({"robot":"ur5e","num_configurations":20,"async":true,)"
                          R"("options":{"k_max":1000000,"max_evaluations":400000}})",
                          "application/json");
    ASSERT_TRUE(op && op->status == 200);
    operation = json::parse(op->body)["id"];
    // Clients in the middle of sending a request are told the server is stopping, not held until their
    // request deadline (10 s by default).
    RawConnection line(server.port());
    line.Send("GET /v1/rob");
    RawConnection body(server.port());
    body.Send("POST /v1/robots HTTP/1.1\r\nContent-Type: application/json\r\nContent-Length: 50\r\n\r\n{");
    ASSERT_TRUE(server.WaitForConnections(2)) << "the server never took the two clients";
    EXPECT_EQ(server.Terminate(), 0);
    const RawReply line_reply = line.Read(std::chrono::milliseconds(100));
    const RawReply body_reply = body.Read(std::chrono::milliseconds(100));
    EXPECT_EQ(line_reply.status, 503) << line_reply.head;
    EXPECT_EQ(body_reply.status, 503) << body_reply.head;
    EXPECT_EQ(body_reply.json["error"]["status"], "UNAVAILABLE") << body_reply.body;
  }
  // Shut down in order: the running operation was cancelled and its final state written, not left RUNNING.
  auto storage = OpenSqliteStorage(db);
  EXPECT_EQ(storage->IntegrityCheck(), "ok");
  const auto doc = storage->Get("operations", operation);
  ASSERT_TRUE(doc.has_value());
  const json op = json::parse(doc->json);
  EXPECT_EQ(op["state"], "CANCELLED") << doc->json;
  EXPECT_TRUE(op["done"].get<bool>());
  bool shutting_down = false, stopped = false;
  for (const std::string& line : ReadLines(log)) {
    const json j = json::parse(line, nullptr, false);
    shutting_down = shutting_down || (j.value("msg", "") == "shutting down" && j.value("signal", "") == "SIGTERM");
    stopped = stopped || j.value("msg", "") == "stopped";
  }
  EXPECT_TRUE(shutting_down);
  EXPECT_TRUE(stopped);
}

}  // namespace
}  // namespace robocal::server::testing
