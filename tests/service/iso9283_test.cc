// The ISO 9283 pose test over HTTP in the virtual cell: a test plan's poses, 30 cycles measured on a robot with known
// errors and repeatability before and after compensation, and the characteristics against what the cell's truth
// gives; the bad inputs named.
#include "robocal/core/iso9283.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "robocal/api/robots.h"
#include "robocal/core/error_model.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"
#include "robocal/core/transforms.h"
#include "robocal/core/units.h"
#include "robocal/core/virtual_cell.h"
#include "test_server.h"

namespace robocal::server::testing {
namespace {

using nlohmann::json;

Eigen::Vector3d Vec(const json& a) { return {a[0].get<double>(), a[1].get<double>(), a[2].get<double>()}; }

Transform PoseOf(const json& pose) {
  api::PoseWire w;
  w.position_mm = {pose["position_mm"][0], pose["position_mm"][1], pose["position_mm"][2]};
  w.quaternion = {pose["quaternion"][0], pose["quaternion"][1], pose["quaternion"][2], pose["quaternion"][3]};
  return api::PoseToTransform(w);
}

// The test shots of a test plan measured in `cell`: one shot per configuration, tagged as the plan tags it.
json TestShots(const RobotModel& model, VirtualCell* cell, const json& plan, const std::string& request_id) {
  json list = json::array();
  for (std::size_t i = 0; i < plan["configurations"].size(); ++i) {
    const Eigen::VectorXd q = api::JointsToCore(model, plan["configurations"][i].get<std::vector<double>>());
    const Measurement m = cell->Measure(q, 1).at(0);
    list.push_back({{"joints", plan["configurations"][i]},
                    {"pose", json(api::TransformToPose(m.T_world_tool))},
                    {"test_pose", plan["test"]["tags"][i]["test_pose"]},
                    {"cycle", plan["test"]["tags"][i]["cycle"]}});
  }
  return {{"request_id", request_id}, {"role", "test"}, {"measurements", list}};
}

// Per pose of a test plan, the true robot's mean deviation from the command at its joints, in the base frame the
// report used: the systematic error the test should find.
std::vector<Eigen::Vector3d> TrueDeviations(const RobotModel& model, const VirtualCell& cell, const json& plan,
                                            const json& report) {
  const Transform T_base_world = PoseOf(report["base"]).inverse();
  std::vector<Eigen::Vector3d> out;
  for (const json& pose : plan["test"]["poses"]) {
    const Eigen::VectorXd q = api::JointsToCore(model, pose["joints"].get<std::vector<double>>());
    out.push_back((T_base_world * cell.TruePose(q)).translation() - Vec(pose["position_mm"]));
  }
  return out;
}

class Iso9283Test : public ::testing::Test {
 protected:
  static constexpr double kRepeatabilityMm = 0.06;
  static constexpr double kTrackerSigmaMm = 0.005;

  Iso9283Test() : model_(Preset("ur5e")), cell_(model_, Options()) {}
  static VirtualCellOptions Options() {
    VirtualCellOptions o;
    o.seed = 23;
    o.noise.position_mm = kTrackerSigmaMm;
    o.noise.orientation_rad = 2e-5;
    o.noise.repeatability_mm = kRepeatabilityMm;
    return o;
  }
  json TestPlan(const std::string& compensated_by = "") {
    json iso = {{"cube", {{"center_mm", {350, 250, 300}}, {"size_mm", 300}}}, {"cycles", 30}};
    if (!compensated_by.empty()) iso["compensated_by"] = compensated_by;
    const Reply plan = s_.Post("/v1/plans", {{"robot", "ur5e"}, {"test", {{"iso9283", iso}}}});
    EXPECT_EQ(plan.status, 200) << plan.text;
    return plan.body;
  }

  TestServer s_{{}, {}, {}, OpenSqliteStorage(":memory:")};
  RobotModel model_;
  VirtualCell cell_;
};

TEST_F(Iso9283Test, APlanLaysOutTheStandardsPosesWithTheirCommandsAndTags) {
  const json plan = TestPlan();
  const json& test = plan["test"];
  ASSERT_EQ(test["poses"].size(), 5u);
  ASSERT_EQ(plan["configurations"].size(), 150u);
  ASSERT_EQ(test["tags"].size(), 150u);
  EXPECT_EQ(test["tags"][0], json({{"test_pose", "P1"}, {"cycle", 1}}));
  EXPECT_EQ(test["tags"][149], json({{"test_pose", "P5"}, {"cycle", 30}}));
  const auto positions = Iso9283Positions({Eigen::Vector3d(350, 250, 300), 300.0});
  for (int k = 0; k < 5; ++k) {
    const json& pose = test["poses"][k];
    EXPECT_EQ(pose["name"], Iso9283PoseName(k));
    EXPECT_LT((Vec(pose["position_mm"]) - positions[k]).norm(), 1e-9);
    // The nominal robot reaches the pose at its joint commands, tool down, on one branch.
    const Eigen::VectorXd q = api::JointsToCore(model_, pose["joints"].get<std::vector<double>>());
    const Transform reached = model_.T_world_base().inverse() * ForwardKinematics(model_, q);
    EXPECT_LT((reached.translation() - positions[k]).norm(), 1e-6);
    EXPECT_LT(RotationVector(reached.linear().transpose() * RotX(M_PI)).norm(), 1e-9);
    EXPECT_EQ(plan["configurations"][k], pose["joints"]);
    EXPECT_EQ(plan["configurations"][145 + k], pose["joints"]);
  }
  EXPECT_FALSE(test["configuration"].get<std::string>().empty());
  EXPECT_TRUE(plan["indices"]["condition_number"].is_null());
  // Stored as made.
  EXPECT_EQ(s_.Get("/v1/plans/" + plan["id"].get<std::string>()).body["test"], test);
}

// 30 cycles before and after compensation: AP against the truth's systematic error, RP against the repeatability
// and noise the cell was given, and the report's before and after.
TEST_F(Iso9283Test, ThirtyCyclesFindTheTruthsErrorAndRepeatabilityBeforeAndAfterCompensation) {
  // The calibration: a drawn plan's poses measured, fitted.
  const Reply drawn = s_.Post("/v1/plans", {{"robot", "ur5e"}, {"num_configurations", 40}, {"seed", 5},
                                            {"options", {{"k_max", 10}}}});
  ASSERT_EQ(drawn.status, 200) << drawn.text;
  std::vector<Eigen::VectorXd> poses;
  for (const json& q : drawn.body["configurations"]) poses.push_back(api::JointsToCore(model_, q.get<std::vector<double>>()));
  const json before_plan = TestPlan();
  ASSERT_EQ(s_.Post("/v1/campaigns", {{"id", "before"}, {"robot", "ur5e"}, {"plan", before_plan["id"]},
                                      {"repeatability_mm", kRepeatabilityMm}})
                .status,
            200);
  ASSERT_EQ(s_.Post("/v1/campaigns/before/measurements", Batch(model_, cell_.MeasureAll(poses, 1), "cal", "calibration"))
                .status,
            200);
  // Before the fit the frames are registered on the test shots themselves, and the report says so.
  const Reply shots = s_.Post("/v1/campaigns/before/measurements", TestShots(model_, &cell_, before_plan, "iso"));
  ASSERT_EQ(shots.status, 200) << shots.text;
  const Reply unfitted = s_.Get("/v1/campaigns/before/iso9283");
  ASSERT_EQ(unfitted.status, 200) << unfitted.text;
  EXPECT_EQ(unfitted.body["frames"], "registered_on_test");
  EXPECT_TRUE(unfitted.body["calibrated"].is_null());
  const Reply fit = s_.Post("/v1/campaigns/before:fit", json::object());
  ASSERT_EQ(fit.status, 200) << fit.text;

  const Reply before = s_.Get("/v1/campaigns/before/iso9283");
  ASSERT_EQ(before.status, 200) << before.text;
  EXPECT_EQ(before.body["commands"], "plan");
  EXPECT_EQ(before.body["frames"], "calibration");
  EXPECT_EQ(before.body["cycles"], 30);
  EXPECT_EQ(before.body["num_shots"], 150);
  // The repeatability the cell was given, with the tracker's noise: per axis sigma_r (RP / 3.615) and sigma_t.
  const double sigma = std::hypot(kRepeatabilityMm / kRepeatabilityPerSigma, kTrackerSigmaMm);
  const double expected_rpl = kRepeatabilityPerSigma * sigma;

  const auto check = [&](const json& plan, const json& report, const char* when) {
    SCOPED_TRACE(when);
    const std::vector<Eigen::Vector3d> truth = TrueDeviations(model_, cell_, plan, report);
    double rpl_sum = 0.0;
    ASSERT_EQ(report["measured"]["poses"].size(), 5u);
    for (int k = 0; k < 5; ++k) {
      const json& p = report["measured"]["poses"][k];
      SCOPED_TRACE(p["pose"].get<std::string>());
      EXPECT_EQ(p["cycles"], 30);
      const Eigen::Vector3d ap(p["apx_mm"].get<double>(), p["apy_mm"].get<double>(), p["apz_mm"].get<double>());
      // AP within 0.01 mm of the truth's systematic error (the barycentre of 30 shots: sigma / sqrt(30) per axis).
      EXPECT_NEAR(p["ap_mm"].get<double>(), truth[k].norm(), 0.01) << truth[k].transpose();
      EXPECT_LT((ap - truth[k]).norm(), 0.015);
      // RPl per pose within its sampling spread (about 8 % of RPl at 30 cycles: 3 sigma is 25 %).
      EXPECT_NEAR(p["rpl_mm"].get<double>(), expected_rpl, 0.25 * expected_rpl);
      rpl_sum += p["rpl_mm"].get<double>();
      EXPECT_FALSE(p["rpa_deg"].is_null());
    }
    // Over the five poses (150 shots) within 10 %.
    EXPECT_NEAR(rpl_sum / 5.0, expected_rpl, 0.1 * expected_rpl);
    std::printf("%s: RPl mean over the poses %.4f mm, expected %.4f mm\n", when, rpl_sum / 5.0, expected_rpl);
    ASSERT_EQ(report["measured"]["distances"].size(), 2u);
    EXPECT_EQ(report["measured"]["distances"][0]["from"], "P1");
    EXPECT_EQ(report["measured"]["distances"][1]["to"], "P4");
    EXPECT_FALSE(report["measured"]["distances"][0]["rd_mm"].is_null());
  };
  check(before_plan, before.body, "nominal commands");

  // After: the same test with the commands compensated by the calibration, in a campaign of its own (no fit: its
  // frames registered on the test, as a cell re-checking its robot would).
  const json after_plan = TestPlan("before");
  EXPECT_EQ(after_plan["test"]["compensated_by"], "before");
  ASSERT_EQ(s_.Post("/v1/campaigns", {{"id", "after"}, {"robot", "ur5e"}, {"plan", after_plan["id"]}}).status, 200);
  ASSERT_EQ(s_.Post("/v1/campaigns/after/measurements", TestShots(model_, &cell_, after_plan, "iso")).status, 200);
  const Reply after = s_.Get("/v1/campaigns/after/iso9283");
  ASSERT_EQ(after.status, 200) << after.text;
  check(after_plan, after.body, "compensated commands");
  double before_mean = 0.0, after_mean = 0.0, predicted_mean = 0.0;
  for (int k = 0; k < 5; ++k) {
    before_mean += before.body["measured"]["poses"][k]["ap_mm"].get<double>() / 5.0;
    after_mean += after.body["measured"]["poses"][k]["ap_mm"].get<double>() / 5.0;
    predicted_mean += before.body["calibrated"]["poses"][k]["ap_mm"].get<double>() / 5.0;
  }
  EXPECT_LT(after_mean, before_mean / 3.0) << before_mean << " -> " << after_mean;
  std::printf("AP mean over the poses: nominal commands %.4f mm, compensated %.4f mm, predicted by the fit %.4f mm\n",
              before_mean, after_mean, predicted_mean);
  // The calibrated set of the first campaign predicts what the compensated commands reach.
  EXPECT_NEAR(predicted_mean, after_mean, 0.05);

  // CSV: a header and one row per pose and pair of each set.
  const Reply csv = s_.Get("/v1/campaigns/before/iso9283?format=csv");
  ASSERT_EQ(csv.status, 200);
  EXPECT_EQ(csv.text.rfind("set,pose,cycles,AP_mm", 0), 0u) << csv.text;
  EXPECT_EQ(std::count(csv.text.begin(), csv.text.end(), '\n'), 1 + 2 * 7);
  // The report holds the table, before and after.
  const Reply page = s_.Get("/v1/campaigns/before/report");
  ASSERT_EQ(page.status, 200);
  EXPECT_NE(page.text.find("id=\"iso9283\""), std::string::npos);
}

TEST_F(Iso9283Test, BadInputIsNamed) {
  // A cube out of reach names it; fewer than 2 cycles; "auto" without a cell.
  Reply r = s_.Post("/v1/plans", {{"robot", "ur5e"},
                                 {"test", {{"iso9283", {{"cube", {{"center_mm", {3000, 0, 0}}, {"size_mm", 200}}}}}}}});
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(ReasonOf(r, "test.iso9283.cube").find("P1 at (3000, 0, 0) mm is out of"), std::string::npos) << r.text;
  r = s_.Post("/v1/plans", {{"robot", "ur5e"},
                            {"test", {{"iso9283", {{"cube", {{"center_mm", {350, 250, 300}}, {"size_mm", 300}}},
                                                   {"cycles", 1}}}}}});
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(ReasonOf(r, "test.iso9283.cycles").find("[2, 1000]"), std::string::npos) << r.text;
  r = s_.Post("/v1/plans", {{"robot", "ur5e"}, {"test", {{"iso9283", {{"cube", "auto"}}}}}});
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(ReasonOf(r, "test.iso9283.cube").find("cell"), std::string::npos) << r.text;
  r = s_.Post("/v1/plans", {{"robot", "ur5e"}, {"candidates", {{0, 0, 0, 0, 0, 0}}},
                            {"test", {{"iso9283", {{"cube", "auto"}}}}}});
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(ReasonOf(r, "candidates"), "");
  r = s_.Post("/v1/plans", {{"robot", "ur5e"}, {"test", {{"iso9283", {{"cube", "big"}}}}}});
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(ReasonOf(r, "test.iso9283.cube"), "");

  // Test shots without their tags, tags on other roles, a campaign without test shots, a pose and cycle twice.
  ASSERT_EQ(s_.Post("/v1/campaigns", {{"id", "c"}, {"robot", "ur5e"}}).status, 200);
  const json q = json::array({10, -80, 70, -80, -90, 0});
  const json pose = json(api::TransformToPose(ForwardKinematics(model_, api::JointsToCore(model_, {10, -80, 70, -80, -90, 0}))));
  r = s_.Post("/v1/campaigns/c/measurements",
              {{"request_id", "a"}, {"role", "test"}, {"measurements", {{{"joints", q}, {"pose", pose}}}}});
  EXPECT_EQ(r.status, 400);
  EXPECT_EQ(ReasonOf(r, "measurements[0].test_pose"), "required");
  EXPECT_EQ(ReasonOf(r, "measurements[0].cycle"), "required");
  r = s_.Post("/v1/campaigns/c/measurements",
              {{"request_id", "b"}, {"role", "test"},
               {"measurements", {{{"joints", q}, {"pose", pose}, {"test_pose", "P6"}, {"cycle", 0}}}}});
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(ReasonOf(r, "measurements[0].test_pose").find("P1, P2"), std::string::npos) << r.text;
  EXPECT_NE(ReasonOf(r, "measurements[0].cycle"), "");
  r = s_.Post("/v1/campaigns/c/measurements",
              {{"request_id", "c"}, {"measurements", {{{"joints", q}, {"pose", pose}, {"test_pose", "P1"}}}}});
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(ReasonOf(r, "measurements[0].test_pose").find("role test"), std::string::npos) << r.text;
  r = s_.Get("/v1/campaigns/c/iso9283");
  EXPECT_EQ(r.status, 400);
  EXPECT_EQ(r.body["error"]["status"], "FAILED_PRECONDITION");
  EXPECT_NE(ReasonOf(r, "measurements"), "");
  // One pose cannot register the tracker; a visit measured again counts with its latest shot.
  const auto shot = [&](const std::vector<double>& joints, const char* name) {
    const json p = json(api::TransformToPose(ForwardKinematics(model_, api::JointsToCore(model_, joints))));
    return json{{"joints", joints}, {"pose", p}, {"test_pose", name}, {"cycle", 1}};
  };
  ASSERT_EQ(s_.Post("/v1/campaigns/c/measurements",
                    {{"request_id", "d"}, {"role", "test"}, {"measurements", {shot({10, -80, 70, -80, -90, 0}, "P1")}}})
                .status,
            200);
  r = s_.Get("/v1/campaigns/c/iso9283");
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(r.body["error"]["message"].get<std::string>().find("on a line"), std::string::npos) << r.text;
  ASSERT_EQ(s_.Post("/v1/campaigns/c/measurements",
                    {{"request_id", "e"},
                     {"role", "test"},
                     {"measurements",
                      {shot({20, -80, 70, -80, -90, 0}, "P2"), shot({10, -70, 70, -80, -90, 0}, "P3"),
                       shot({10, -80, 70, -80, -90, 0}, "P1")}}})
                .status,
            200);
  r = s_.Get("/v1/campaigns/c/iso9283");
  ASSERT_EQ(r.status, 200) << r.text;
  EXPECT_EQ(r.body["num_shots"], 3);
  bool noted = false;
  for (const json& note : r.body["notes"])
    noted = noted || note.get<std::string>().find("P1 cycle 1: measurement 4 (not 1)") != std::string::npos;
  EXPECT_TRUE(noted) << r.body["notes"];
  // A campaign of a test plan takes only its visits: its cycles, its commands.
  const json plan = TestPlan();
  ASSERT_EQ(s_.Post("/v1/campaigns", {{"id", "planned"}, {"robot", "ur5e"}, {"plan", plan["id"]}}).status, 200);
  json wrong = shot(plan["test"]["poses"][0]["joints"].get<std::vector<double>>(), "P3");
  json late = shot(plan["test"]["poses"][0]["joints"].get<std::vector<double>>(), "P1");
  late["cycle"] = 31;
  r = s_.Post("/v1/campaigns/planned/measurements",
              {{"request_id", "w"}, {"role", "test"}, {"measurements", {wrong, late}}});
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(ReasonOf(r, "measurements[0].joints").find("not the joint commands of P3"), std::string::npos) << r.text;
  EXPECT_NE(ReasonOf(r, "measurements[1].cycle").find("30 cycles"), std::string::npos) << r.text;
  // A test plan beyond the plan size limit (1000 configurations: 201 cycles of 5).
  r = s_.Post(
      "/v1/plans",
      {{"robot", "ur5e"},
       {"test", {{"iso9283", {{"cube", {{"center_mm", {350, 250, 300}}, {"size_mm", 300}}}, {"cycles", 201}}}}}});
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(ReasonOf(r, "test.iso9283.cycles"), "") << r.text;
  // Plan members a test plan has no use for are refused, not ignored.
  r = s_.Post("/v1/plans", {{"robot", "ur5e"},
                            {"num_configurations", 30},
                            {"optimiser", "exchange"},
                            {"test", {{"iso9283", {{"cube", {{"center_mm", {350, 250, 300}}, {"size_mm", 300}}}}}}}});
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(ReasonOf(r, "num_configurations"), "") << r.text;
  EXPECT_NE(ReasonOf(r, "optimiser"), "") << r.text;
  // compensated_by an unknown or uncalibrated campaign, named.
  r = s_.Post(
      "/v1/plans",
      {{"robot", "ur5e"},
       {"test",
        {{"iso9283", {{"cube", {{"center_mm", {350, 250, 300}}, {"size_mm", 300}}}, {"compensated_by", "nope"}}}}}});
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(ReasonOf(r, "test.iso9283.compensated_by"), "") << r.text;
  EXPECT_EQ(s_.Get("/v1/campaigns/c/iso9283?format=xml").status, 400);
  EXPECT_EQ(s_.Get("/v1/campaigns/nope/iso9283").status, 404);
}

}  // namespace
}  // namespace robocal::server::testing
