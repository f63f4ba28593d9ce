// The whole calibration flow over HTTP with measurements from the core's virtual cell: plan -> campaign ->
// upload -> fit -> forward -> compensate -> evaluate, on the real SQLite storage (in memory).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <tuple>

#include <gtest/gtest.h>

#include "robocal/api/calibration.h"
#include "robocal/api/campaigns.h"
#include "robocal/api/plans.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"
#include "robocal/core/units.h"
#include "robocal/core/virtual_cell.h"
#include "test_server.h"

namespace robocal::server::testing {
namespace {

using nlohmann::json;

std::vector<Eigen::VectorXd> Configurations(const RobotModel& model, const json& wire) {
  std::vector<Eigen::VectorXd> out;
  for (const auto& q : wire) out.push_back(api::JointsToCore(model, q.get<std::vector<double>>()));
  return out;
}

TEST(FlowTest, PlanCampaignUploadFitCompensateEvaluate) {
  TestServer s({}, {}, {}, OpenSqliteStorage(":memory:"));
  const RobotModel model = Preset("grinder5");
  const Reply plan = s.Post("/v1/plans", {{"robot", "grinder5"},
                                          {"num_configurations", 12},
                                          {"measurement_type", "pose"},
                                          {"seed", 3},
                                          {"num_validation", 10},
                                          {"options", {{"k_max", 20}}}});
  ASSERT_EQ(plan.status, 200) << plan.text;
  const Reply campaign = s.Post("/v1/campaigns", {{"id", "flow"}, {"robot", "grinder5"}, {"plan", plan.body["id"]}});
  ASSERT_EQ(campaign.status, 200) << campaign.text;

  VirtualCellOptions cell_options;
  cell_options.seed = 11;
  cell_options.shots_per_pose = 2;
  VirtualCell cell(model, cell_options);
  const auto calibration = cell.MeasureAll(Configurations(model, plan.body["configurations"]));
  ASSERT_EQ(s.Post("/v1/campaigns/flow/measurements", Batch(model, calibration, "cal-1", "calibration")).status, 200);
  Rng rng(5);
  const auto validation = cell.MeasureAll(RandomConfigurations(model, 15, &rng), 1);
  ASSERT_EQ(s.Post("/v1/campaigns/flow/measurements", Batch(model, validation, "val-1", "validation")).status, 200);
  const Reply counts = s.Get("/v1/campaigns/flow");
  EXPECT_EQ(counts.body["counts"]["calibration"], 24);
  EXPECT_EQ(counts.body["counts"]["validation"], 15);

  const Reply fit = s.Post("/v1/campaigns/flow:fit", json::object());
  ASSERT_EQ(fit.status, 200) << fit.text;
  EXPECT_EQ(fit.body["parameters"].size(), 20u);
  EXPECT_LT(fit.body["residuals_after"]["rms_position_mm"].get<double>(),
            fit.body["residuals_before"]["rms_position_mm"].get<double>());
  EXPECT_LT(fit.body["residuals_after"]["rms_position_mm"].get<double>(), 0.1);
  EXPECT_EQ(s.Get("/v1/campaigns/flow/calibration").body["parameters"], fit.body["parameters"]);
  EXPECT_TRUE(s.Get("/v1/campaigns/flow").body["calibrated"].get<bool>());

  // The calibrated model predicts the (true) robot far better than the nominal one.
  const Eigen::VectorXd q = validation[0].joints;
  const Reply fk = s.Post("/v1/campaigns/flow:forward", {{"joints", {api::JointsToWire(model, q)}}});
  ASSERT_EQ(fk.status, 200) << fk.text;
  const Eigen::Vector3d truth = cell.TruePose(q).translation();
  Eigen::Vector3d predicted;
  for (int i = 0; i < 3; ++i) predicted[i] = fk.body["poses"][0]["position_mm"][i];
  EXPECT_LT((predicted - truth).norm(), 0.1);

  const json targets = {{"targets", {{{"joints", api::JointsToWire(model, q)}}}}};
  const Reply compensated = s.Post("/v1/campaigns/flow:compensate", targets);
  const Reply evaluated = s.Post("/v1/campaigns/flow:evaluate", {{"h_mm", 30}});
  ASSERT_EQ(compensated.status, 200) << compensated.text;
  EXPECT_TRUE(compensated.body["results"][0]["converged"].get<bool>());
  EXPECT_EQ(compensated.body["results"][0]["joints"].size(), 5u);
  ASSERT_EQ(evaluated.status, 200) << evaluated.text;
  EXPECT_EQ(evaluated.body["num_validation"], 15);
  EXPECT_LT(evaluated.body["calibrated"]["e_xyz_mm"]["mean"].get<double>(),
            evaluated.body["nominal"]["e_xyz_mm"]["mean"].get<double>());
}

// GET .../calibration?format=dh|mdh: a robot whose neighbouring axes are never parallel gets its calibrated
// table, which registers as a robot with the calibrated kinematics; the grinder, whose Z and C axes are one line,
// gets a 400 naming format, the row and the parameters.
TEST(FlowTest, CalibratedDhTablesRegisterWithTheCalibratedKinematics) {
  TestServer s({}, {}, {}, OpenSqliteStorage(":memory:"));
  json joints = json::array();
  const double a[6] = {50, 300, 40, 10, 0, 5}, d[6] = {400, 30, -20, 350, 15, 90};
  const double alpha[6] = {90, -90, 90, -90, 90, 0};
  for (int i = 0; i < 6; ++i) {
    joints.push_back({{"name", "j" + std::to_string(i + 1)}, {"type", "revolute"}, {"a_mm", a[i]},
                      {"alpha_deg", alpha[i]}, {"d_mm", d[i]}, {"theta_deg", 5.0 * i}, {"min_deg", -170},
                      {"max_deg", 170}});
  }
  const json skew = {{"id", "skew"}, {"convention", "dh"}, {"joints", joints},
                     {"tool", {{"position_mm", {10, 20, 120}}, {"rpy_deg", {0, 15, 0}}}}};
  ASSERT_EQ(s.Post("/v1/robots", skew).status, 200);
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "skew-cal"}, {"robot", "skew"}}).status, 200);
  const RobotModel model = api::BuildModel(api::ParseRegisterRobotRequest(skew, api::Limits{}));
  VirtualCellOptions cell_options;
  cell_options.seed = 4;
  VirtualCell cell(model, cell_options);
  Rng rng(9);
  const auto measured = cell.MeasureAll(RandomConfigurations(model, 30, &rng), 1);
  ASSERT_EQ(s.Post("/v1/campaigns/skew-cal/measurements", Batch(model, measured, "c", "calibration")).status, 200);
  ASSERT_EQ(s.Post("/v1/campaigns/skew-cal:fit", json::object()).status, 200);

  json q = json::array();
  for (int k = 0; k < 5; ++k) q.push_back(api::JointsToWire(model, RandomConfiguration(model, &rng)));
  const Reply calibrated = s.Post("/v1/campaigns/skew-cal:forward", {{"joints", q}});
  ASSERT_EQ(calibrated.status, 200) << calibrated.text;
  for (const char* format : {"dh", "mdh"}) {
    SCOPED_TRACE(format);
    const Reply table = s.Get(std::string("/v1/campaigns/skew-cal/calibration?format=") + format);
    ASSERT_EQ(table.status, 200) << table.text;
    EXPECT_EQ(table.body["id"], std::string("skew-cal-") + format);
    EXPECT_EQ(table.body["convention"], format);
    ASSERT_EQ(s.Post("/v1/robots", table.body).status, 200);
    const Reply nominal = s.Post("/v1/robots/skew-cal-" + std::string(format) + ":forward", {{"joints", q}});
    ASSERT_EQ(nominal.status, 200) << nominal.text;
    for (std::size_t k = 0; k < q.size(); ++k) {
      for (int i = 0; i < 3; ++i) {
        EXPECT_NEAR(nominal.body["poses"][k]["position_mm"][i].get<double>(),
                    calibrated.body["poses"][k]["position_mm"][i].get<double>(), 1e-9);
      }
    }
  }

  // The grinder's Z and C axes are one line; a calibration that tilts or offsets C across it has no table.
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "grind"}, {"robot", "grinder5"}}).status, 200);
  const RobotModel grinder = Preset("grinder5");
  VirtualCell grinder_cell(grinder, cell_options);
  const auto shots = grinder_cell.MeasureAll(RandomConfigurations(grinder, 30, &rng), 1);
  ASSERT_EQ(s.Post("/v1/campaigns/grind/measurements", Batch(grinder, shots, "c", "calibration")).status, 200);
  const Reply fit = s.Post("/v1/campaigns/grind:fit", json::object());
  ASSERT_EQ(fit.status, 200) << fit.text;
  const Reply refused = s.Get("/v1/campaigns/grind/calibration?format=dh");
  ASSERT_EQ(refused.status, 400) << refused.text;
  EXPECT_EQ(refused.body["error"]["details"][0]["field"], "format");
  const std::string message = refused.body["error"]["message"];
  EXPECT_NE(message.find("joint 'Z' and joint 'C' are"), std::string::npos) << message;
  // It names identified parameters of C.
  EXPECT_NE(message.find("identified C."), std::string::npos) << message;
}

// A noise-free cell, one shot per pose, whose robot has joint harmonics of order 1 (1-sigma `harmonic_rad`) and a
// compliance deflecting it by `compliance_mm`.
VirtualCellOptions NoiseFreeCell(std::uint64_t seed, double compliance_mm, double harmonic_rad) {
  VirtualCellOptions o;
  o.seed = seed;
  o.shots_per_pose = 1;
  o.noise.position_mm = 0.0;
  o.noise.orientation_rad = 0.0;
  o.compliance_deflection_mm = compliance_mm;
  o.joint_harmonic_sigma_rad = harmonic_rad;
  o.joint_harmonic_min_order = 1;
  o.joint_harmonic_max_order = 1;
  return o;
}

// A calibration with compliance and harmonics registered as a robot (from_calibration): the robot holds the joint
// terms, moves under a payload as the calibration does, and a geometric fit of it in a new campaign on the same
// (true) robot has nothing left to explain that the first fit explained.
TEST(FlowTest, ACompliantCalibrationRegistersAsARobotHoldingItsJointTerms) {
  TestServer s({}, {}, {}, OpenSqliteStorage(":memory:"));
  const RobotModel model = Preset("ur5e");
  VirtualCell cell(model, NoiseFreeCell(17, 0.3, 5e-5));
  Rng rng(23);
  // The joint ranges of campaign "soft"'s calibration measurements (deg).
  std::vector<api::JointRangeWire> ranges(6, {HUGE_VAL, -HUGE_VAL});
  const auto upload = [&](const std::string& campaign, const std::string& request, int count, double mass_kg) {
    const Payload payload{mass_kg, Eigen::Vector3d(0, 20, 60)};
    json batch = Batch(model, cell.MeasureAll(RandomConfigurations(model, count, &rng), 0, nullptr, payload), request,
                       "calibration");
    for (json& m : batch["measurements"]) {
      m["payload"] = {{"mass_kg", mass_kg}, {"com_mm", {0, 20, 60}}};
      for (std::size_t i = 0; campaign == "soft" && i < ranges.size(); ++i) {
        ranges[i] = {std::min(ranges[i].min, m["joints"][i].get<double>()),
                     std::max(ranges[i].max, m["joints"][i].get<double>())};
      }
    }
    return s.Post("/v1/campaigns/" + campaign + "/measurements", batch).status;
  };
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "soft"}, {"robot", "ur5e"}}).status, 200);
  ASSERT_EQ(upload("soft", "light", 60, 0.0), 200);
  ASSERT_EQ(upload("soft", "heavy", 60, 5.0), 200);
  // A shot beyond the others' range of joint 1, 5 mm off: the fit excludes it, and the range leaves it out.
  Eigen::VectorXd odd = RandomConfiguration(model, &rng);
  odd[0] = ranges[0].max * kRadPerDeg + 0.5 * (model.upper_limits()[0] - ranges[0].max * kRadPerDeg);
  Measurement moved = cell.MeasureAll({odd}, 0, nullptr, Payload())[0];
  moved.T_world_tool.translation().x() += 5.0;
  ASSERT_EQ(s.Post("/v1/campaigns/soft/measurements", Batch(model, {moved}, "odd", "calibration")).status, 200);
  const Reply fit = s.Post("/v1/campaigns/soft:fit", {{"model", {{"compliance", true}, {"joint_harmonics", 1}}}});
  ASSERT_EQ(fit.status, 200) << fit.text;
  ASSERT_EQ(fit.body["outliers"].size(), 1u) << fit.text;
  EXPECT_EQ(fit.body["outliers"][0]["sequence"], 121) << fit.text;

  const Reply robot = s.Post("/v1/robots", {{"id", "ur5e-soft"}, {"from_calibration", "soft"}});
  ASSERT_EQ(robot.status, 200) << robot.text;
  EXPECT_NE(robot.body["joints"][1]["compliance_deg_per_nm"].get<double>(), 0.0) << robot.text;
  EXPECT_NE(robot.body["joints"][0]["harmonics_deg"][0].get<double>(), 0.0) << robot.text;
  EXPECT_EQ(robot.body["error_parameters"].size(), 48u);  // geometric only: the terms are held, not fitted
  // Where the calibration was measured: the joint ranges of its measurements.
  EXPECT_EQ(robot.body["calibrated_from"]["joint_ranges"], json(ranges)) << robot.text;

  // The robot and the calibration under a payload it never saw. The calibration's frame is the tracker's (its
  // registered base), the robot's its nominal base: compared where a rigid motion does not count, in the distances
  // between the poses and in each tool's deflection under the payload, in its own frame.
  json q = json::array();
  for (int k = 0; k < 5; ++k) q.push_back(api::JointsToWire(model, RandomConfiguration(model, &rng)));
  const json payload = {{"mass_kg", 2.5}, {"com_mm", {40, -20, 90}}};
  const json none = {{"mass_kg", 0}};
  const auto poses = [&](const std::string& path, const json& p) {
    const Reply reply = s.Post(path, {{"joints", q}, {"payload", p}});
    EXPECT_EQ(reply.status, 200) << reply.text;
    std::vector<Transform> out;
    for (const json& pose : reply.body["poses"]) out.push_back(api::PoseToTransform(pose.get<api::PoseWire>()));
    return out;
  };
  const std::vector<Transform> calibrated = poses("/v1/campaigns/soft:forward", payload);
  const std::vector<Transform> calibrated_unloaded = poses("/v1/campaigns/soft:forward", none);
  const std::vector<Transform> held = poses("/v1/robots/ur5e-soft:forward", payload);
  const std::vector<Transform> held_unloaded = poses("/v1/robots/ur5e-soft:forward", none);
  ASSERT_EQ(held.size(), q.size());
  for (std::size_t k = 0; k < q.size(); ++k) {
    EXPECT_NEAR((held[k].translation() - held[0].translation()).norm(),
                (calibrated[k].translation() - calibrated[0].translation()).norm(), 1e-2);
    const Eigen::Vector3d deflection = held_unloaded[k].inverse() * held[k].translation();
    const Eigen::Vector3d expected = calibrated_unloaded[k].inverse() * calibrated[k].translation();
    EXPECT_GT(deflection.norm(), 0.01);
    // The torques come from the registered robot's own (calibrated) chain, its links tilted by the calibration's
    // errors: a few hundredths of the deflection at most.
    EXPECT_LT((deflection - expected).norm(), 0.03 * expected.norm() + 1e-6) << deflection.transpose();
  }

  // A new campaign of the registered robot: the geometric fit explains the (noise-free) robot but for the torques'
  // chain (a few micrometres); the same fit of the rigid ur5e is left with the deflections.
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "reuse"}, {"robot", "ur5e-soft"}}).status, 200);
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "rigid"}, {"robot", "ur5e"}}).status, 200);
  const Rng before_upload = rng;
  ASSERT_EQ(upload("reuse", "load", 40, 3.0), 200);
  rng = before_upload;
  ASSERT_EQ(upload("rigid", "load", 40, 3.0), 200);
  const Reply reuse = s.Post("/v1/campaigns/reuse:fit", json::object());
  const Reply rigid = s.Post("/v1/campaigns/rigid:fit", json::object());
  ASSERT_EQ(reuse.status, 200) << reuse.text;
  ASSERT_EQ(rigid.status, 200) << rigid.text;
  const double reused = reuse.body["residuals_after"]["max_position_mm"].get<double>();
  const double rigid_left = rigid.body["residuals_after"]["max_position_mm"].get<double>();
  EXPECT_LT(reused, 0.01) << reuse.text;
  EXPECT_LT(reused, 0.1 * rigid_left) << rigid.text;
}

// A robot holding joint harmonics identified over part of a joint's turn: a fit of its poses beyond that range
// says so (there the harmonics extrapolate); a fit within it does not.
TEST(FlowTest, AFitBeyondTheRangesOfARobotsHeldHarmonicsSaysSo) {
  TestServer s({}, {}, {}, OpenSqliteStorage(":memory:"));
  const RobotModel model = Preset("ur5e");
  VirtualCell cell(model, NoiseFreeCell(29, 0.0, 1e-4));
  Rng rng(31);
  // 40 configurations with the first joint within +-30 degrees; the same, moved to 60 .. 120 degrees.
  std::vector<Eigen::VectorXd> narrow, moved;
  for (int k = 0; k < 40; ++k) {
    narrow.push_back(RandomConfiguration(model, &rng));
    narrow.back()[0] = rng.Uniform(-30.0, 30.0) * kRadPerDeg;
    moved.push_back(narrow.back());
    moved.back()[0] += 90.0 * kRadPerDeg;
  }
  const auto upload = [&](const std::string& campaign, const std::vector<Eigen::VectorXd>& q) {
    return s.Post("/v1/campaigns/" + campaign + "/measurements", Batch(model, cell.MeasureAll(q), "b", "calibration"))
        .status;
  };
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "narrow"}, {"robot", "ur5e"}}).status, 200);
  ASSERT_EQ(upload("narrow", narrow), 200);
  const Reply first = s.Post("/v1/campaigns/narrow:fit", {{"model", {{"joint_harmonics", 1}}}});
  ASSERT_EQ(first.status, 200) << first.text;
  const Reply robot = s.Post("/v1/robots", {{"id", "ur5e-narrow"}, {"from_calibration", "narrow"}});
  ASSERT_EQ(robot.status, 200) << robot.text;
  ASSERT_NE(robot.body["joints"][0]["harmonics_deg"], json::array({0.0, 0.0, 0.0, 0.0})) << robot.text;
  EXPECT_LE(robot.body["calibrated_from"]["joint_ranges"][0]["max"].get<double>(), 30.0);
  for (const auto& [campaign, q] : {std::tuple{"inside", narrow}, std::tuple{"outside", moved}}) {
    ASSERT_EQ(s.Post("/v1/campaigns", {{"id", campaign}, {"robot", "ur5e-narrow"}}).status, 200);
    ASSERT_EQ(upload(campaign, q), 200);
    const Reply fit = s.Post(std::string("/v1/campaigns/") + campaign + ":fit", json::object());
    ASSERT_EQ(fit.status, 200) << fit.text;
    const std::string message = fit.body["summary"]["message"];
    if (std::string(campaign) == "inside") {
      EXPECT_EQ(message.find("leave the joint ranges"), std::string::npos) << message;
    } else {
      EXPECT_NE(message.find("40 of 40 shots leave the joint ranges the robot's joint harmonics were identified over "
                             "(joint1 "),
                std::string::npos)
          << message;
      EXPECT_NE(message.find(" deg: 40 beyond)"), std::string::npos) << message;
    }
  }
}

// A tracker's own point export (measurements:import), matched to the plan by target name: stored as one batch
// that fits; a file with one bad line stores nothing and names the line; a repeat is replayed.
TEST(FlowTest, TrackerPointExportsAreImportedAgainstThePlan) {
  TestServer s({}, {}, {}, OpenSqliteStorage(":memory:"));
  const RobotModel model = Preset("grinder5");
  const Reply plan = s.Post("/v1/plans", {{"robot", "grinder5"},
                                          {"num_configurations", 12},
                                          {"measurement_type", "position"},
                                          {"seed", 3},
                                          {"options", {{"k_max", 20}}}});
  ASSERT_EQ(plan.status, 200) << plan.text;
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "sa"}, {"robot", "grinder5"}, {"plan", plan.body["id"]}}).status, 200);
  VirtualCellOptions cell_options;
  cell_options.seed = 11;
  VirtualCell cell(model, cell_options);
  const auto configurations = Configurations(model, plan.body["configurations"]);
  // Two shots of each configuration, in metres, targets P001.. as a tracker program names them.
  std::string text = "// robocal test export\n// Units: Meters\n";
  int lines = 2;
  for (int shot = 0; shot < 2; ++shot) {
    for (std::size_t k = 0; k < configurations.size(); ++k) {
      const Eigen::Vector3d p = cell.Measure(configurations[k], 1).front().T_world_tool.translation() / 1000.0;
      char row[160];
      std::snprintf(row, sizeof(row), "A,Robot,P%03zu,%.9f,%.9f,%.9f\n", k + 1, p.x(), p.y(), p.z());
      text += row;
      ++lines;
    }
  }
  const json import = {{"request_id", "sa-1"}, {"format", "sa"}, {"text", text}};
  const Reply stored = s.Post("/v1/campaigns/sa/measurements:import", import);
  ASSERT_EQ(stored.status, 200) << stored.text;
  EXPECT_EQ(stored.body["count"], 24);
  EXPECT_EQ(s.Post("/v1/campaigns/sa/measurements:import", import).body["replayed"], true);
  const Reply listed = s.Get("/v1/campaigns/sa/measurements?limit=1");
  ASSERT_EQ(listed.status, 200);
  EXPECT_EQ(listed.body["measurements"][0]["joints"], plan.body["configurations"][0]);

  // One bad line among good ones: nothing stored, the line named.
  const json bad = {{"request_id", "sa-2"}, {"format", "sa"}, {"text", text + "A,Robot,P004,1,2\n"}};
  const Reply refused = s.Post("/v1/campaigns/sa/measurements:import", bad);
  ASSERT_EQ(refused.status, 400) << refused.text;
  EXPECT_EQ(refused.body["error"]["details"][0]["field"], "text");
  EXPECT_EQ(refused.body["error"]["details"][0]["reason"],
            "line " + std::to_string(lines + 1) + ": expected 6 fields (collection group target x y z), got 5");
  EXPECT_EQ(s.Get("/v1/campaigns/sa").body["counts"]["calibration"], 24);

  const Reply fit = s.Post("/v1/campaigns/sa:fit", json::object());
  ASSERT_EQ(fit.status, 200) << fit.text;
  EXPECT_LT(fit.body["residuals_after"]["rms_position_mm"].get<double>(), 0.1);

  // A pose campaign takes no point export; a campaign without a plan needs one named.
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "pose"}, {"robot", "grinder5"}}).status, 200);
  const Reply pose = s.Post("/v1/campaigns/pose/measurements:import", import);
  EXPECT_EQ(pose.status, 400);
  EXPECT_EQ(pose.body["error"]["details"][0]["field"], "format");
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "csv"}, {"robot", "grinder5"}, {"measurement_type", "position"}}).status,
            200);
  std::string csv = "X;Y;Z\n";
  for (const auto& q : configurations) {
    const Eigen::Vector3d p = cell.Measure(q, 1).front().T_world_tool.translation();
    csv += std::to_string(p.x()) + ";" + std::to_string(p.y()) + ";" + std::to_string(p.z()) + "\n";
  }
  json by_order = {{"request_id", "csv-1"}, {"format", "csv"}, {"text", csv}, {"unit", "mm"}, {"match", "order"}};
  const Reply no_plan = s.Post("/v1/campaigns/csv/measurements:import", by_order);
  EXPECT_EQ(no_plan.status, 400);
  EXPECT_EQ(no_plan.body["error"]["details"][0]["field"], "plan");
  by_order["plan"] = plan.body["id"];
  const Reply ordered = s.Post("/v1/campaigns/csv/measurements:import", by_order);
  ASSERT_EQ(ordered.status, 200) << ordered.text;
  EXPECT_EQ(ordered.body["count"], 12);
}

TEST(FlowTest, FitWithTooFewMeasurementsStoresNothing) {
  TestServer s({}, {}, {}, OpenSqliteStorage(":memory:"));
  const RobotModel model = Preset("ur5e");
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "few"}, {"robot", "ur5e"}}).status, 200);
  VirtualCell cell(model);
  Rng rng(1);
  const auto few = cell.MeasureAll(RandomConfigurations(model, 2, &rng), 1);
  ASSERT_EQ(s.Post("/v1/campaigns/few/measurements", Batch(model, few, "r", "calibration")).status, 200);
  const Reply fit = s.Post("/v1/campaigns/few:fit", json::object());
  EXPECT_EQ(fit.status, 400) << fit.text;
  EXPECT_EQ(fit.body["error"]["status"], "FAILED_PRECONDITION");
  EXPECT_FALSE(fit.body["error"]["message"].get<std::string>().empty());
  EXPECT_TRUE(NamesField(fit, "measurements")) << fit.text;
  EXPECT_EQ(s.Get("/v1/campaigns/few/calibration").status, 404);
  EXPECT_FALSE(s.storage().Get("calibrations", "few").has_value());
}

}  // namespace
}  // namespace robocal::server::testing
