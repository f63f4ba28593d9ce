// The HTTP edge against bytes nobody planned for: invalid UTF-8 anywhere, bodies without limits or without
// bodies, stalled and trickling clients, a full connection pool, and the small holes of a request head.
// Each case was a defect of the server before the edge was hardened; each answer must be a well-formed
// error body naming the field, and the server must keep serving.
#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

// Eigen (through the server's headers) before the network headers: glibc's resolver macros clash with its
// parameter names otherwise.
#include "robocal/server/http_server.h"
// clang-format off
#include "raw_http.h"
#include "robocal/api/text.h"
#include "robocal/server/config.h"
#include "test_server.h"
// clang-format on

namespace robocal::server::testing {
namespace {

using namespace std::chrono_literals;

std::string Get(const std::string& target) { return "GET " + target + " HTTP/1.1\r\nHost: x\r\n\r\n"; }

std::string PostJson(const std::string& target, const std::string& body,
                     const std::string& type = "application/json") {
  return "POST " + target + " HTTP/1.1\r\nHost: x\r\nContent-Type: " + type +
         "\r\nContent-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
}

// A reply is an error body the API promises: valid JSON, the status and code, the field named.
void ExpectErrorBody(const RawReply& r, int code, const std::string& field) {
  EXPECT_EQ(r.status, code) << r.head << "\n" << r.body;
  ASSERT_TRUE(r.json.is_object()) << r.body;
  EXPECT_EQ(r.json["error"]["code"], code);
  EXPECT_TRUE(api::IsValidUtf8(r.body));
  EXPECT_EQ(FirstDetailField(r), field) << r.body;
}

void ExpectHealthy(int port) {
  const RawReply r = RawConnection::Exchange(port, Get("/healthz"));
  EXPECT_EQ(r.status, 200) << r.body;
}

TEST(EdgeTest, InvalidUtf8InPathsQueriesAndBodiesIsAnErrorBodyNotACrash) {
  TestServer server;
  const int port = server.port();
  ExpectErrorBody(RawConnection::Exchange(port, Get("/v1/robots/%ff")), 400, "robot");
  ExpectErrorBody(RawConnection::Exchange(port, Get("/%ff")), 404, "path");
  ExpectErrorBody(RawConnection::Exchange(port, Get("/v1/robots?page_size=%ff")), 400, "page_size");
  ExpectErrorBody(RawConnection::Exchange(port, PostJson("/v1/robots", "{\"id\": \"\xff\"}")), 400, "body");
  ExpectErrorBody(RawConnection::Exchange(port, PostJson("/v1/plans", "{\"robot\": \"ur5e\xc3\x28\"}")), 400, "body");
  // Valid UTF-8 right before a syntax error: the parser's message quotes it.
  ExpectErrorBody(RawConnection::Exchange(port, PostJson("/v1/campaigns/c1:evaluate", "{\"h_mm\": \xc3\xa9}")), 400,
                  "body");
  const RawReply nul = RawConnection::Exchange(port, Get("/v1/robots/a%00b%1bc"));
  ExpectErrorBody(nul, 400, "robot");
  // The message is not cut at the NUL and carries no raw control byte.
  EXPECT_NE(nul.json["error"]["message"].get<std::string>().find("a\\x00b\\x1bc"), std::string::npos) << nul.body;
  ExpectHealthy(port);
}

TEST(EdgeTest, IdsThatCannotNameAResourceAre400) {
  TestServer server;
  for (const char* id : {"..", "UPPER", "-x"}) {
    ExpectErrorBody(RawConnection::Exchange(server.port(), Get(std::string("/v1/robots/") + id)), 400, "robot");
    ExpectErrorBody(RawConnection::Exchange(server.port(), Get(std::string("/v1/campaigns/") + id)), 400,
                    "campaign");
  }
  EXPECT_EQ(RawConnection::Exchange(server.port(), Get("/v1/robots/nosuchrobot")).status, 404);
}

TEST(EdgeTest, ChunkedBodyBeyondTheLimitIsCutWhileReading) {
  ServerConfig config;
  config.max_body_bytes = 65536;
  TestServer server(config);
  RawConnection c(server.port());
  ASSERT_TRUE(c.Send("POST /v1/robots HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                     "Transfer-Encoding: chunked\r\n\r\n"));
  // 64 MiB offered in 64 KiB chunks; the server must answer long before it has them all.
  const std::string chunk = "10000\r\n" + std::string(65536, ' ') + "\r\n";
  std::size_t sent = 0;
  while (sent < (64u << 20) && c.Send(chunk)) sent += 65536;
  const RawReply r = c.Read();
  ExpectErrorBody(r, 413, "body");
  EXPECT_LT(sent, 64u << 20) << "the server read the whole body";
  ExpectHealthy(server.port());
}

TEST(EdgeTest, ContentLengthOverTheLimitIsRefusedBeforeReading) {
  ServerConfig config;
  config.max_body_bytes = 65536;
  config.request_read_timeout_s = 60;
  TestServer server(config);
  RawConnection c(server.port());
  ASSERT_TRUE(c.Send("POST /v1/robots HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                     "Content-Length: 2000000000\r\n\r\n{}"));
  // Answered at once, not after the read deadline (60 s here) or after 2 GB.
  ExpectErrorBody(c.Read(30s), 413, "body");
}

TEST(EdgeTest, AClientThatAsksFirstIsRefusedBeforeItSends) {
  ServerConfig config;
  config.max_body_bytes = 65536;
  TestServer server(config);
  const RawReply r = RawConnection::Exchange(
      server.port(),
      "POST /v1/robots HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 1000000\r\n"
      "Expect: 100-continue\r\n\r\n");
  ExpectErrorBody(r, 413, "body");  // not "100 Continue"
  // "100 Continue" has no length: wait for the server to say something, then take what it said.
  RawConnection asks(server.port());
  asks.Send(
      "POST /v1/robots HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 2\r\n"
      "Expect: 100-continue\r\n\r\n");
  ASSERT_TRUE(asks.Answered(30s));
  const RawReply go = asks.Read(1000ms);
  EXPECT_EQ(go.status, 100) << go.head;
}

TEST(EdgeTest, PostWithoutBodyIs400AtOnce) {
  ServerConfig config;
  config.request_read_timeout_s = 60;
  TestServer server(config);
  ExpectErrorBody(
      RawConnection::Exchange(server.port(), "POST /v1/campaigns/c1:evaluate HTTP/1.1\r\nHost: x\r\n\r\n", 30s), 400,
      "body");
  ExpectErrorBody(RawConnection::Exchange(server.port(), PostJson("/v1/campaigns/c1:evaluate", ""), 30s), 400, "body");
  // A DELETE without a body is complete at its blank line (it used to wait for the connection to close).
  const RawReply del =
      RawConnection::Exchange(server.port(), "DELETE /v1/robots/nosuch HTTP/1.1\r\nHost: x\r\n\r\n", 30s);
  EXPECT_EQ(del.status, 404) << del.body;
}

TEST(EdgeTest, BodyShorterThanItsContentLengthTimesOutAtTheRequestDeadline) {
  ServerConfig config;
  config.request_read_timeout_s = 1;
  TestServer server(config);
  RawConnection c(server.port());
  ASSERT_TRUE(c.Send("POST /v1/robots HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                     "Content-Length: 1000\r\n\r\n{}"));
  const RawReply r = c.Read(30s);
  ExpectErrorBody(r, 408, "request");
  EXPECT_EQ(r.json["error"]["status"], "DEADLINE_EXCEEDED");
}

TEST(EdgeTest, ATricklingClientCannotExtendTheDeadline) {
  ServerConfig config;
  config.request_read_timeout_s = 1;
  TestServer server(config);
  RawConnection c(server.port());
  // One byte every 200 ms (the pace, cut short by the server's answer): each read is quick, the request never
  // completes.
  const std::string request = Get("/healthz");
  std::size_t sent = 0;
  while (sent + 1 < request.size() && c.Send(request.substr(sent, 1))) {
    ++sent;
    if (c.Answered(200ms)) break;
  }
  const RawReply r = c.Read(30s);
  EXPECT_EQ(r.status, 408) << r.head;
  EXPECT_LT(sent, request.size() - 1) << "the server kept reading a trickling request";
}

TEST(EdgeTest, StalledConnectionsDoNotStopHealthProbes) {
  ServerConfig config;
  config.request_read_timeout_s = 30;
  config.max_connections = 64;
  TestServer server(config);
  // More stalled sockets than handler slots (4 in the test server) and than the old pool's 8 threads.
  std::vector<std::unique_ptr<RawConnection>> stalled;
  for (int i = 0; i < 40; ++i) {
    stalled.push_back(std::make_unique<RawConnection>(server.port()));
    stalled.back()->Send(i % 2 == 0 ? "GET /v1/rob" : "POST /v1/robots HTTP/1.1\r\nContent-Length: 10\r\n\r\n{");
  }
  ASSERT_TRUE(server.WaitForConnections([](const auto& c) { return c.active + c.queued >= 40; }));
  for (int i = 0; i < 5; ++i) {
    const RawReply r = RawConnection::Exchange(server.port(), Get("/healthz"), 15s);
    EXPECT_EQ(r.status, 200);
    const RawReply f = RawConnection::Exchange(
        server.port(), PostJson("/v1/robots/ur5e:forward", R"({"joints":[[0,0,0,0,0,0]]})"), 15s);
    EXPECT_EQ(f.status, 200) << f.body;
  }
}

TEST(EdgeTest, AFullPoolRefusesNewConnectionsAtOnce) {
  ServerConfig config;
  config.request_read_timeout_s = 30;
  config.max_connections = 2;
  config.max_queued_connections = 1;
  TestServer server(config);
  std::vector<std::unique_ptr<RawConnection>> stalled;
  for (int i = 0; i < 3; ++i) {
    stalled.push_back(std::make_unique<RawConnection>(server.port()));
    stalled.back()->Send("GET /healthz HTTP/1.1\r\n");
  }
  // Both connection threads busy and the one queue place taken.
  ASSERT_TRUE(server.WaitForConnections([](const auto& c) { return c.active == 2 && c.queued == 1; }));
  const RawReply r = RawConnection::Exchange(server.port(), Get("/healthz"), 15s);
  ExpectErrorBody(r, 503, "connection");
  EXPECT_NE(r.head.find("Retry-After: 1"), std::string::npos) << r.head;
  // Once the stalled clients go, the server serves again.
  stalled.clear();
  ASSERT_TRUE(server.WaitForConnections([](const auto& c) { return c.active == 0 && c.queued == 0; }));
  ExpectHealthy(server.port());
}

TEST(EdgeTest, HeadsBeyondTheLimitAre431) {
  TestServer server;
  std::string request = "GET /healthz HTTP/1.1\r\nHost: x\r\n";
  for (int i = 0; i < 2000; ++i) request += "X-Filler-" + std::to_string(i) + ": " + std::string(40, 'a') + "\r\n";
  request += "\r\n";
  ExpectErrorBody(RawConnection::Exchange(server.port(), request), 431, "head");
  // A request line that never ends.
  RawConnection c(server.port());
  c.Send("GET /" + std::string(100000, 'a'));
  const RawReply r = c.Read();
  EXPECT_TRUE(r.status == 431 || r.status == 414) << r.head;
}

TEST(EdgeTest, LongRequestLinesAre414WithDetails) {
  TestServer server;
  ExpectErrorBody(RawConnection::Exchange(server.port(), Get("/v1/robots/" + std::string(9000, 'a'))), 414, "uri");
}

TEST(EdgeTest, DuplicateKeysAreRefusedWithTheirPath) {
  TestServer server;
  const RawReply r = RawConnection::Exchange(
      server.port(), PostJson("/v1/robots/ur5e:forward", R"({"joints":[[0,0,0,0,0,0]],"joints":[[1,1,1,1,1,1]]})"));
  ExpectErrorBody(r, 400, "joints");
  const RawReply nested = RawConnection::Exchange(
      server.port(), PostJson("/v1/plans", R"({"robot":"ur5e","options":{"k_max":10,"k_max":20}})"));
  ExpectErrorBody(nested, 400, "options.k_max");
}

TEST(EdgeTest, OnlyJsonBodiesAreParsed) {
  TestServer server;
  ExpectErrorBody(RawConnection::Exchange(server.port(), PostJson("/v1/robots/ur5e:forward",
                                                                  R"({"joints":[[0,0,0,0,0,0]]})", "text/plain")),
                  400, "Content-Type");
  const RawReply ok = RawConnection::Exchange(
      server.port(),
      PostJson("/v1/robots/ur5e:forward", R"({"joints":[[0,0,0,0,0,0]]})", "Application/JSON; charset=utf-8"));
  EXPECT_EQ(ok.status, 200) << ok.body;
  ExpectErrorBody(RawConnection::Exchange(server.port(),
                                          "POST /v1/robots HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                                          "Content-Encoding: gzip\r\nContent-Length: 2\r\n\r\n{}"),
                  400, "Content-Encoding");
  ExpectErrorBody(RawConnection::Exchange(server.port(),
                                          "POST /v1/robots HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                                          "Content-Length: 2\r\nTransfer-Encoding: chunked\r\n\r\n{}"),
                  400, "Transfer-Encoding");
}

TEST(EdgeTest, EmptyRequestIdIsRefused) {
  TestServer server;
  ASSERT_EQ(server.Post("/v1/campaigns", {{"id", "c1"}, {"robot", "grinder5"}}).status, 200);
  const Reply r = server.Post("/v1/campaigns/c1/measurements",
                              {{"request_id", ""},
                               {"measurements",
                                {{{"joints", {400, 300, 200, 30, 45}},
                                  {"pose", {{"position_mm", {1, 2, 3}}, {"quaternion", {1, 0, 0, 0}}}}}}}});
  EXPECT_EQ(r.status, 400) << r.text;
  EXPECT_TRUE(NamesField(r, "request_id")) << r.text;
}

TEST(EdgeTest, PageTokensAreChecked) {
  TestServer server;
  const Reply first = server.Get("/v1/robots?page_size=1");
  ASSERT_EQ(first.status, 200);
  const std::string token = first.body["next_page_token"];
  EXPECT_EQ(server.Get("/v1/robots?page_size=1&page_token=" + token).status, 200);
  for (const std::string& bad : std::vector<std::string>{"garbage", "grinder5", token + "x", "puma560~00000000"}) {
    const Reply r = server.Get("/v1/robots?page_token=" + bad);
    EXPECT_EQ(r.status, 400) << bad;
    EXPECT_TRUE(NamesField(r, "page_token")) << r.text;
  }
  // A robots token is not a campaigns token.
  const Reply other = server.Get("/v1/campaigns?page_token=" + token);
  EXPECT_EQ(other.status, 400) << other.text;
}

TEST(EdgeTest, TokensWithControlBytesAreRefused) {
  TestServer server({}, {"s3cret"});
  const auto with_auth = [](const std::string& value) {
    return "GET /v1/robots HTTP/1.1\r\nHost: x\r\nAuthorization: " + value + "\r\n\r\n";
  };
  EXPECT_EQ(RawConnection::Exchange(server.port(), with_auth("Bearer s3cret")).status, 200);
  // Header values are percent-decoded by the HTTP library: %00 arrives as a NUL byte.
  ExpectErrorBody(RawConnection::Exchange(server.port(), with_auth("Bearer s3cret%00more")), 400,
                  "header Authorization");
  ExpectErrorBody(RawConnection::Exchange(server.port(), with_auth(std::string("Bearer s3cret\0more", 18))), 400,
                  "header Authorization");
  EXPECT_EQ(RawConnection::Exchange(server.port(), with_auth("Bearer s3cretmore")).status, 401);
}

TEST(EdgeTest, UnsafeRequestIdsAreReplaced) {
  TestServer server;
  const RawReply kept =
      RawConnection::Exchange(server.port(), "GET /healthz HTTP/1.1\r\nHost: x\r\nX-Request-Id: cell-7.42\r\n\r\n");
  EXPECT_NE(kept.head.find("X-Request-Id: cell-7.42"), std::string::npos) << kept.head;
  const RawReply replaced = RawConnection::Exchange(
      server.port(), "GET /healthz HTTP/1.1\r\nHost: x\r\nX-Request-Id: a%1b[31mred\r\n\r\n");
  EXPECT_EQ(replaced.status, 400);  // a control byte in a header
  const RawReply spaced =
      RawConnection::Exchange(server.port(), "GET /healthz HTTP/1.1\r\nHost: x\r\nX-Request-Id: a b\r\n\r\n");
  EXPECT_EQ(spaced.status, 200);
  EXPECT_EQ(spaced.head.find("X-Request-Id: a b"), std::string::npos) << spaced.head;
}

TEST(EdgeTest, MetricsLabelsStayBoundedWhateverTheMethod) {
  TestServer server;
  for (int i = 0; i < 50; ++i) {
    RawConnection::Exchange(server.port(), "M" + std::to_string(i) + "X\"}\xff\x1b /healthz HTTP/1.1\r\nHost: x\r\n\r\n");
  }
  const RawReply metrics = RawConnection::Exchange(server.port(), Get("/metrics"));
  ASSERT_EQ(metrics.status, 200);
  EXPECT_NE(metrics.body.find("method=\"other\""), std::string::npos) << metrics.body;
  EXPECT_EQ(metrics.body.find("M7X"), std::string::npos);
  EXPECT_TRUE(api::IsValidUtf8(metrics.body));
  EXPECT_EQ(metrics.body.find('\x1b'), std::string::npos);
}

TEST(EdgeTest, RangeHeadersAreIgnored) {
  TestServer server({}, {"s3cret"});
  // An error body stays whole (it used to be cut to the first byte).
  ExpectErrorBody(RawConnection::Exchange(server.port(),
                                          "GET /v1/robots HTTP/1.1\r\nHost: x\r\nRange: bytes=0-0\r\n\r\n"),
                  401, "");
  std::string ranges;
  for (int i = 0; i < 4000; ++i) ranges += i == 0 ? "-" : ",-";
  const RawReply many = RawConnection::Exchange(
      server.port(), "GET /healthz HTTP/1.1\r\nHost: x\r\nRange: bytes=" + ranges + "\r\n\r\n");
  EXPECT_EQ(many.status, 200);
  EXPECT_EQ(many.json["status"], "ok") << many.body.substr(0, 200);
}

TEST(EdgeTest, AGetWithABodyIsRefusedNotSplitIntoTwoRequests) {
  TestServer server;
  const std::string inner = "DELETE /v1/robots/abc HTTP/1.1\r\nHost: x\r\n\r\n";
  for (const std::string& framing :
       {"Content-Length: " + std::to_string(inner.size()), std::string("Transfer-Encoding: chunked")}) {
    RawConnection c(server.port());
    c.Send("GET /healthz HTTP/1.1\r\nHost: x\r\n" + framing + "\r\n\r\n" + inner);
    ExpectErrorBody(c.Read(), 400, "body");
    EXPECT_EQ(c.Read(500ms).status, 0) << "a second reply: the body was read as a request";
  }
}

TEST(EdgeTest, ErrorDetailsAreCapped) {
  TestServer server;
  std::string body = "{";
  for (int i = 0; i < 1000; ++i) body += (i ? "," : "") + std::string("\"k") + std::to_string(i) + "\":1";
  body += "}";
  const RawReply r = RawConnection::Exchange(server.port(), PostJson("/v1/plans", body));
  ASSERT_EQ(r.status, 400) << r.body.substr(0, 300);
  EXPECT_EQ(r.json["error"]["details"].size(), 100u);
  EXPECT_NE(r.json["error"]["message"].get<std::string>().find("more"), std::string::npos);
}

TEST(EdgeTest, LoopbackMeansAnAddress) {
  EXPECT_TRUE(IsLoopbackHost("127.0.0.1"));
  EXPECT_TRUE(IsLoopbackHost("127.8.9.10"));
  EXPECT_TRUE(IsLoopbackHost("::1"));
  EXPECT_TRUE(IsLoopbackHost("localhost"));
  EXPECT_FALSE(IsLoopbackHost("127.evil.invalid"));
  EXPECT_FALSE(IsLoopbackHost("127.0.0.1.evil.invalid"));
  EXPECT_FALSE(IsLoopbackHost("128.0.0.1"));
  EXPECT_FALSE(IsLoopbackHost("0.0.0.0"));
  EXPECT_FALSE(IsLoopbackHost("::"));
}

TEST(EdgeTest, KeepAliveStillServesSeveralRequestsOnOneConnection) {
  TestServer server;
  RawConnection c(server.port());
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(c.Send(Get("/healthz")));
    EXPECT_EQ(c.Read().status, 200);
  }
  // Pipelined: two requests in one write.
  ASSERT_TRUE(c.Send(Get("/healthz") + Get("/healthz")));
  EXPECT_EQ(c.Read().status, 200);
  EXPECT_EQ(c.Read().status, 200);
}

}  // namespace
}  // namespace robocal::server::testing
