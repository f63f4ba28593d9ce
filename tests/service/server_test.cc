// The HTTP server end to end in-process: every endpoint, bad input, idempotency, auth, limits, operations.
#include <fstream>
#include <set>

#include <gtest/gtest.h>

#include "robocal/api/convert.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/server/config.h"
#include "test_server.h"

namespace robocal::server::testing {
namespace {

using nlohmann::json;

// A small, fast plan request.
json SmallPlan(const std::string& robot = "grinder5") {
  return {{"robot", robot},
          {"num_configurations", 6},
          {"measurement_type", "pose"},
          {"seed", 7},
          {"num_validation", 5},
          {"options", {{"k_max", 5}}}};
}

// Exact (noise-free) nominal measurements at random configurations, on the wire.
json NominalBatch(const std::string& robot, const std::string& request_id, int count, std::uint64_t seed,
                  const std::string& role = "calibration") {
  const RobotModel model = Preset(robot);
  Rng rng(seed);
  json list = json::array();
  for (int i = 0; i < count; ++i) {
    const Eigen::VectorXd q = RandomConfiguration(model, &rng);
    const Transform pose = ForwardKinematics(model, q);
    list.push_back({{"joints", api::JointsToWire(model, q)}, {"pose", api::ToJson(api::TransformToPose(pose))}});
  }
  return {{"request_id", request_id}, {"role", role}, {"measurements", list}};
}

TEST(ServerTest, HealthzAndSpecAndUnknownEndpoint) {
  TestServer s;
  EXPECT_EQ(s.Get("/healthz").body["status"], "ok");
  const Reply spec = s.Get("/v1/openapi.json");
  EXPECT_EQ(spec.status, 200);
  EXPECT_TRUE(spec.body.contains("openapi"));
  const Reply missing = s.Get("/v1/nothing");
  EXPECT_EQ(missing.status, 404);
  EXPECT_EQ(missing.body["error"]["status"], "NOT_FOUND");
}

TEST(ServerTest, RobotsPresetsRegisterForwardDelete) {
  TestServer s;
  const Reply list = s.Get("/v1/robots");
  ASSERT_EQ(list.status, 200);
  EXPECT_EQ(list.body["robots"].size(), 3u);
  EXPECT_EQ(s.Get("/v1/robots/ur5e").body["num_joints"], 6);
  EXPECT_EQ(s.Get("/v1/robots/nope").status, 404);

  const json arm = json::parse(R"({"id":"arm2","convention":"dh","joints":[
      {"type":"revolute","a_mm":300,"min_deg":-170,"max_deg":170},
      {"type":"revolute","a_mm":200,"min_deg":-120,"max_deg":120}]})");
  EXPECT_EQ(s.Post("/v1/robots", arm).status, 200);
  EXPECT_EQ(s.Post("/v1/robots", arm).status, 409);
  EXPECT_EQ(s.Post("/v1/robots", {{"id", "ur5e"}, {"from_preset", "ur5e"}}).status, 409);
  const Reply fk = s.Post("/v1/robots/arm2:forward", {{"joints", {{0, 0}, {90, 0}}}});
  ASSERT_EQ(fk.status, 200);
  EXPECT_NEAR(fk.body["poses"][0]["position_mm"][0].get<double>(), 500.0, 1e-9);
  EXPECT_NEAR(fk.body["poses"][1]["position_mm"][1].get<double>(), 500.0, 1e-9);

  const Reply bad = s.Post("/v1/robots/arm2:forward", {{"joints", {{0, 0, 0}, {0, 500}}}});
  EXPECT_EQ(bad.status, 400);
  EXPECT_TRUE(NamesField(bad, "joints[0]"));
  EXPECT_TRUE(NamesField(bad, "joints[1][1]"));

  EXPECT_EQ(s.Delete("/v1/robots/arm2").status, 200);
  EXPECT_EQ(s.Get("/v1/robots/arm2").status, 404);
  EXPECT_EQ(s.Delete("/v1/robots/arm2").status, 404);
  const Reply preset = s.Delete("/v1/robots/ur5e");
  EXPECT_EQ(preset.status, 400);
  EXPECT_EQ(preset.body["error"]["status"], "FAILED_PRECONDITION");
}

TEST(ServerTest, BadRobotDefinitionsNameTheField) {
  TestServer s;
  const Reply r = s.Post("/v1/robots", json::parse(R"({"id":"x1","convention":"dhx","joints":[]})"));
  EXPECT_EQ(r.status, 400);
  EXPECT_TRUE(NamesField(r, "convention"));
  const Reply j = s.Post("/v1/robots", json::parse(R"({"id":"x1","convention":"dh","joints":[
      {"type":"revolute","a_mm":"long","min_deg":0,"max_deg":10}]})"));
  EXPECT_TRUE(NamesField(j, "joints[0].a_mm"));
  EXPECT_EQ(s.storage().List("robots").size(), 0u);
}

TEST(ServerTest, SynchronousPlanIsStoredAndComplete) {
  TestServer s;
  const Reply plan = s.Post("/v1/plans", SmallPlan());
  ASSERT_EQ(plan.status, 200) << plan.text;
  EXPECT_EQ(plan.body["configurations"].size(), 6u);
  EXPECT_EQ(plan.body["configurations"][0].size(), 5u);
  EXPECT_EQ(plan.body["identifiable_parameters"].size(), 20u);
  EXPECT_TRUE(plan.body["indices"].contains("o1"));
  EXPECT_TRUE(plan.body["baseline"]["indices"].contains("condition_number"));
  EXPECT_GT(plan.body["predicted_accuracy"]["rms_position_mm"].get<double>(), 0.0);
  const std::string id = plan.body["id"];
  const Reply again = s.Get("/v1/plans/" + id);
  ASSERT_EQ(again.status, 200);
  EXPECT_EQ(again.body["configurations"], plan.body["configurations"]);
  EXPECT_EQ(s.Get("/v1/plans/plan-0000").status, 404);
}

TEST(ServerTest, PlanValidationAndLimits) {
  ServiceOptions options;
  options.limits.max_plan_configurations = 20;
  TestServer s({}, {}, options);
  json p = SmallPlan();
  p["num_configurations"] = 21;
  const Reply big = s.Post("/v1/plans", p);
  EXPECT_EQ(big.status, 400);
  EXPECT_TRUE(NamesField(big, "num_configurations"));
  EXPECT_EQ(s.Post("/v1/plans", SmallPlan("nobody")).status, 404);
  p = SmallPlan();
  p["objective"] = "best";
  p["options"]["kmax"] = 3;
  const Reply enums = s.Post("/v1/plans", p);
  EXPECT_TRUE(NamesField(enums, "objective"));
  EXPECT_TRUE(NamesField(enums, "options.kmax"));
  EXPECT_EQ(s.storage().List("plans").size(), 0u);
}

TEST(ServerTest, AsyncPlanRunsAsAnOperation) {
  TestServer s;
  json p = SmallPlan();
  p["async"] = true;
  const Reply op = s.Post("/v1/plans", p);
  ASSERT_EQ(op.status, 200) << op.text;
  const std::string id = op.body["id"];
  Reply state;
  for (int i = 0; i < 2000; ++i) {
    state = s.Get("/v1/operations/" + id);
    if (state.body.value("done", false)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(state.body.value("done", false)) << state.text;
  EXPECT_EQ(state.body["state"], "SUCCEEDED");
  EXPECT_EQ(s.Get("/v1/plans/" + state.body["result"]["plan"].get<std::string>()).status, 200);
  EXPECT_EQ(s.Post("/v1/operations/" + id + ":cancel", json::object()).status, 200);
  EXPECT_EQ(s.Get("/v1/operations/op-none").status, 404);
}

TEST(ServerTest, AsyncPlanCanBeCancelled) {
  TestServer s;
  json p = SmallPlan();
  p["async"] = true;
  p["options"]["k_max"] = 1000000;
  p["options"]["max_evaluations"] = 1000000;
  const Reply op = s.Post("/v1/plans", p);
  ASSERT_EQ(op.status, 200) << op.text;
  const std::string id = op.body["id"];
  EXPECT_EQ(s.Post("/v1/operations/" + id + ":cancel", json::object()).status, 200);
  Reply state;
  for (int i = 0; i < 3000; ++i) {
    state = s.Get("/v1/operations/" + id);
    if (state.body.value("done", false)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(state.body["state"], "CANCELLED") << state.text;
}

TEST(ServerTest, CampaignMeasurementsAreAtomicAndIdempotent) {
  TestServer s;
  const Reply plan = s.Post("/v1/plans", SmallPlan("ur5e"));
  ASSERT_EQ(plan.status, 200);
  const Reply c = s.Post("/v1/campaigns", {{"id", "c1"}, {"robot", "ur5e"}, {"plan", plan.body["id"]}});
  ASSERT_EQ(c.status, 200) << c.text;
  EXPECT_EQ(c.body["measurement_type"], "pose");
  EXPECT_EQ(s.Post("/v1/campaigns", {{"id", "c1"}, {"robot", "ur5e"}}).status, 409);
  EXPECT_EQ(s.Post("/v1/campaigns", {{"robot", "grinder5"}, {"plan", plan.body["id"]}}).status, 400);
  EXPECT_EQ(s.Post("/v1/campaigns", {{"robot", "robotx"}}).status, 404);
  EXPECT_EQ(s.Get("/v1/campaigns").body["campaigns"].size(), 1u);

  const json batch = NominalBatch("ur5e", "req-1", 8, 3);
  const Reply first = s.Post("/v1/campaigns/c1/measurements", batch);
  ASSERT_EQ(first.status, 200) << first.text;
  EXPECT_EQ(first.body["count"], 8);
  EXPECT_FALSE(first.body["replayed"].get<bool>());
  const Reply replay = s.Post("/v1/campaigns/c1/measurements", batch);
  EXPECT_EQ(replay.status, 200);
  EXPECT_TRUE(replay.body["replayed"].get<bool>());
  EXPECT_EQ(s.storage().CountMeasurements("c1"), 8);
  const Reply conflict = s.Post("/v1/campaigns/c1/measurements", NominalBatch("ur5e", "req-1", 8, 4));
  EXPECT_EQ(conflict.status, 409);
  EXPECT_EQ(conflict.body["error"]["status"], "ALREADY_EXISTS");

  // One bad measurement among good ones: nothing is stored.
  json bad = NominalBatch("ur5e", "req-2", 5, 5);
  bad["measurements"][3]["joints"] = {0, 0, 0, 0, 0};
  bad["measurements"][4]["pose"]["quaternion"] = {1, 0, 0};
  const Reply rejected = s.Post("/v1/campaigns/c1/measurements", bad);
  EXPECT_EQ(rejected.status, 400);
  EXPECT_TRUE(NamesField(rejected, "measurements[3].joints"));
  EXPECT_TRUE(NamesField(rejected, "measurements[4].pose.quaternion"));
  EXPECT_EQ(s.storage().CountMeasurements("c1"), 8);

  const Reply listed = s.Get("/v1/campaigns/c1/measurements?role=calibration&limit=5");
  ASSERT_EQ(listed.status, 200);
  EXPECT_EQ(listed.body["measurements"].size(), 5u);
  EXPECT_EQ(listed.body["next_after"], 5);
  EXPECT_EQ(s.Get("/v1/campaigns/c1/measurements?limit=x").status, 400);
  EXPECT_EQ(s.Get("/v1/campaigns/c1").body["counts"]["calibration"], 8);
  EXPECT_EQ(s.Post("/v1/campaigns/c9/measurements", batch).status, 404);
}

TEST(ServerTest, CalibrationEndpointsNeedAFit) {
  TestServer s;
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "c2"}, {"robot", "grinder5"}}).status, 200);
  const Reply fit = s.Post("/v1/campaigns/c2:fit", json::object());
  EXPECT_EQ(fit.status, 400);
  EXPECT_EQ(fit.body["error"]["status"], "FAILED_PRECONDITION");
  EXPECT_EQ(s.Get("/v1/campaigns/c2/calibration").status, 404);
  for (const char* method : {":compensate", ":forward", ":evaluate"}) {
    const Reply r = s.Post(std::string("/v1/campaigns/c2") + method, json::object());
    EXPECT_EQ(r.status, 400) << method;
    EXPECT_EQ(r.body["error"]["status"], "FAILED_PRECONDITION") << method;
  }
  EXPECT_EQ(s.Post("/v1/campaigns/none:fit", json::object()).status, 404);
  const Reply badfit = s.Post("/v1/campaigns/c2:fit", {{"parameters", {"joint9.dz"}}});
  EXPECT_TRUE(NamesField(badfit, "parameters[0]"));
}

TEST(ServerTest, MalformedAndOversizedInputKeepsTheServerServing) {
  ServerConfig config;
  config.max_body_bytes = 4096;
  api::Limits limits;
  limits.max_array_length = 50;
  ServiceOptions options;
  options.limits = limits;
  TestServer s(config, {}, options);
  for (const char* path : {"/v1/robots", "/v1/plans", "/v1/campaigns", "/v1/robots/ur5e:forward"}) {
    const Reply r = s.PostText(path, "{\"robot\": ");
    EXPECT_EQ(r.status, 400) << path;
    EXPECT_EQ(r.body["error"]["status"], "INVALID_ARGUMENT") << path;
    EXPECT_EQ(FirstField(r), "body") << path;
    EXPECT_EQ(s.PostText(path, "[1,2]").status, 400) << path;
    EXPECT_EQ(s.PostText(path, R"({"x": 1e999})").status, 400) << path;
  }
  const Reply huge = s.PostText("/v1/robots", std::string(10000, ' ') + "{}");
  EXPECT_EQ(huge.status, 413);
  EXPECT_EQ(huge.body["error"]["status"], "RESOURCE_EXHAUSTED");
  json many = {{"joints", json::array()}};
  for (int i = 0; i < 51; ++i) many["joints"].push_back({0, 0, 0, 0, 0, 0});
  const Reply long_array = s.Post("/v1/robots/ur5e:forward", many);
  EXPECT_EQ(long_array.status, 400);
  EXPECT_NE(long_array.body["error"]["details"][0]["reason"].get<std::string>().find("limit 50"), std::string::npos);
  const Reply types = s.Post("/v1/robots/ur5e:forward", {{"joints", {{0, 0, "0", 0, true, 0}}}});
  EXPECT_TRUE(NamesField(types, "joints[0][2]"));
  EXPECT_TRUE(NamesField(types, "joints[0][4]"));
  EXPECT_EQ(s.Get("/healthz").status, 200);
}

TEST(ServerTest, MeasurementsPerCampaignLimit) {
  ServiceOptions options;
  options.max_measurements_per_campaign = 10;
  TestServer s({}, {}, options);
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "c3"}, {"robot", "ur5e"}}).status, 200);
  EXPECT_EQ(s.Post("/v1/campaigns/c3/measurements", NominalBatch("ur5e", "a", 8, 1)).status, 200);
  const Reply over = s.Post("/v1/campaigns/c3/measurements", NominalBatch("ur5e", "b", 3, 2));
  EXPECT_EQ(over.status, 413);
  EXPECT_EQ(over.body["error"]["status"], "RESOURCE_EXHAUSTED");
  EXPECT_EQ(s.storage().CountMeasurements("c3"), 8);
}

TEST(ServerTest, BearerTokensGuardEveryEndpointButHealthz) {
  TestServer s({}, {"secret-token-1", "other"});
  EXPECT_EQ(s.Get("/healthz").status, 200);
  for (const RouteInfo& route : Routes()) {
    if (route.openapi_path == "/healthz") continue;
    std::string path = route.openapi_path;
    for (const char* p : {"{robot}", "{plan}", "{campaign}", "{operation}"}) {
      if (auto at = path.find(p); at != std::string::npos) path.replace(at, std::string(p).size(), "x1");
    }
    s.set_token("");
    const Reply none = s.Request(route.method, path, "{}");
    EXPECT_EQ(none.status, 401) << route.method << " " << path;
    EXPECT_EQ(none.body["error"]["status"], "UNAUTHENTICATED");
    s.set_token("secret-token-2");
    EXPECT_EQ(s.Request(route.method, path, "{}").status, 401) << route.method << " " << path;
    s.set_token("secret-token-1");
    EXPECT_NE(s.Request(route.method, path, "{}").status, 401) << route.method << " " << path;
  }
}

TEST(ServerTest, TokenComparison) {
  EXPECT_TRUE(TokenMatches("abc", {"x", "abc"}));
  EXPECT_FALSE(TokenMatches("ab", {"abc"}));
  EXPECT_FALSE(TokenMatches("abcd", {"abc"}));
  EXPECT_FALSE(TokenMatches("", {"abc"}));
}

TEST(ServerTest, MetricsCountRequests) {
  TestServer s;
  s.Get("/healthz");
  s.Get("/v1/robots/nope");
  // A request is counted by the logger hook, which runs after its response is sent: poll briefly.
  const std::string line = "robocal_http_requests_total{method=\"GET\",route=\"/v1/robots/{robot}\",code=\"404\"} 1";
  Reply m;
  for (int i = 0; i < 200; ++i) {
    m = s.Get("/metrics");
    if (m.text.find(line) != std::string::npos) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(m.status, 200);
  EXPECT_NE(m.text.find("robocal_http_requests_total{method=\"GET\",route=\"/v1/robots/{robot}\",code=\"404\"} 1"),
            std::string::npos)
      << m.text;
  EXPECT_NE(m.text.find("robocal_operations_running"), std::string::npos);
}

TEST(ServerTest, OpenApiSpecMatchesTheRouteTable) {
  const json spec = json::parse(OpenApiSpec());
  ASSERT_TRUE(spec.contains("paths"));
  std::set<std::pair<std::string, std::string>> routes, documented;
  for (const RouteInfo& r : Routes()) routes.insert({r.method, r.openapi_path});
  for (auto it = spec["paths"].begin(); it != spec["paths"].end(); ++it) {
    for (auto m = it.value().begin(); m != it.value().end(); ++m) {
      std::string method = m.key();
      if (method == "parameters") continue;
      for (char& ch : method) ch = static_cast<char>(std::toupper(ch));
      documented.insert({method, it.key()});
    }
  }
  for (const auto& r : routes) EXPECT_TRUE(documented.count(r)) << "undocumented: " << r.first << " " << r.second;
  for (const auto& d : documented) EXPECT_TRUE(routes.count(d)) << "not served: " << d.first << " " << d.second;
}

TEST(ConfigTest, PrecedenceFlagsEnvFileDefaults) {
  const std::string file = ::testing::TempDir() + "robocal_config_test.json";
  std::ofstream(file) << R"({"host":"127.0.0.2","port":9000,"db":"/tmp/a.db","threads":3})";
  const ConfigResult r = LoadConfig({"--port", "9100", "--config", file}, {{"ROBOCAL_PORT", "9001"},
                                                                          {"ROBOCAL_DB", "/tmp/b.db"}});
  ASSERT_TRUE(r.run) << r.message;
  EXPECT_EQ(r.config.host, "127.0.0.2");
  EXPECT_EQ(r.config.port, 9100);
  EXPECT_EQ(r.config.db, "/tmp/b.db");
  EXPECT_EQ(r.config.threads, 3);
  EXPECT_EQ(r.config.max_body_bytes, 8388608);
  const ConfigResult env_file = LoadConfig({}, {{"ROBOCAL_CONFIG", file}});
  EXPECT_EQ(env_file.config.port, 9000);
}

TEST(ConfigTest, BadFlagsExitTwo) {
  EXPECT_EQ(LoadConfig({"--bogus"}, {}).exit_code, 2);
  EXPECT_EQ(LoadConfig({"--port", "http"}, {}).exit_code, 2);
  EXPECT_EQ(LoadConfig({"--port"}, {}).exit_code, 2);
  EXPECT_EQ(LoadConfig({"--log-level", "loud"}, {}).exit_code, 2);
  EXPECT_EQ(LoadConfig({}, {{"ROBOCAL_THREADS", "0"}}).exit_code, 2);
  EXPECT_EQ(LoadConfig({"--tls-cert", "a.pem"}, {}).exit_code, 2);
  const ConfigResult help = LoadConfig({"--help"}, {});
  EXPECT_FALSE(help.run);
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.message.find("--max-measurements-per-campaign"), std::string::npos);
  EXPECT_TRUE(LoadConfig({"--allow-insecure-bind", "--log-format=json"}, {}).config.allow_insecure_bind);
  EXPECT_TRUE(IsLoopbackHost("127.0.0.1"));
  EXPECT_FALSE(IsLoopbackHost("0.0.0.0"));
}

}  // namespace
}  // namespace robocal::server::testing
