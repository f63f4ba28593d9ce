// The whole calibration flow over HTTP with measurements from the core's virtual cell: plan -> campaign ->
// upload -> fit -> forward -> compensate -> evaluate, on the real SQLite storage (in memory).
#include <gtest/gtest.h>

#include "robocal/api/calibration.h"
#include "robocal/api/campaigns.h"
#include "robocal/api/plans.h"
#include "robocal/core/presets.h"
#include "robocal/core/virtual_cell.h"
#include "test_server.h"

namespace robocal::server::testing {
namespace {

using nlohmann::json;

json Batch(const RobotModel& model, const std::vector<Measurement>& measurements, const std::string& request_id,
           const std::string& role) {
  json list = json::array();
  for (const Measurement& m : measurements) {
    list.push_back({{"joints", api::JointsToWire(model, m.joints)},
                    {"pose", nlohmann::json(api::TransformToPose(m.T_world_tool))}});
  }
  return {{"request_id", request_id}, {"role", role}, {"measurements", list}};
}

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
