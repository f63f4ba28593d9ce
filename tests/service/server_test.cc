// The HTTP server end to end in-process: every endpoint, bad input, idempotency, auth, limits, operations.
#include <atomic>
#include <condition_variable>
#include <cstring>
#include <fstream>
#include <future>
#include <mutex>
#include <regex>
#include <set>
#include <sstream>
#include <tuple>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "robocal/api/calibration.h"
#include "robocal/api/campaigns.h"
#include "robocal/api/plans.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/virtual_cell.h"
#include "robocal/server/config.h"
#include "robocal/server/memory_trimmer.h"
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
    list.push_back({{"joints", api::JointsToWire(model, q)}, {"pose", nlohmann::json(api::TransformToPose(pose))}});
  }
  return {{"request_id", request_id}, {"role", role}, {"measurements", list}};
}

// Simulated tracker shots of a robot with geometric errors: a fit of these takes several iterations.
json CellBatch(const std::string& robot, const std::string& request_id, int count, std::uint64_t seed) {
  const RobotModel model = Preset(robot);
  VirtualCellOptions o;
  o.seed = seed;
  o.shots_per_pose = 1;
  VirtualCell cell(model, o);
  Rng rng(seed);
  std::vector<Eigen::VectorXd> configurations;
  for (int i = 0; i < count; ++i) configurations.push_back(RandomConfiguration(model, &rng));
  json list = json::array();
  for (const Measurement& m : cell.MeasureAll(configurations)) {
    list.push_back({{"joints", api::JointsToWire(model, m.joints)},
                    {"pose", nlohmann::json(api::TransformToPose(m.T_world_tool))}});
  }
  return {{"request_id", request_id}, {"role", "calibration"}, {"measurements", list}};
}

// A campaign "cf" of ur5e with 30 simulated shots.
void CreateFitCampaign(TestServer& s) {
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "cf"}, {"robot", "ur5e"}}).status, 200);
  const Reply batch = s.Post("/v1/campaigns/cf/measurements", CellBatch("ur5e", "shots", 30, 5));
  ASSERT_EQ(batch.status, 200) << batch.text;
}

// Polls the operation until it is done (300 s: a hang guard, not a time the operation should keep to).
Reply WaitDone(TestServer& s, const std::string& op) {
  Reply state;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(300);
  while (std::chrono::steady_clock::now() < give_up) {
    state = s.Get("/v1/operations/" + op);
    if (state.body.value("done", false)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_TRUE(state.body.value("done", false)) << state.text;
  return state;
}

TEST(ServerTest, HealthzAndSpecAndUnknownEndpoint) {
  TestServer s;
  EXPECT_EQ(s.Get("/healthz").body["status"], "ok");
  const Reply spec = s.Get("/v1/openapi.json");
  EXPECT_EQ(spec.status, 200);
  EXPECT_TRUE(spec.body.contains("openapi"));
  // Served exactly as api/openapi.json (embedded in parts at build time and joined).
  std::ifstream file(ROBOCAL_SOURCE_DIR "/api/openapi.json", std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  ASSERT_GT(text.size(), 65536u);
  EXPECT_TRUE(spec.text == text) << "served " << spec.text.size() << " bytes, api/openapi.json " << text.size();
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

// The reason given for `field`, "" if it is not named.
std::string ReasonFor(const Reply& r, const std::string& field) {
  if (!r.body.is_object() || !r.body.contains("error")) return "";
  for (const auto& d : r.body["error"]["details"]) {
    if (d.value("field", "") == field) return d.value("reason", "");
  }
  return "";
}

// Work is bounded on the plan's total before anything runs (async, so that a server without the bound would
// answer at once with an operation instead of holding the test): each refusal names the fields that set the
// total and the limit it exceeds, and nothing is stored or started.
TEST(ServerTest, PlansOverTheWorkLimitsAreRefusedNamingFieldsAndLimit) {
  TestServer s;
  json p = SmallPlan("ur5e");
  p["async"] = true;
  p["options"] = {{"k_max", 1000000}, {"restarts", 1000}};
  const Reply restarts = s.Post("/v1/plans", p);
  EXPECT_EQ(restarts.status, 400) << restarts.text;
  for (const char* field : {"options.k_max", "options.restarts"}) {
    EXPECT_NE(ReasonFor(restarts, field).find("2002001001 objective evaluations"), std::string::npos) << field;
    EXPECT_NE(ReasonFor(restarts, field).find("max_plan_evaluations = 1000000"), std::string::npos) << field;
  }

  p["optimiser"] = "exchange";
  p["options"] = {{"num_candidates", 100000}};
  const Reply pool = s.Post("/v1/plans", p);
  EXPECT_EQ(pool.status, 400) << pool.text;
  EXPECT_NE(ReasonFor(pool, "options.num_candidates").find("max_plan_candidates = 20000"), std::string::npos)
      << pool.text;

  // A pool within its limit, but 200 iterations of 20016 evaluations each.
  p["options"] = {{"num_candidates", 20000}};
  const Reply exchange = s.Post("/v1/plans", p);
  EXPECT_EQ(exchange.status, 400) << exchange.text;
  for (const char* field : {"options.max_iterations", "options.num_candidates", "options.screen"}) {
    EXPECT_NE(ReasonFor(exchange, field).find("max_plan_evaluations"), std::string::npos) << field;
  }

  // M = 1000 at 20001 evaluations: 2e7 Jacobians.
  p["optimiser"] = "solis_wets";
  p["num_configurations"] = 1000;
  p["options"] = {{"k_max", 10000}};
  const Reply jacobians = s.Post("/v1/plans", p);
  EXPECT_EQ(jacobians.status, 400) << jacobians.text;
  for (const char* field : {"num_configurations", "options.k_max", "options.restarts", "num_validation"}) {
    EXPECT_NE(ReasonFor(jacobians, field).find("max_plan_jacobians = 10000000"), std::string::npos) << field;
  }
  EXPECT_EQ(s.storage().List("plans").size(), 0u);
  EXPECT_EQ(s.storage().List("operations").size(), 0u);
}

// With a budget at the limit, the plan's reported evaluations stay within it, and they include the exchange
// optimiser's screening: 1 + iterations x (num_candidates + screen).
TEST(ServerTest, PlansAtTheLimitReportEvaluationsWithinIt) {
  ServiceOptions options;
  options.limits.max_plan_evaluations = 3000;
  TestServer s({}, {}, options);
  json p = SmallPlan("ur5e");
  p["optimiser"] = "exchange";
  p["options"] = {{"num_candidates", 300}, {"max_iterations", 1000}, {"max_evaluations", 3000}};
  const Reply exchange = s.Post("/v1/plans", p);
  ASSERT_EQ(exchange.status, 200) << exchange.text;
  const json& summary = exchange.body["summary"];
  EXPECT_LE(summary["evaluations"].get<int>(), 3000) << summary.dump();
  EXPECT_EQ(summary["evaluations"].get<int>(), 1 + summary["iterations"].get<int>() * (300 + 16)) << summary.dump();
  // Without max_evaluations the same request is over the limit.
  p["options"].erase("max_evaluations");
  EXPECT_EQ(s.Post("/v1/plans", p).status, 400);

  p["optimiser"] = "solis_wets";
  p["options"] = {{"k_max", 100000}, {"restarts", 5}, {"max_evaluations", 3000}};
  const Reply solis_wets = s.Post("/v1/plans", p);
  ASSERT_EQ(solis_wets.status, 200) << solis_wets.text;
  EXPECT_LE(solis_wets.body["summary"]["evaluations"].get<int>(), 3000);
  EXPECT_GE(solis_wets.body["summary"]["evaluations"].get<int>(), 2999);
  EXPECT_NE(solis_wets.body["summary"]["message"].get<std::string>().find("evaluation budget reached"),
            std::string::npos);
}

TEST(ServerTest, AsyncPlanRunsAsAnOperation) {
  TestServer s;
  json p = SmallPlan();
  p["async"] = true;
  const Reply op = s.Post("/v1/plans", p);
  ASSERT_EQ(op.status, 200) << op.text;
  const std::string id = op.body["id"];
  const Reply state = WaitDone(s, id);
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
  const Reply state = WaitDone(s, id);
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

// What the storage holds, to show that a rejected request wrote nothing.
std::string StorageSnapshot(Storage& storage, const std::string& campaign) {
  std::string snapshot;
  for (const char* collection : {"robots", "plans", "campaigns", "calibrations", "operations"}) {
    for (const Document& d : storage.List(collection)) snapshot += d.collection + "/" + d.id + "#" + d.json + "\n";
  }
  return snapshot + "measurements " + std::to_string(storage.CountMeasurements(campaign));
}

TEST(ServerTest, EveryEndpointRejectsBadInputNamingTheFieldAndStoresNothing) {
  TestServer s;
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "c5"}, {"robot", "ur5e"}}).status, 200);
  ASSERT_EQ(s.Post("/v1/campaigns/c5/measurements", NominalBatch("ur5e", "cal", 30, 1)).status, 200);
  ASSERT_EQ(s.Post("/v1/campaigns/c5/measurements", NominalBatch("ur5e", "val", 5, 2, "validation")).status, 200);
  const Reply fit = s.Post("/v1/campaigns/c5:fit", json::object());
  ASSERT_EQ(fit.status, 200) << fit.text;
  const std::string before = StorageSnapshot(s.storage(), "c5");

  const json good = NominalBatch("ur5e", "bad", 2, 3);
  auto batch_with = [&](const json::json_pointer& at, const json& value) {
    json b = good;
    b[at] = value;
    return b.dump();
  };
  const std::string pose = R"({"position_mm":[100,200,300],"quaternion":[1,0,0,0]})";
  struct Case {
    const char* method;
    std::string path;
    std::string body;
    int status;
    std::string field;
  };
  const std::vector<Case> cases = {
      {"POST", "/v1/robots", R"({"id":"Bad Id","from_preset":"ur5e"})", 400, "id"},
      {"POST", "/v1/robots",
       R"({"id":"r9","convention":"dh","joints":[{"type":"revolute","a_mm":1e308,"min_deg":0,"max_deg":10}]})", 400,
       "joints[0].a_mm"},
      {"POST", "/v1/robots", R"({"id":"r9","convention":"dh","joints":"six"})", 400, "joints"},
      {"POST", "/v1/robots/ur5e:forward", R"({"joints":[]})", 400, "joints"},
      {"POST", "/v1/robots/ur5e:forward", R"({"joints":[[0,0,0,0,0]]})", 400, "joints[0]"},
      {"POST", "/v1/robots/ur5e:forward", R"({"joints":[[0,0,0,0,0,1e6]]})", 400, "joints[0][5]"},
      {"POST", "/v1/robots/ur5e:forward", R"({"joints":[[0,0,0,0,0,0]],"speed":1})", 400, "speed"},
      {"POST", "/v1/robots/ur5e:forward", R"({"joints":[[0,0,0,0,0,NaN]]})", 400, "body"},
      {"POST", "/v1/plans", R"({"robot":"ur5e","num_configurations":"ten"})", 400, "num_configurations"},
      {"POST", "/v1/plans", R"({"robot":"ur5e","num_configurations":1e20})", 400, "num_configurations"},
      {"POST", "/v1/plans", R"({"robot":"ur5e","num_configurations":99999999999999999999})", 400, "num_configurations"},
      {"POST", "/v1/plans", R"({"robot":"ur5e","seed":-1})", 400, "seed"},
      {"POST", "/v1/plans", R"({"robot":"ur5e","async":"yes"})", 400, "async"},
      {"POST", "/v1/plans", R"({"robot":"ur5e","options":{"k_max":2000000000}})", 400, "options.k_max"},
      {"POST", "/v1/plans", R"({"num_configurations":5})", 400, "robot"},
      {"POST", "/v1/plans", R"({"robot":"ur5e","noise":{"position_mm":-1}})", 400, "noise.position_mm"},
      {"POST", "/v1/campaigns", R"({"robot":"ur5e","measurement_type":"laser"})", 400, "measurement_type"},
      {"POST", "/v1/campaigns", R"({"id":"C-1","robot":"ur5e"})", 400, "id"},
      {"POST", "/v1/campaigns", R"({"robot":7})", 400, "robot"},
      {"POST", "/v1/campaigns/c5/measurements", batch_with(json::json_pointer("/request_id"), nullptr), 400,
       "request_id"},
      {"POST", "/v1/campaigns/c5/measurements", batch_with(json::json_pointer("/role"), "audit"), 400, "role"},
      {"POST", "/v1/campaigns/c5/measurements", batch_with(json::json_pointer("/measurements/1/joints/0"), 1e6), 400,
       "measurements[1].joints[0]"},
      {"POST", "/v1/campaigns/c5/measurements",
       batch_with(json::json_pointer("/measurements/0/pose/position_mm/2"), 1e300), 400,
       "measurements[0].pose.position_mm[2]"},
      {"POST", "/v1/campaigns/c5/measurements", batch_with(json::json_pointer("/measurements/0/pose"), "here"), 400,
       "measurements[0].pose"},
      {"POST", "/v1/campaigns/c5/measurements", batch_with(json::json_pointer("/measurements"), json::array()), 400,
       "measurements"},
      {"GET", "/v1/campaigns/c5/measurements?role=audit", "", 400, "role"},
      {"GET", "/v1/campaigns/c5/measurements?after=-1", "", 400, "after"},
      {"GET", "/v1/robots?page_size=0", "", 400, "page_size"},
      {"GET", "/v1/campaigns?page_size=1e3", "", 400, "page_size"},
      {"GET", "/v1/campaigns?page_token=..%2Fx", "", 400, "page_token"},
      {"POST", "/v1/campaigns/c5:fit", R"({"max_iterations":0})", 400, "max_iterations"},
      {"POST", "/v1/campaigns/c5:fit", R"({"register_base":1})", 400, "register_base"},
      {"POST", "/v1/campaigns/c5:fit", R"({"parameters":"all"})", 400, "parameters"},
      {"POST", "/v1/campaigns/c5:fit", R"({"async":"yes"})", 400, "async"},
      {"POST", "/v1/campaigns/c5:compensate", R"({"targets":[{"joints":[0,0,0,0,0,0],"pose":)" + pose + "}]}", 400,
       "targets[0]"},
      {"POST", "/v1/campaigns/c5:compensate", R"({"targets":[{"pose":{"position_mm":[1,2]}}]})", 400,
       "targets[0].pose.position_mm"},
      {"POST", "/v1/campaigns/c5:compensate", R"({"targets":[{"pose":)" + pose + R"(,"frame":"moon"}]})", 400,
       "targets[0].frame"},
      {"POST", "/v1/campaigns/c5:compensate", R"({"targets":[{"joints":[0,0,0,0,0,720]}]})", 400,
       "targets[0].joints[5]"},
      {"POST", "/v1/campaigns/c5:forward", R"({"joints":[[0,0,0,0,0,"x"]]})", 400, "joints[0][5]"},
      {"POST", "/v1/campaigns/c5:evaluate", R"({"h_mm":-1})", 400, "h_mm"},
      {"POST", "/v1/campaigns/c5:evaluate", R"({"h_mm":"30"})", 400, "h_mm"},
      // Unknown (or impossible) ids.
      {"GET", "/v1/robots/no-such", "", 404, ""},
      {"DELETE", "/v1/robots/no-such", "", 404, ""},
      {"POST", "/v1/robots/no-such:forward", R"({"joints":[[0]]})", 404, ""},
      {"GET", "/v1/plans/no-such", "", 404, ""},
      {"GET", "/v1/campaigns/NO-SUCH", "", 400, "campaign"},
      {"POST", "/v1/campaigns/no-such/measurements", good.dump(), 404, ""},
      {"GET", "/v1/campaigns/no-such/measurements", "", 404, ""},
      {"POST", "/v1/campaigns/no-such:fit", "{}", 404, ""},
      {"GET", "/v1/campaigns/no-such/calibration", "", 404, ""},
      {"POST", "/v1/campaigns/no-such:compensate", R"({"targets":[{"joints":[0,0,0,0,0,0]}]})", 404, ""},
      {"POST", "/v1/campaigns/no-such:forward", R"({"joints":[[0,0,0,0,0,0]]})", 404, ""},
      {"POST", "/v1/campaigns/no-such:evaluate", "{}", 404, ""},
      {"GET", "/v1/operations/no-such", "", 404, ""},
      {"POST", "/v1/operations/no-such:cancel", "{}", 404, ""},
  };
  for (const Case& c : cases) {
    const Reply r = s.Request(c.method, c.path, c.body);
    EXPECT_EQ(r.status, c.status) << c.method << " " << c.path << " " << c.body << "\n" << r.text;
    ASSERT_TRUE(r.body.is_object() && r.body.contains("error")) << c.path << ": " << r.text;
    EXPECT_EQ(r.body["error"]["code"], c.status) << c.path;
    if (!c.field.empty()) {
      EXPECT_TRUE(NamesField(r, c.field)) << c.method << " " << c.path << " " << c.body << "\n" << r.text;
    }
  }
  // Malformed JSON on every route that reads a body.
  for (const RouteInfo& route : Routes()) {
    if (route.method != "POST" || route.openapi_path.find(":cancel") != std::string::npos) continue;
    std::string path = route.openapi_path;
    for (const auto& [param, id] : {std::pair{"{robot}", "ur5e"}, std::pair{"{campaign}", "c5"}}) {
      if (auto at = path.find(param); at != std::string::npos) path.replace(at, std::string(param).size(), id);
    }
    const Reply r = s.PostText(path, R"({"joints": [[0, 0,)");
    EXPECT_EQ(r.status, 400) << path;
    EXPECT_EQ(FirstField(r), "body") << path;
  }
  EXPECT_EQ(StorageSnapshot(s.storage(), "c5"), before);
  EXPECT_EQ(s.Get("/healthz").status, 200);
  EXPECT_EQ(s.Post("/v1/robots/ur5e:forward", {{"joints", {{0, 0, 0, 0, 0, 0}}}}).status, 200);
}

TEST(ServerTest, ListsArePagedWithANextPageToken) {
  TestServer s;
  for (const char* id : {"arm-c", "arm-a", "arm-b"}) {
    ASSERT_EQ(s.Post("/v1/robots", {{"id", id}, {"from_preset", "ur5e"}}).status, 200);
  }
  for (const char* id : {"c-4", "c-2", "c-1", "c-5", "c-3"}) {
    ASSERT_EQ(s.Post("/v1/campaigns", {{"id", id}, {"robot", "ur5e"}}).status, 200);
  }
  const std::vector<std::string> robots = {"grinder5", "puma560", "ur5e", "arm-a", "arm-b", "arm-c"};
  const std::vector<std::string> campaigns = {"c-1", "c-2", "c-3", "c-4", "c-5"};
  for (const auto& [path, key, expected] : {std::tuple{"/v1/robots", "robots", robots},
                                             std::tuple{"/v1/campaigns", "campaigns", campaigns}}) {
    const Reply all = s.Get(path);
    ASSERT_EQ(all.status, 200);
    EXPECT_EQ(all.body[key].size(), expected.size());
    EXPECT_FALSE(all.body.contains("next_page_token"));
    for (std::size_t size = 1; size <= expected.size() + 1; ++size) {
      std::vector<std::string> seen;
      std::string token;
      std::size_t pages = 0;
      do {
        const Reply page = s.Get(std::string(path) + "?page_size=" + std::to_string(size) +
                                 (token.empty() ? "" : "&page_token=" + token));
        ASSERT_EQ(page.status, 200) << page.text;
        EXPECT_LE(page.body[key].size(), size);
        for (const json& item : page.body[key]) seen.push_back(item["id"]);
        token = page.body.value("next_page_token", "");
        ASSERT_LE(++pages, expected.size() + 1) << "paging does not end";
      } while (!token.empty());
      EXPECT_EQ(seen, expected) << path << " page_size " << size;
      EXPECT_EQ(pages, (expected.size() + size - 1) / size) << path << " page_size " << size;
    }
  }
}

TEST(ServerTest, SynchronousPlanStopsAtTheRequestDeadlineAndSaysSo) {
  ServiceOptions options;
  // Long enough for the small plan below on a busy, instrumented machine; the big one runs for over a minute.
  options.request_deadline = std::chrono::milliseconds(3000);
  TestServer s({}, {}, options);
  json p = SmallPlan("ur5e");
  p["num_configurations"] = 20;
  // Over a minute of search without the deadline, within the default work limits (400000 x 20 Jacobians).
  p["options"] = {{"k_max", 1000000}, {"max_evaluations", 400000}};
  const Reply plan = s.Post("/v1/plans", p);
  ASSERT_EQ(plan.status, 200) << plan.text;
  EXPECT_EQ(plan.body["configurations"].size(), 20u);
  const json& summary = plan.body["summary"];
  EXPECT_TRUE(summary.at("deadline_exceeded").get<bool>()) << summary.dump();
  EXPECT_EQ(summary["termination"], "NO_CONVERGENCE");
  EXPECT_NE(summary["message"].get<std::string>().find("request deadline"), std::string::npos) << summary.dump();
  // The brief names the deadline too, not a cancel nobody asked for.
  EXPECT_NE(summary["brief"].get<std::string>().find("stopped at the request deadline"), std::string::npos)
      << summary.dump();
  EXPECT_EQ(summary["brief"].get<std::string>().find("cancelled"), std::string::npos) << summary.dump();
  EXPECT_LT(summary["evaluations"].get<int>(), 400000);  // the deadline stopped it, not the budget
  EXPECT_EQ(s.Get("/v1/plans/" + plan.body["id"].get<std::string>()).status, 200);
  // A plan within its deadline does not claim otherwise.
  const Reply small = s.Post("/v1/plans", SmallPlan());
  ASSERT_EQ(small.status, 200);
  EXPECT_EQ(small.body["summary"].at("deadline_exceeded"), false);
}

TEST(ServerTest, SynchronousFitStopsAtTheRequestDeadlineAndIsNotStored) {
  ServiceOptions options;
  options.request_deadline = std::chrono::milliseconds(1);
  // Each iteration outlasts the deadline, so the first progress check finds it passed.
  options.on_fit_progress = [] { std::this_thread::sleep_for(std::chrono::milliseconds(5)); };
  TestServer s({}, {}, options);
  CreateFitCampaign(s);
  const Reply fit = s.Post("/v1/campaigns/cf:fit", json::object());
  ASSERT_EQ(fit.status, 200) << fit.text;
  const json& summary = fit.body["summary"];
  EXPECT_TRUE(summary.at("deadline_exceeded").get<bool>()) << summary.dump();
  EXPECT_EQ(summary["termination"], "NO_CONVERGENCE");
  EXPECT_EQ(summary["iterations"], 1);
  EXPECT_NE(summary["message"].get<std::string>().find("request deadline"), std::string::npos) << summary.dump();
  EXPECT_FALSE(fit.body.at("stored").get<bool>());
  EXPECT_FALSE(fit.body["parameters"].empty());
  EXPECT_EQ(s.Get("/v1/campaigns/cf/calibration").status, 404);

  // Within its deadline the same fit converges, says nothing of a deadline and is stored.
  TestServer plain;
  CreateFitCampaign(plain);
  const Reply full = plain.Post("/v1/campaigns/cf:fit", json::object());
  ASSERT_EQ(full.status, 200) << full.text;
  EXPECT_EQ(full.body["summary"].at("deadline_exceeded"), false);
  EXPECT_GT(full.body["summary"]["iterations"].get<int>(), 1);
  EXPECT_TRUE(full.body.at("stored").get<bool>());
  EXPECT_EQ(plain.Get("/v1/campaigns/cf/calibration").body["parameters"], full.body["parameters"]);
}

TEST(ServerTest, AsyncFitRunsAsAnOperationAndStoresTheCalibration) {
  TestServer s;
  CreateFitCampaign(s);
  const Reply op = s.Post("/v1/campaigns/cf:fit", {{"async", true}});
  ASSERT_EQ(op.status, 200) << op.text;
  EXPECT_EQ(op.body["kind"], "fit");
  EXPECT_EQ(op.body["campaign"], "cf");
  EXPECT_TRUE(op.body["request"]["async"].get<bool>());
  const Reply done = WaitDone(s, op.body["id"]);
  EXPECT_EQ(done.body["state"], "SUCCEEDED") << done.text;
  EXPECT_EQ(done.body["progress"], 1.0);
  const json& result = done.body["result"];
  EXPECT_TRUE(result.value("stored", false));
  EXPECT_EQ(result["summary"]["termination"], "CONVERGENCE");
  const Reply stored = s.Get("/v1/campaigns/cf/calibration");
  ASSERT_EQ(stored.status, 200);
  EXPECT_EQ(stored.body["parameters"], result["parameters"]);
  // Errors of the fit itself come back as the operation's error, not as a stored calibration.
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "cg"}, {"robot", "ur5e"}}).status, 200);
  ASSERT_EQ(s.Post("/v1/campaigns/cg/measurements", CellBatch("ur5e", "few", 2, 5)).status, 200);
  const Reply failing = s.Post("/v1/campaigns/cg:fit", {{"async", true}});
  ASSERT_EQ(failing.status, 200) << failing.text;
  const Reply failed = WaitDone(s, failing.body["id"]);
  EXPECT_EQ(failed.body["state"], "FAILED") << failed.text;
  EXPECT_EQ(failed.body["error"]["status"], "FAILED_PRECONDITION");
  EXPECT_EQ(s.Get("/v1/campaigns/cg/calibration").status, 404);
}

TEST(ServerTest, AsyncFitCanBeCancelledAndCountsAsARunningOperation) {
  // The hook holds the fit after its first iteration until the test has asked to cancel: no race.
  std::promise<void> reached, release;
  std::shared_future<void> released = release.get_future().share();
  std::atomic<int> calls{0};
  ServiceOptions options;
  options.max_running_operations = 1;
  options.on_fit_progress = [&] {
    if (calls++ == 0) {
      reached.set_value();
      released.wait();
    }
  };
  TestServer s({}, {}, options);
  CreateFitCampaign(s);
  const Reply op = s.Post("/v1/campaigns/cf:fit", {{"async", true}});
  ASSERT_EQ(op.status, 200) << op.text;
  const std::string id = op.body["id"];
  if (reached.get_future().wait_for(std::chrono::seconds(120)) != std::future_status::ready) {
    release.set_value();
    FAIL() << "the fit never reached its first iteration";
  }
  const Reply busy = s.Post("/v1/campaigns/cf:fit", {{"async", true}});
  EXPECT_EQ(busy.status, 503) << busy.text;
  EXPECT_TRUE(NamesField(busy, "async"));
  const Reply cancel = s.Post("/v1/operations/" + id + ":cancel", json::object());
  EXPECT_EQ(cancel.status, 200);
  EXPECT_TRUE(cancel.body.value("cancel_requested", false)) << cancel.text;
  release.set_value();
  const Reply done = WaitDone(s, id);
  EXPECT_EQ(done.body["state"], "CANCELLED") << done.text;
  const json& result = done.body["result"];
  EXPECT_FALSE(result.value("stored", true));
  EXPECT_EQ(result["summary"]["termination"], "NO_CONVERGENCE");
  EXPECT_EQ(result["summary"]["iterations"], 1);
  EXPECT_NE(result["summary"]["message"].get<std::string>().find("cancelled"), std::string::npos);
  EXPECT_EQ(s.Get("/v1/campaigns/cf/calibration").status, 404);
  // The slot is free again once the operation is done.
  const Reply again = s.Post("/v1/campaigns/cf:fit", {{"async", true}});
  ASSERT_EQ(again.status, 200) << again.text;
  EXPECT_EQ(WaitDone(s, again.body["id"]).body["state"], "SUCCEEDED");
  EXPECT_EQ(s.Get("/v1/campaigns/cf/calibration").status, 200);
}

// Operations are shared by every instance on one database through their leases (OperationRunner): two Services
// on one storage stand for two instances. The tests drive the lease keeper's round (KeepOperationLeases) by
// hand, and the fit hook holds the work at a known point, so nothing races the clock.
class HeldFit {
 public:
  HeldFit() {
    options.max_running_operations = 1;
    options.operation_lease = std::chrono::seconds(600);  // the keeper's own rounds stay out of the test
    // Held at its second iteration, so that the first one's progress has been recorded.
    options.on_fit_progress = [this] {
      if (calls_++ == 1) {
        reached_.set_value();
        released_.wait();
      }
    };
  }
  ~HeldFit() { Release(); }
  bool WaitReached() { return reached_.get_future().wait_for(std::chrono::seconds(120)) == std::future_status::ready; }
  void Release() {
    if (!released_flag_.exchange(true)) release_.set_value();
  }
  ServiceOptions options;

 private:
  std::promise<void> reached_, release_;
  std::shared_future<void> released_ = release_.get_future().share();
  std::atomic<int> calls_{0};
  std::atomic<bool> released_flag_{false};
};

// Campaign "cf" of `a`, an async fit of it held at its second iteration; the operation's id ("" if it failed).
std::string StartHeldFit(TestServer& a, HeldFit& held) {
  CreateFitCampaign(a);
  const Reply op = a.Post("/v1/campaigns/cf:fit", {{"async", true}});
  EXPECT_EQ(op.status, 200) << op.text;
  if (op.status != 200 || !held.WaitReached()) return "";
  return op.body["id"];
}

TEST(OperationLeaseTest, AnotherInstanceSeesProgressAndCancelsThroughTheLease) {
  HeldFit held;
  TestServer a({}, {}, held.options);
  const std::string id = StartHeldFit(a, held);
  ASSERT_FALSE(id.empty());
  Service b(&a.storage(), ServiceOptions{});

  EXPECT_EQ(b.GetOperation(id).state, api::OperationState::kRunning);
  EXPECT_EQ(b.GetOperation(id).progress, 0.0) << "no renewal yet";
  a.service().KeepOperationLeases();
  const double progress = a.service().GetOperation(id).progress;
  EXPECT_GT(progress, 0.0);
  EXPECT_EQ(b.GetOperation(id).progress, progress) << "b reads the progress a renewed its lease with";

  EXPECT_TRUE(b.CancelOperation(id).cancel_requested);
  EXPECT_FALSE(a.service().GetOperation(id).cancel_requested) << "a has not renewed since";
  a.service().KeepOperationLeases();
  EXPECT_TRUE(a.service().GetOperation(id).cancel_requested);
  held.Release();
  const Reply done = WaitDone(a, id);
  EXPECT_EQ(done.body["state"], "CANCELLED") << done.text;
  EXPECT_EQ(b.GetOperation(id).state, api::OperationState::kCancelled);
  EXPECT_FALSE(a.storage().GetLease(id).has_value());
}

std::string RunningOperationJson(const std::string& id) {
  api::Operation op;
  op.id = id;
  op.plan_request = api::PlanRequest{};
  op.state = api::OperationState::kRunning;
  return nlohmann::json(api::StoredOperation{op}).dump();
}

// Instance a runs a fit; its lease lapses and instance b marks it FAILED. With `owner_renews`, a's lease keeper
// runs before the fit goes on (a learns it lost the lease and stops the work); without, the fit runs to its end
// and finds out only when it is about to store the calibration. Either way a's finish changes nothing.
void TakeOverAHeldFit(bool owner_renews) {
  HeldFit held;
  TestServer a({}, {}, held.options);
  const std::string id = StartHeldFit(a, held);
  ASSERT_FALSE(id.empty());
  auto& storage = dynamic_cast<FakeStorage&>(a.storage());
  storage.shared = true;  // a and b are two instances on one database
  Service b(&a.storage(), ServiceOptions{});
  EXPECT_EQ(b.KeepOperationLeases(), 0) << "a live lease is left alone";

  // a stops renewing (here: its lease is made to lapse, as when a's host stalls longer than the lease).
  storage.LapseLease(id);
  EXPECT_EQ(b.KeepOperationLeases(), 1);
  const api::Operation failed = b.GetOperation(id);
  EXPECT_EQ(failed.state, api::OperationState::kFailed);
  ASSERT_TRUE(failed.error.has_value());
  EXPECT_NE(failed.error->message.find("stopped renewing its lease"), std::string::npos) << failed.error->message;
  EXPECT_NE(failed.error->message.find("resubmit"), std::string::npos) << failed.error->message;

  if (owner_renews) {
    a.service().KeepOperationLeases();
    EXPECT_TRUE(a.service().GetOperation(id).done);
  }
  held.Release();
  a.service().WaitForOperations();
  ASSERT_EQ(a.service().running_operations(), 0);
  EXPECT_EQ(a.service().GetOperation(id).state, api::OperationState::kFailed) << "an operation ends once";
  EXPECT_EQ(a.Get("/v1/campaigns/cf/calibration").status, 404) << "a fit taken over stores nothing";
}

TEST(OperationLeaseTest, AnExpiredLeaseIsFailedByAnotherInstanceAndItsOwnerStopsAtItsNextRenewal) {
  TakeOverAHeldFit(true);
}

TEST(OperationLeaseTest, AFitTakenOverThatRunsToItsEndStoresNothing) { TakeOverAHeldFit(false); }

TEST(OperationLeaseTest, AFitThatCannotConfirmItsLeaseFailsRatherThanSucceedWithoutItsResult) {
  HeldFit held;
  TestServer a({}, {}, held.options);
  const std::string id = StartHeldFit(a, held);
  ASSERT_FALSE(id.empty());
  auto& storage = dynamic_cast<FakeStorage&>(a.storage());
  storage.fail_renewals = true;  // the database stops answering renewals
  held.Release();
  const Reply done = WaitDone(a, id);
  EXPECT_EQ(done.body["state"], "FAILED") << done.text;
  EXPECT_EQ(done.body["error"]["status"], "UNAVAILABLE") << done.text;
  EXPECT_NE(done.body["error"]["message"].get<std::string>().find("nothing was stored"), std::string::npos)
      << done.text;
  storage.fail_renewals = false;
  EXPECT_EQ(a.Get("/v1/campaigns/cf/calibration").status, 404);
}

TEST(OperationLeaseTest, AnOperationWhoseFinalWriteFailedEndsFailedWithoutARestart) {
  HeldFit held;
  TestServer a({}, {}, held.options);  // one process on its own database (FakeStorage: not shared)
  const std::string id = StartHeldFit(a, held);
  ASSERT_FALSE(id.empty());
  auto& storage = dynamic_cast<FakeStorage&>(a.storage());
  storage.fail_finishes = true;
  held.Release();
  a.service().WaitForOperations();
  ASSERT_EQ(a.service().running_operations(), 0);
  storage.fail_finishes = false;
  EXPECT_EQ(a.service().GetOperation(id).state, api::OperationState::kRunning) << "its final write was lost";
  // Nobody renews its lease any more; once it lapses, the process's own keeper ends it.
  storage.LapseLease(id);
  EXPECT_EQ(a.service().KeepOperationLeases(), 1);
  EXPECT_EQ(a.service().GetOperation(id).state, api::OperationState::kFailed);
}

TEST(OperationLeaseTest, AnUnreadableOperationNeverHoldsUpTheOthersLeases) {
  FakeStorage storage;
  storage.shared = true;
  // Written by a build that knows another kind of operation; both instances that ran them stopped.
  storage.CreateLeased("op-alien", R"({"schema_version":4,"id":"op-alien","kind":"teleport"})", "gone", -1);
  storage.CreateLeased("op-fit", RunningOperationJson("op-fit"), "gone", -1);
  storage.Create("operations", "op-alien-old", R"({"kind":"teleport"})");  // unreadable, no lease: left alone
  Service service(&storage, ServiceOptions{});
  EXPECT_NO_THROW(service.RecoverOperations());
  EXPECT_FALSE(storage.GetLease("op-alien").has_value());
  EXPECT_EQ(storage.Get("operations", "op-alien")->json, R"({"schema_version":4,"id":"op-alien","kind":"teleport"})");
  EXPECT_EQ(service.GetOperation("op-fit").state, api::OperationState::kFailed);
}


TEST(OperationLeaseTest, RecoveryAtStartFailsOnlyOperationsNoLiveInstanceRuns) {
  for (const bool shared : {true, false}) {
    FakeStorage storage;
    storage.shared = shared;
    storage.CreateLeased("op-live", RunningOperationJson("op-live"), "another-instance", 600000);
    storage.CreateLeased("op-lapsed", RunningOperationJson("op-lapsed"), "a-stopped-instance", -1);
    storage.Create("operations", "op-old", RunningOperationJson("op-old"));  // stored before leases existed
    Service service(&storage, ServiceOptions{});
    // Shared: the live lease belongs to a running instance. Unshared: one process owns the database, so every
    // operation found RUNNING at start belongs to a process that is gone.
    EXPECT_EQ(service.RecoverOperations(), shared ? 2 : 3) << "shared " << shared;
    EXPECT_EQ(service.GetOperation("op-live").state,
              shared ? api::OperationState::kRunning : api::OperationState::kFailed);
    EXPECT_EQ(service.GetOperation("op-lapsed").state, api::OperationState::kFailed);
    EXPECT_EQ(service.GetOperation("op-old").state, api::OperationState::kFailed);
    EXPECT_EQ(service.RecoverOperations(), 0) << "ended once";
  }
}

TEST(ServerTest, FormEncodedBodyGetsAContentTypeHint) {
  // curl -d sends application/x-www-form-urlencoded: the reply must say what to change, whatever the size.
  TestServer s;
  httplib::Client raw = GuardedClient(s.port());
  for (const std::size_t size : {10, 9000}) {
    auto form = raw.Post("/v1/robots", std::string(size, ' ') + "{}", "application/x-www-form-urlencoded");
    ASSERT_TRUE(form);
    EXPECT_EQ(form->status, 400);
    EXPECT_NE(form->body.find("application/json"), std::string::npos) << form->body;
    EXPECT_NE(form->body.find("\"field\":\"Content-Type\""), std::string::npos) << form->body;
  }
  auto json_body = raw.Post("/v1/robots", std::string(9000, ' ') + "{}", "application/json");
  ASSERT_TRUE(json_body);
  EXPECT_EQ(json_body->status, 400);  // parsed: the id is missing
}

// A fit's Jacobian (rows x measurements x parameters) is bounded before any measurement is loaded: over the
// limit the fit is refused naming the measurements, the parameters when given, and the limit; fewer parameters
// bring it within.
TEST(ServerTest, FitsOverTheJacobianLimitAreRefusedBeforeTheyStart) {
  ServiceOptions options;
  options.limits.max_fit_jacobian_entries = 3000;  // 30 pose shots x 6 rows x 30 identifiable parameters = 5400
  TestServer s({}, {}, options);
  CreateFitCampaign(s);
  const Reply all = s.Post("/v1/campaigns/cf:fit", json::object());
  EXPECT_EQ(all.status, 400) << all.text;
  EXPECT_EQ(all.body["error"]["status"], "FAILED_PRECONDITION");
  EXPECT_NE(ReasonFor(all, "measurements").find("5400 Jacobian entries"), std::string::npos) << all.text;
  EXPECT_NE(ReasonFor(all, "measurements").find("max_fit_jacobian_entries = 3000"), std::string::npos) << all.text;
  EXPECT_NE(ReasonFor(all, "measurements").find("at most 16 calibration measurements"), std::string::npos) << all.text;
  const std::vector<std::string> identifiable =
      FindIdentifiableParameters(Preset("ur5e"), MeasurementType::kPose).identifiable_names;
  ASSERT_EQ(identifiable.size(), 30u);
  json some = {{"parameters", std::vector<std::string>(identifiable.begin(), identifiable.begin() + 17)}};
  const Reply over = s.Post("/v1/campaigns/cf:fit", some);  // 30 x 6 x 17 = 3060
  EXPECT_EQ(over.status, 400) << over.text;
  EXPECT_NE(ReasonFor(over, "parameters").find("3060 Jacobian entries"), std::string::npos) << over.text;
  some["parameters"].erase(16);  // 30 x 6 x 16 = 2880
  const Reply within = s.Post("/v1/campaigns/cf:fit", some);
  ASSERT_EQ(within.status, 200) << within.text;
  EXPECT_EQ(within.body["parameters"].size(), 16u);
}

// Fit and evaluate read a campaign's measurements a page (1000) at a time: every measurement still counts.
TEST(ServerTest, FitAndEvaluateReadEveryPageOfMeasurements) {
  TestServer s;
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "pages"}, {"robot", "grinder5"}}).status, 200);
  ASSERT_EQ(s.Post("/v1/campaigns/pages/measurements", NominalBatch("grinder5", "cal", 1001, 1)).status, 200);
  ASSERT_EQ(s.Post("/v1/campaigns/pages/measurements", NominalBatch("grinder5", "val", 2001, 2, "validation")).status,
            200);
  const Reply fit = s.Post("/v1/campaigns/pages:fit", json::object());
  ASSERT_EQ(fit.status, 200) << fit.text;
  EXPECT_EQ(fit.body["summary"]["num_measurements"], 1001);
  const Reply evaluation = s.Post("/v1/campaigns/pages:evaluate", json::object());
  ASSERT_EQ(evaluation.status, 200) << evaluation.text;
  EXPECT_EQ(evaluation.body["num_validation"], 2001);
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
  // A request is counted by the logger hook, which runs after its response is sent: poll until it has (30 s:
  // a hang guard).
  const std::string line = "robocal_http_requests_total{method=\"GET\",route=\"/v1/robots/{robot}\",code=\"404\"} 1";
  Reply m;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (std::chrono::steady_clock::now() < give_up) {
    m = s.Get("/metrics");
    if (m.text.find(line) != std::string::npos) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(m.status, 200);
  EXPECT_NE(m.text.find("robocal_http_requests_total{method=\"GET\",route=\"/v1/robots/{robot}\",code=\"404\"} 1"),
            std::string::npos)
      << m.text;
  EXPECT_NE(m.text.find("robocal_operations_running"), std::string::npos);
  // Prometheus text format 0.0.4: every sample is `name{label="value",...} number` of a family whose
  // # HELP and # TYPE came first.
  const std::regex sample(R"re(([a-zA-Z_:][a-zA-Z0-9_:]*)(\{([a-zA-Z_][a-zA-Z0-9_]*="[^"\\]*",?)*\})? -?[0-9.e+-]+)re");
  const std::regex type(R"(# TYPE ([a-zA-Z_:][a-zA-Z0-9_:]*) (counter|gauge|summary|histogram|untyped))");
  std::set<std::string> typed;
  std::istringstream lines(m.text);
  for (std::string line; std::getline(lines, line);) {
    std::smatch match;
    if (line.rfind("# HELP ", 0) == 0) continue;
    if (std::regex_match(line, match, type)) {
      typed.insert(match[1]);
      continue;
    }
    ASSERT_TRUE(std::regex_match(line, match, sample)) << "not a Prometheus sample: " << line;
    std::string family = match[1];
    for (const char* suffix : {"_sum", "_count"}) {
      if (!typed.count(family) && family.ends_with(suffix)) family.resize(family.size() - std::strlen(suffix));
    }
    EXPECT_TRUE(typed.count(family)) << "sample before its # TYPE: " << line;
  }
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

// Trims run on the trimmer's thread after the delay, once however often they were asked for, none without being
// asked, and a trimmer with a trim still waiting stops at once.
TEST(MemoryTrimmerTest, TrimsOnceAfterTheDelayAndStopsAtOnce) {
  std::mutex mutex;
  std::condition_variable trimmed;
  int trims = 0;
  const auto trim = [&] {
    {
      const std::lock_guard lock(mutex);
      ++trims;
    }
    trimmed.notify_all();
  };
  // The guard only turns a hang into a failure; the test waits for the trim itself.
  const auto wait_for_trims = [&](int n) {
    std::unique_lock lock(mutex);
    return trimmed.wait_for(lock, std::chrono::minutes(1), [&] { return trims >= n; });
  };
  const auto count = [&] {
    const std::lock_guard lock(mutex);
    return trims;
  };
  {
    MemoryTrimmer trimmer(std::chrono::milliseconds(50), trim);
    for (int i = 0; i < 5; ++i) trimmer.Schedule();
    ASSERT_TRUE(wait_for_trims(1));
    // A Schedule() of the burst that came after the first trim began asks for one more (a slow test thread). Read
    // before Due(): a trim Due() reports has not begun, so it counts after `seen`.
    for (int seen = count(); trimmer.Due(); seen = count()) ASSERT_TRUE(wait_for_trims(seen + 1));
    const int after_burst = count();
    EXPECT_LE(after_burst, 5);
    EXPECT_FALSE(trimmer.Due()) << "nothing asked, nothing waiting: the thread sleeps until Schedule()";
    trimmer.Schedule();
    ASSERT_TRUE(wait_for_trims(after_burst + 1));
    EXPECT_EQ(count(), after_burst + 1);
  }
  const auto start = std::chrono::steady_clock::now();
  {
    MemoryTrimmer waiting(std::chrono::hours(1), trim);
    waiting.Schedule();
  }
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::minutes(1));
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

// A --db of another store's URL is refused at start by its scheme, from a flag, the environment or a file, and
// never opened as an SQLite file of that name.
TEST(ConfigTest, ADatabaseUrlRobocalDoesNotServeIsRefused) {
  for (const char* url : {"mysql://db/robocal", "sqlite:///var/robocal.db", "postgresq://typo/robocal"}) {
    const ConfigResult flag = LoadConfig({"--db", url}, {});
    EXPECT_FALSE(flag.run) << url;
    EXPECT_EQ(flag.exit_code, 2) << url;
    EXPECT_NE(flag.message.find("db: \""), std::string::npos) << flag.message;
    EXPECT_NE(flag.message.find("is not a database robocal serves"), std::string::npos) << flag.message;
    EXPECT_EQ(LoadConfig({}, {{"ROBOCAL_DB", url}}).exit_code, 2) << url;
  }
  const std::string file = ::testing::TempDir() + "robocal_db_url_test.json";
  std::ofstream(file) << R"({"db": "mysql://localhost/robocal"})";
  EXPECT_EQ(LoadConfig({"--config", file}, {}).exit_code, 2);
  // PostgreSQL URLs are taken as they are (OpenStorage connects, and never falls back to a file).
  for (const char* url : {"postgresql://postgres@/robocal?host=/tmp/s&port=5433", "postgres://u:pw@db:5432/robocal"}) {
    const ConfigResult r = LoadConfig({"--db", url}, {});
    ASSERT_TRUE(r.run) << url << ": " << r.message;
    EXPECT_EQ(r.config.db, url);
  }
  const ConfigResult pool = LoadConfig({"--db-pool-size", "3", "--operation-lease-s", "4"}, {});
  ASSERT_TRUE(pool.run) << pool.message;
  EXPECT_EQ(pool.config.db_pool_size, 3);
  EXPECT_EQ(pool.config.operation_lease_s, 4);
  EXPECT_EQ(LoadConfig({"--db-pool-size", "0"}, {}).exit_code, 2);
  EXPECT_EQ(LoadConfig({"--operation-lease-s", "0"}, {}).exit_code, 2);
  EXPECT_EQ(LoadConfig({"--db", ""}, {}).exit_code, 2);
  // Paths and SQLite's own names stay as they are.
  for (const char* path : {"./var/robocal.db", ":memory:", "/tmp/a:b.db", "file.db"}) {
    const ConfigResult r = LoadConfig({"--db", path}, {});
    ASSERT_TRUE(r.run) << path << ": " << r.message;
    EXPECT_EQ(r.config.db, path);
  }
}

TEST(ConfigTest, EveryLimitIsConfigurable) {
  const ConfigResult r = LoadConfig({"--max-array-length", "50", "--max-plan-evaluations=5000",
                                     "--max-running-operations", "4", "--request-timeout-s", "2"},
                                    {{"ROBOCAL_MAX_BODY_BYTES", "4096"}});
  ASSERT_TRUE(r.run) << r.message;
  EXPECT_EQ(r.config.max_array_length, 50);
  EXPECT_EQ(r.config.max_plan_evaluations, 5000);
  EXPECT_EQ(r.config.max_running_operations, 4);
  EXPECT_EQ(r.config.request_timeout_s, 2);
  EXPECT_EQ(r.config.max_body_bytes, 4096);
  EXPECT_EQ(LoadConfig({"--max-array-length", "0"}, {}).exit_code, 2);
  // The work limits, from flags, the environment and a file, and each one in --help.
  const std::string file = ::testing::TempDir() + "robocal_limits_test.json";
  std::ofstream(file) << R"({"max_fit_jacobian_entries": 12345})";
  const ConfigResult work =
      LoadConfig({"--max-plan-jacobians", "777", "--config", file}, {{"ROBOCAL_MAX_PLAN_CANDIDATES", "55"}});
  ASSERT_TRUE(work.run) << work.message;
  EXPECT_EQ(work.config.max_plan_jacobians, 777);
  EXPECT_EQ(work.config.max_plan_candidates, 55);
  EXPECT_EQ(work.config.max_fit_jacobian_entries, 12345);
  EXPECT_EQ(LoadConfig({"--max-plan-candidates", "0"}, {}).exit_code, 2);
  for (const char* flag :
       {"--max-plan-evaluations", "--max-plan-jacobians", "--max-plan-candidates", "--max-fit-jacobian-entries"}) {
    EXPECT_NE(UsageText().find(flag), std::string::npos) << flag;
  }
  // The shipped example configuration is accepted as it stands.
  const ConfigResult example = LoadConfig({"--config", ROBOCAL_SOURCE_DIR "/deploy/robocal.example.json"}, {});
  EXPECT_TRUE(example.run) << example.message;
}

TEST(ConfigTest, TokensMustBeSendableAsWritten) {
  const std::string file = ::testing::TempDir() + "robocal_tokens_percent";
  std::ofstream(file) << "# cell 7\nabc%2Ddef\n";
  EXPECT_THROW(ReadTokensFile(file), std::runtime_error);
  std::ofstream(file) << "good-token_1.x\n";
  EXPECT_EQ(ReadTokensFile(file), std::vector<std::string>{"good-token_1.x"});
}

TEST(ConfigTest, ConnectionTimeoutsFromFlagsEnvAndFile) {
  const ServerConfig defaults = LoadConfig({}, {}).config;
  EXPECT_EQ(defaults.keep_alive_timeout_s, 2);
  EXPECT_EQ(defaults.request_read_timeout_s, 10);
  EXPECT_EQ(defaults.write_timeout_s, 60);
  EXPECT_EQ(defaults.max_connections, 256);
  EXPECT_EQ(defaults.max_queued_connections, 64);
  const std::string file = ::testing::TempDir() + "robocal_timeouts_test.json";
  std::ofstream(file) << R"({"keep_alive_timeout_s":7,"request_read_timeout_s":8,"write_timeout_s":9,"max_connections":11})";
  const ConfigResult from_file = LoadConfig({"--config", file}, {});
  ASSERT_TRUE(from_file.run) << from_file.message;
  EXPECT_EQ(from_file.config.keep_alive_timeout_s, 7);
  EXPECT_EQ(from_file.config.request_read_timeout_s, 8);
  EXPECT_EQ(from_file.config.write_timeout_s, 9);
  EXPECT_EQ(from_file.config.max_connections, 11);
  const ConfigResult r = LoadConfig({"--keep-alive-timeout-s", "3", "--config", file},
                                    {{"ROBOCAL_KEEP_ALIVE_TIMEOUT_S", "4"}, {"ROBOCAL_REQUEST_READ_TIMEOUT_S", "5"}});
  ASSERT_TRUE(r.run) << r.message;
  EXPECT_EQ(r.config.keep_alive_timeout_s, 3);
  EXPECT_EQ(r.config.request_read_timeout_s, 5);
  EXPECT_EQ(r.config.write_timeout_s, 9);
  const ConfigResult zero = LoadConfig({"--keep-alive-timeout-s", "0"}, {});
  EXPECT_EQ(zero.exit_code, 2);
  EXPECT_NE(zero.message.find("keep_alive_timeout_s"), std::string::npos) << zero.message;
  EXPECT_NE(LoadConfig({"--help"}, {}).message.find("--keep-alive-timeout-s"), std::string::npos);
}

TEST(ServerTest, IdleKeepAliveConnectionIsClosedAfterTheTimeout) {
  ServerConfig config;
  config.keep_alive_timeout_s = 1;
  TestServer s(config);
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(s.port()));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  // 4.5 times the server's setting: generous for the setting on a busy machine, and shorter than the HTTP library's
  // own default (5 s), so the test fails if the setting does not reach the server.
  timeval bound{4, 500000};
  ASSERT_EQ(::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &bound, sizeof bound), 0);
  const std::string request = "GET /healthz HTTP/1.1\r\nHost: localhost\r\nConnection: keep-alive\r\n\r\n";
  ASSERT_EQ(::send(fd, request.data(), request.size(), 0), static_cast<ssize_t>(request.size()));
  std::string received;
  char buffer[4096];
  ssize_t n = 0;
  // Read the reply and then on: the server closes the idle connection (recv returns 0), or the bound hits (-1).
  while ((n = ::recv(fd, buffer, sizeof buffer, 0)) > 0) received.append(buffer, static_cast<std::size_t>(n));
  ::close(fd);
  EXPECT_NE(received.find("200 OK"), std::string::npos) << received;
  EXPECT_EQ(n, 0) << "the idle connection was not closed within 4.5 s";
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
