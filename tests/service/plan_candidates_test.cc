// Plans from the cell's own configurations over HTTP (POST /v1/plans with "candidates"): the three sources, the
// account of rejected candidates, the coverage warning, a task, and "num_configurations": "auto".
#include <cmath>
#include <map>
#include <set>
#include <sstream>

#include <gtest/gtest.h>

#include "robocal/api/robots.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"
#include "test_server.h"

namespace robocal::server::testing {
namespace {

using nlohmann::json;

// `count` random ur5e joint vectors on the wire (deg), joint 2 within `joint2_half_range_deg` of -90 deg when
// given (a cell whose poses keep the shoulder nearly still).
json Candidates(int count, std::uint64_t seed, double joint2_half_range_deg = 0.0) {
  const RobotModel model = Preset("ur5e");
  Rng rng(seed);
  json list = json::array();
  for (int i = 0; i < count; ++i) {
    std::vector<double> q = api::JointsToWire(model, RandomConfiguration(model, &rng));
    if (joint2_half_range_deg > 0.0) q[1] = -90.0 + joint2_half_range_deg * (2.0 * rng.Uniform() - 1.0);
    list.push_back(q);
  }
  return list;
}

json PlanFrom(const json& candidates, int n) {
  return {{"robot", "ur5e"},       {"num_configurations", n}, {"measurement_type", "position"},
          {"seed", 3},             {"num_validation", 20},    {"candidates", candidates},
          {"optimiser", "exchange"}};
}

// Each planned configuration is the candidate its index names, no index twice.
void ExpectMembers(const json& plan, const json& candidates) {
  ASSERT_EQ(plan["candidate_indices"].size(), plan["configurations"].size());
  std::set<int> seen;
  for (std::size_t m = 0; m < plan["configurations"].size(); ++m) {
    const int k = plan["candidate_indices"][m];
    EXPECT_TRUE(seen.insert(k).second) << "candidate " << k << " twice";
    for (std::size_t j = 0; j < 6; ++j) {
      EXPECT_NEAR(plan["configurations"][m][j].get<double>(), candidates[k][j].get<double>(), 1e-9);
    }
  }
}

TEST(PlanCandidatesTest, AListOfJointVectorsIsPlannedFromWithEachConfigurationsIndex) {
  TestServer s;
  const json candidates = Candidates(200, 11);
  const Reply plan = s.Post("/v1/plans", PlanFrom(candidates, 10));
  ASSERT_EQ(plan.status, 200) << plan.text;
  ExpectMembers(plan.body, candidates);
  // Without an objective a plan from candidates is D-optimal.
  EXPECT_EQ(plan.body["objective"], "log_det");
  EXPECT_EQ(plan.body["candidates"]["num_candidates"], 200);
  EXPECT_EQ(plan.body["candidates"]["num_usable"], 200);
  // Spread candidates: every joint covers most of its range, no warning.
  ASSERT_EQ(plan.body["coverage"]["joints"].size(), 6u);
  EXPECT_GT(plan.body["coverage"]["joints"][1]["fraction"].get<double>(), 0.8);
  EXPECT_EQ(plan.body["coverage"]["warning"], "");
  // The plan beats the random set of as many of the same candidates on its own objective.
  EXPECT_GT(plan.body["indices"]["log_det"].get<double>(), plan.body["baseline"]["indices"]["log_det"].get<double>());
  // The stored plan keeps the request's candidates and answers the same.
  const Reply again = s.Get("/v1/plans/" + plan.body["id"].get<std::string>());
  ASSERT_EQ(again.status, 200);
  EXPECT_EQ(again.body["candidate_indices"], plan.body["candidate_indices"]);
  EXPECT_EQ(again.body["request"]["candidates"]["joints"].size(), 200u);
}

TEST(PlanCandidatesTest, MalformedCandidatesAreRefusedByIndexOrCountedAsTheRequestChooses) {
  TestServer s;
  json candidates = Candidates(60, 12);
  candidates[5] = {1.0, 2.0, 3.0};
  candidates[7][5] = 900.0;
  const Reply refused = s.Post("/v1/plans", PlanFrom(candidates, 8));
  EXPECT_EQ(refused.status, 400);
  EXPECT_TRUE(NamesField(refused, "candidates.joints[5]")) << refused.text;
  EXPECT_TRUE(NamesField(refused, "candidates.joints[7][5]")) << refused.text;
  json nan = Candidates(60, 12);
  nan[9][0] = "x";
  EXPECT_TRUE(NamesField(s.Post("/v1/plans", PlanFrom(nan, 8)), "candidates[9][0]"));

  const Reply counted = s.Post("/v1/plans", PlanFrom({{"joints", candidates}, {"malformed", "reject"}}, 8));
  ASSERT_EQ(counted.status, 200) << counted.text;
  EXPECT_EQ(counted.body["candidates"]["num_usable"], 58);
  std::map<std::string, json> rejected;
  for (const json& r : counted.body["candidates"]["rejected"]) rejected[r["reason"]] = r;
  EXPECT_EQ(rejected["joint_count"]["first_indices"], json::array({5}));
  EXPECT_EQ(rejected["beyond_limits"]["first_indices"], json::array({7}));
  for (const json& k : counted.body["candidate_indices"]) EXPECT_TRUE(k != 5 && k != 7);
  EXPECT_EQ(s.storage().List("plans").size(), 1u);
}

TEST(PlanCandidatesTest, MoreConfigurationsThanUsableCandidatesIsRefusedNamingBothCounts) {
  TestServer s;
  const Reply r = s.Post("/v1/plans", PlanFrom(Candidates(20, 13), 25));
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(ReasonOf(r, "num_configurations").find("25 configurations asked, 20 of 20"), std::string::npos) << r.text;
  EXPECT_TRUE(NamesField(s.Post("/v1/plans", PlanFrom(json::array(), 5)), "candidates"));
  EXPECT_TRUE(NamesField(s.Post("/v1/plans", PlanFrom({{"joints", Candidates(5, 1)}, {"campaign", "c"}}, 3)),
                         "candidates"));
  EXPECT_EQ(s.storage().List("plans").size(), 0u);
}

TEST(PlanCandidatesTest, ACampaignsMeasuredPosesAreCandidatesEachOnce) {
  TestServer s;
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "taught"}, {"robot", "ur5e"}, {"measurement_type", "position"}}).status,
            200);
  const RobotModel model = Preset("ur5e");
  const json poses = Candidates(30, 14);
  json measurements = json::array();
  for (const json& q : poses) {
    const Eigen::Vector3d p = ForwardKinematics(model, api::JointsToCore(model, q)).translation();
    // Two shots of each pose: one candidate.
    for (int shot = 0; shot < 2; ++shot) {
      measurements.push_back({{"joints", q}, {"pose", {{"position_mm", {p.x(), p.y(), p.z()}}}}});
    }
  }
  ASSERT_EQ(s.Post("/v1/campaigns/taught/measurements",
                   {{"request_id", "b1"}, {"measurements", measurements}})
                .status,
            200);
  const Reply plan = s.Post("/v1/plans", PlanFrom({{"campaign", "taught"}}, 10));
  ASSERT_EQ(plan.status, 200) << plan.text;
  EXPECT_EQ(plan.body["candidates"]["num_candidates"], 30);
  ExpectMembers(plan.body, poses);
  EXPECT_EQ(s.Post("/v1/plans", PlanFrom({{"campaign", "missing"}}, 10)).status, 404);
}

TEST(PlanCandidatesTest, ATrackerExportsRowsAreCandidatesWithTheirLines) {
  TestServer s;
  const json poses = Candidates(40, 15);
  std::ostringstream csv;
  csv.precision(17);
  csv << "q1;q2;q3;q4;q5;q6;x;y;z\r\n";
  std::vector<int> line_of;  // first line of each pose, 1-based
  int line = 1;
  for (const json& q : poses) {
    line_of.push_back(line + 1);
    for (int shot = 0; shot < 2; ++shot) {
      ++line;
      for (int j = 0; j < 6; ++j) csv << q[j].get<double>() * M_PI / 180.0 << ";";
      csv << "1;2;3\r\n";
    }
  }
  const json file = {{"format", "csv"},
                     {"text", csv.str()},
                     {"unit", "mm"},
                     {"columns", {{"x", "x"}, {"y", "y"}, {"z", "z"}}},
                     {"joints", {{"columns", {"q1", "q2", "q3", "q4", "q5", "q6"}}, {"unit", "rad"}}}};
  const Reply plan = s.Post("/v1/plans", PlanFrom({{"file", file}}, 10));
  ASSERT_EQ(plan.status, 200) << plan.text;
  EXPECT_EQ(plan.body["candidates"]["num_candidates"], 40);
  ASSERT_EQ(plan.body["candidate_lines"].size(), 10u);
  for (std::size_t m = 0; m < 10; ++m) {
    const int k = plan.body["candidate_indices"][m];
    EXPECT_EQ(plan.body["candidate_lines"][m], line_of[static_cast<std::size_t>(k)]);
    EXPECT_NEAR(plan.body["configurations"][m][0].get<double>(), poses[k][0].get<double>(), 1e-9);
  }
  // A request_id (as the CLI's import request carries, empty) is no matter here; rows must be data rows.
  json with_id = file;
  with_id["request_id"] = "";
  EXPECT_EQ(s.Post("/v1/plans", PlanFrom({{"file", with_id}}, 10)).status, 200);
  json rows = file;
  rows["rows"] = {1, 3, 999};
  const Reply not_data = s.Post("/v1/plans", PlanFrom({{"file", rows}}, 1));
  EXPECT_TRUE(NamesField(not_data, "candidates.file.rows[0]")) << not_data.text;
  EXPECT_TRUE(NamesField(not_data, "candidates.file.rows[2]")) << not_data.text;
  json bad = file;
  bad.erase("joints");
  EXPECT_TRUE(NamesField(s.Post("/v1/plans", PlanFrom({{"file", bad}}, 10)), "candidates.file.joints"));
}

TEST(PlanCandidatesTest, CandidatesWithANarrowJointWarnNamingItAndTheParametersLeftPoorlyDetermined) {
  TestServer s;
  const Reply plan = s.Post("/v1/plans", PlanFrom(Candidates(300, 16, 7.5), 12));
  ASSERT_EQ(plan.status, 200) << plan.text;
  const json& coverage = plan.body["coverage"];
  EXPECT_TRUE(coverage["joints"][1]["too_narrow"].get<bool>());
  EXPECT_LT(coverage["joints"][1]["fraction"].get<double>(), 0.03);
  for (int j : {0, 2, 3, 4, 5}) EXPECT_FALSE(coverage["joints"][j]["too_narrow"].get<bool>()) << j;
  EXPECT_NE(coverage["warning"].get<std::string>().find("joint 2"), std::string::npos) << coverage["warning"];
  ASSERT_FALSE(coverage["poorly_determined"].empty());
  for (const json& p : coverage["poorly_determined"]) {
    EXPECT_TRUE(p["std_ratio"].is_null() || p["std_ratio"].get<double>() > 10.0) << p;
  }
}

TEST(PlanCandidatesTest, ATaskIsThePredictedErrorsSampleAndItsObjective) {
  TestServer s;
  const json task = Candidates(25, 17);
  json request = PlanFrom(Candidates(150, 18), 10);
  request["task"] = {{"joints", task}};
  request.erase("num_validation");
  const Reply plan = s.Post("/v1/plans", request);
  ASSERT_EQ(plan.status, 200) << plan.text;
  EXPECT_EQ(plan.body["objective"], "predicted_error");
  EXPECT_EQ(plan.body["predicted_accuracy"]["num_validation"], 25);
  // The planned set predicts less error on the task than the random set of as many candidates.
  EXPECT_LT(plan.body["predicted_accuracy"]["rms_error_mm"].get<double>(),
            plan.body["baseline"]["predicted_accuracy"]["rms_error_mm"].get<double>());

  request["task"] = {{"joints", json::array({{0.0, 1.0}})}};
  EXPECT_TRUE(NamesField(s.Post("/v1/plans", request), "task.joints[0]"));
  request["task"] = {{"joints", json::array()}};
  EXPECT_TRUE(NamesField(s.Post("/v1/plans", request), "task.joints"));
  request["task"] = json::object();
  EXPECT_TRUE(NamesField(s.Post("/v1/plans", request), "task"));
  request["task"] = {{"box", {{"min_mm", {300, -200, 200}}, {"max_mm", {200, 200, 600}}}}};
  EXPECT_TRUE(NamesField(s.Post("/v1/plans", request), "task.box.max_mm[0]"));

  // A box of the base frame with a tool orientation: solved by the arm's inverse kinematics.
  request["task"] = {{"box", {{"min_mm", {300, -200, 200}}, {"max_mm", {500, 200, 500}},
                              {"orientations_rpy_deg", {{180, 0, 0}}}, {"count", 30}}}};
  const Reply boxed = s.Post("/v1/plans", request);
  ASSERT_EQ(boxed.status, 200) << boxed.text;
  EXPECT_EQ(boxed.body["task_method"], "inverse_kinematics");
  EXPECT_EQ(boxed.body["predicted_accuracy"]["num_validation"], 30);
}

TEST(PlanCandidatesTest, AutoPicksTheSmallestCountWhosePredictionReachesTheGoal) {
  TestServer s;
  json request = PlanFrom(Candidates(200, 19), 10);
  request["num_configurations"] = "auto";
  request["min_configurations"] = 8;
  request["max_configurations"] = 30;
  EXPECT_TRUE(NamesField(s.Post("/v1/plans", request), "accuracy_goal_mm"));
  request["accuracy_goal_mm"] = 0.02;
  const Reply plan = s.Post("/v1/plans", request);
  ASSERT_EQ(plan.status, 200) << plan.text;
  const json& curve = plan.body["pose_count"];
  ASSERT_EQ(curve["points"].size(), 23u);
  ASSERT_FALSE(curve["chosen"].is_null()) << curve;
  const int chosen = curve["chosen"];
  EXPECT_EQ(plan.body["configurations"].size(), static_cast<std::size_t>(chosen));
  for (const json& p : curve["points"]) {
    const json& e = p["predicted_mean_mm"];
    const int n = p["num_configurations"];
    if (n == chosen) EXPECT_LE(e.get<double>(), 0.02);
    if (n < chosen) EXPECT_TRUE(e.is_null() || e.get<double>() > 0.02) << p;
  }
  // A goal no N in the range reaches: the range's largest N, and no choice.
  request["accuracy_goal_mm"] = 1e-6;
  const Reply unreachable = s.Post("/v1/plans", request);
  ASSERT_EQ(unreachable.status, 200) << unreachable.text;
  EXPECT_TRUE(unreachable.body["pose_count"]["chosen"].is_null());
  EXPECT_EQ(unreachable.body["configurations"].size(), 30u);
  request["max_configurations"] = 5;
  EXPECT_TRUE(NamesField(s.Post("/v1/plans", request), "max_configurations"));
  // The range goes with "auto" only.
  json fixed = PlanFrom(Candidates(50, 19), 10);
  fixed["min_configurations"] = 8;
  EXPECT_TRUE(NamesField(s.Post("/v1/plans", fixed), "min_configurations"));
}

// Whatever the optimiser, "auto" returns a set predicted to be as good on the task as the one the pose count judged:
// random selection's own set of N would miss the goal the curve's set reaches.
TEST(PlanCandidatesTest, AutoNeverReturnsASetWorseThanTheOneItsCountWasJudgedBy) {
  TestServer s;
  json request = PlanFrom(Candidates(200, 20), 10);
  request["num_configurations"] = "auto";
  request["accuracy_goal_mm"] = 0.03;
  request["optimiser"] = "random";
  const Reply plan = s.Post("/v1/plans", request);
  ASSERT_EQ(plan.status, 200) << plan.text;
  ASSERT_FALSE(plan.body["pose_count"]["chosen"].is_null());
  const double predicted_mean = 0.9213177319235613 * plan.body["predicted_accuracy"]["rms_error_mm"].get<double>();
  EXPECT_LE(predicted_mean, 0.03 * (1.0 + 1e-9)) << plan.body["summary"]["message"];
  ExpectMembers(plan.body, request["candidates"]);
}

// In a cell, candidates beyond its joint ranges are the cell's to reject, by its rule: counted as joint_range, not
// refused as beyond the robot's limits (which they are not).
TEST(PlanCandidatesTest, ACellsJointRangesRejectCandidatesByTheirRule) {
  TestServer s;
  const json cell = {
      {"id", "narrow"},
      {"robot", "ur5e"},
      {"tracker", {{"position_mm", {0, 0, 3000}}}},
      {"reflectors",
       {{{"id", "smr"}, {"position_mm", {0, 0, 50}}, {"normal", {0, 0, 1}}, {"acceptance_half_angle_deg", 180}}}},
      {"joint_ranges",
       {{{"min", -360}, {"max", 360}},
        {{"min", -360}, {"max", 360}},
        {{"min", -360}, {"max", 360}},
        {{"min", -360}, {"max", 360}},
        {{"min", -360}, {"max", 360}},
        {{"min", -90}, {"max", 90}}}}};
  const Reply made = s.Post("/v1/cells", cell);
  ASSERT_EQ(made.status, 200) << made.text;
  json candidates = Candidates(300, 21);
  for (json& q : candidates) q[5] = 0.0;
  candidates[3][5] = 120.0;
  json request = PlanFrom(candidates, 6);
  request["cell"] = "narrow";
  for (bool async : {false, true}) {
    request["async"] = async;
    Reply plan = s.Post("/v1/plans", request);
    ASSERT_EQ(plan.status, 200) << plan.text;
    if (async) {
      const std::string op = plan.body["id"];
      do plan = s.Get("/v1/operations/" + op);
      while (!plan.body["done"].get<bool>());
      ASSERT_EQ(plan.body["state"], "SUCCEEDED") << plan.text;
      plan = s.Get("/v1/plans/" + plan.body["result"]["plan"].get<std::string>());
    }
    bool named = false;
    for (const json& r : plan.body["candidates"]["rejected"]) {
      if (r["reason"] == "joint_range") named = r["first_indices"].get<std::vector<int>>()[0] == 3;
    }
    EXPECT_TRUE(named) << plan.body["candidates"];
    for (const json& k : plan.body["candidate_indices"]) EXPECT_NE(k, 3);
  }
}

}  // namespace
}  // namespace robocal::server::testing
