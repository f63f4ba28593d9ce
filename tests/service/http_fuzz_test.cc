// Random bytes at a real robocal-server process, as a hostile or broken client on the shop-floor network sends
// them: requests built from the API's own routes and bodies, then mutated (invalid UTF-8, control bytes,
// truncation, wrong or missing framing, chunked bodies, duplicate keys), plus stalled sockets held open
// throughout. Every reply must be well-formed HTTP with a JSON error body for 4xx, never a 5xx; the process must
// survive and keep answering; its log must never carry a raw control byte. Seeded: a failure names its seed.
#include <signal.h>
#include <sys/types.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "robocal/api/text.h"
#include "robocal/core/random.h"
// clang-format off
#include "raw_http.h"
#include "server_process.h"
// clang-format on

namespace robocal::server::testing {
namespace {

using namespace std::chrono_literals;

const std::vector<std::string> kTargets = {
    "/healthz", "/metrics", "/v1/openapi.json", "/v1/robots", "/v1/robots/ur5e", "/v1/robots/ur5e:forward",
    "/v1/plans", "/v1/plans/p1", "/v1/campaigns", "/v1/campaigns/c1", "/v1/campaigns/c1/measurements",
    "/v1/campaigns/c1:fit", "/v1/campaigns/c1/calibration", "/v1/campaigns/c1:compensate",
    "/v1/campaigns/c1:forward", "/v1/campaigns/c1:evaluate", "/v1/operations/op1", "/v1/operations/op1:cancel"};

const std::vector<std::string> kBodies = {
    R"({"joints":[[0,-90,90,0,90,0]]})",
    R"({"robot":"grinder5","num_configurations":6,"measurement_type":"pose","seed":1,"options":{"k_max":5}})",
    R"({"id":"c1","robot":"grinder5"})",
    R"({"request_id":"b1","role":"calibration","measurements":[{"joints":[400,300,200,30,45],"pose":{"position_mm":[1,2,3],"quaternion":[1,0,0,0]}}]})",
    R"({"targets":[{"joints":[400,300,200,30,45]},{"pose":{"position_mm":[2500,-80,950],"rpy_deg":[180,0,0]},"frame":"tracker"}]})",
    R"({"h_mm":30})",
    R"({"id":"r9","from_preset":"ur5e","tool":{"position_mm":[0,0,120],"rpy_deg":[0,0,0]}})",
    R"({})"};

// Nasty bytes: invalid UTF-8 of every kind, control characters, a surrogate, an overlong form.
const std::vector<std::string> kNasty = {"\xff", "\xc3\x28", "\xe2\x82", "\xed\xa0\x80", "\xc0\xaf", "\xf4\x90\x80\x80",
                                         std::string(1, '\0'), "\x1b[31m", "\r\n", "%ff", "%00", "%1b", "\"", "\\",
                                         "{", "]", "\xc3\xa9", "1e999", "-", ","};

class RequestMaker {
 public:
  explicit RequestMaker(std::uint64_t seed) : rng_(seed) {}

  std::string Make() {
    truncated_ = false;
    std::string target = Pick(kTargets);
    if (Chance(0.3)) Mutate(&target);
    if (Chance(0.2)) target += "?page_size=" + Pick(kNasty) + "&page_token=" + Pick(kNasty);
    const double m = rng_.Uniform();
    const std::string method = m < 0.35 ? "GET" : m < 0.9 ? "POST" : m < 0.97 ? "DELETE" : Pick(kNasty);
    std::string body = method == "GET" ? "" : Pick(kBodies);
    if (!body.empty() && Chance(0.7)) Mutate(&body);
    if (!body.empty() && Chance(0.1)) body.insert(1, "\"seed\":1,\"seed\":2,");
    std::string head = method + " " + target + " HTTP/1.1\r\nHost: fuzz\r\n";
    if (Chance(0.85)) head += "Content-Type: " + std::string(Chance(0.9) ? "application/json" : Pick(kNasty)) + "\r\n";
    if (Chance(0.1)) head += "X-Request-Id: " + Pick(kNasty) + "id\r\n";
    if (Chance(0.05)) head += "Authorization: Bearer " + Pick(kNasty) + "\r\n";
    if (Chance(0.05)) head += Pick(kNasty) + ": " + Pick(kNasty) + "\r\n";
    const double framing = rng_.Uniform();
    if (body.empty() || framing < 0.6) {
      if (!body.empty() || Chance(0.5)) head += "Content-Length: " + std::to_string(body.size()) + "\r\n";
      return head + "\r\n" + body;
    }
    if (framing < 0.85) {
      // Chunked, in random pieces; sometimes a broken size line.
      std::string chunked;
      for (std::size_t at = 0; at < body.size();) {
        const std::size_t n = std::min<std::size_t>(body.size() - at, 1 + rng_.Index(16));
        std::ostringstream size;
        size << std::hex << n;
        chunked += (Chance(0.03) ? Pick(kNasty) : size.str()) + "\r\n" + body.substr(at, n) + "\r\n";
        at += n;
      }
      return head + "Transfer-Encoding: chunked\r\n\r\n" + chunked + "0\r\n\r\n";
    }
    if (framing < 0.95) {
      // A Content-Length shorter than the body: the rest is read as the next request.
      return head + "Content-Length: " + std::to_string(body.size() / 2) + "\r\n\r\n" + body;
    }
    // Truncated anywhere; the client then leaves.
    truncated_ = true;
    const std::string whole = head + "Content-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
    return whole.substr(0, rng_.Index(whole.size()));
  }
  /// The last request was cut short on purpose (the client hangs up instead of waiting for a reply).
  bool truncated() const { return truncated_; }

 private:
  bool Chance(double p) { return rng_.Uniform() < p; }
  const std::string& Pick(const std::vector<std::string>& list) { return list[rng_.Index(list.size())]; }
  void Mutate(std::string* text) {
    const int edits = 1 + static_cast<int>(rng_.Index(3));
    for (int e = 0; e < edits && !text->empty(); ++e) {
      const std::size_t at = rng_.Index(text->size());
      switch (rng_.Index(3)) {
        case 0:
          text->insert(at, Pick(kNasty));
          break;
        case 1:
          (*text)[at] = static_cast<char>(rng_.Index(256));
          break;
        default:
          text->erase(at, 1 + rng_.Index(4));
          break;
      }
    }
  }
  Rng rng_;
  bool truncated_ = false;
};

TEST(HttpFuzzTest, RandomBytesNeverCrashTheServerNorGetA5xx) {
  const std::string log = ::testing::TempDir() + "robocal_http_fuzz_" + std::to_string(getpid()) + ".log";
  const std::string db = ::testing::TempDir() + "robocal_http_fuzz_" + std::to_string(getpid()) + ".db";
  std::filesystem::remove(db);
  // A short read deadline so that truncated requests cost a second, not ten.
  ServerProcess server({"--db", db, "--request-read-timeout-s", "1", "--log-level", "info"}, log);
  ASSERT_GT(server.port(), 0);
  const int port = server.port();
  // Stalled clients held open for the whole run: a partial head and a body that never comes.
  std::vector<std::unique_ptr<RawConnection>> stalled;
  for (int i = 0; i < 20; ++i) {
    stalled.push_back(std::make_unique<RawConnection>(port));
    stalled.back()->Send(i % 2 == 0 ? "GET /v1/rob" : "POST /v1/plans HTTP/1.1\r\nContent-Length: 99\r\n\r\n{");
  }
  const char* seed_text = std::getenv("ROBOCAL_FUZZ_SEED");
  const std::uint64_t seed = seed_text != nullptr ? std::strtoull(seed_text, nullptr, 10) : 11;
  RequestMaker maker(seed);
  int replies = 0;
  for (int i = 0; i < 1500; ++i) {
    const std::string request = maker.Make();
    RawConnection c(port);
    ASSERT_TRUE(c.connected()) << "request " << i << " (seed " << seed << "): the server stopped accepting";
    c.Send(request);
    if (maker.truncated()) continue;
    const RawReply r = c.Read(30000ms);
    if (r.status == 0) continue;  // closed without a reply: allowed for a request that never completed
    ++replies;
    ASSERT_LT(r.status, 500) << "request " << i << " (seed " << seed << "):\n"
                             << api::SafeText(request) << "\n->\n" << r.head << "\n" << r.body;
    if (r.status >= 400) {
      ASSERT_TRUE(r.json.is_object() && r.json.contains("error")) << api::SafeText(request) << "\n->\n" << r.body;
      EXPECT_TRUE(api::IsValidUtf8(r.body));
    }
  }
  EXPECT_GT(replies, 1000);
  // Still alive, still serving.
  const RawReply health = RawConnection::Exchange(port, "GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n");
  EXPECT_EQ(health.status, 200);
  server.Terminate();
  // The log carries every request line, escaped: no byte below 0x20 but the newlines, no invalid UTF-8.
  std::ifstream in(log, std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_GT(text.size(), 1000u);
  std::string without_newlines = text;
  std::erase(without_newlines, '\n');
  EXPECT_EQ(api::SafeText(without_newlines, without_newlines.size() + 1), without_newlines)
      << "the log holds raw control bytes or invalid UTF-8";
  std::filesystem::remove(log);
  std::filesystem::remove(db);
}

}  // namespace
}  // namespace robocal::server::testing
