// Parameter priors over HTTP (POST /v1/campaigns/{c}:fit with "priors"): the object and "auto", what the fit reports
// of them, and the refusals.
#include <gtest/gtest.h>

#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"
#include "robocal/core/virtual_cell.h"
#include "test_server.h"

namespace robocal::server::testing {
namespace {

using nlohmann::json;

std::vector<Eigen::VectorXd> Configurations(const RobotModel& model, int count, std::uint64_t seed) {
  Rng rng(seed);
  std::vector<Eigen::VectorXd> out;
  for (int i = 0; i < count; ++i) out.push_back(RandomConfiguration(model, &rng));
  return out;
}

// A pose campaign "c" of ur5e with `count` noisy shots of the virtual cell.
void MeasuredCampaign(TestServer& s, int count) {
  const RobotModel model = Preset("ur5e");
  VirtualCellOptions options;
  options.seed = 21;
  options.shots_per_pose = 1;
  options.noise.position_mm = 0.05;
  options.noise.orientation_rad = 2e-4;
  VirtualCell cell(model, options);
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "c"}, {"robot", "ur5e"}, {"noise", {{"position_mm", 0.05},
                                                                                {"orientation_deg", 0.0115}}}})
                .status,
            200);
  const Reply batch = s.Post("/v1/campaigns/c/measurements",
                             Batch(model, cell.MeasureAll(Configurations(model, count, 5)), "b1",
                                   "calibration"));
  ASSERT_EQ(batch.status, 200) << batch.text;
}

TEST(FitPriorsTest, PriorsAreAppliedAndReported) {
  TestServer s;
  MeasuredCampaign(s, 20);
  const Reply plain = s.Post("/v1/campaigns/c:fit", json::object());
  ASSERT_EQ(plain.status, 200) << plain.text;
  EXPECT_FALSE(plain.body.contains("priors"));
  // A tiny prior on one parameter holds it at zero, with about the prior's std, and names it as the prior's.
  const Reply held = s.Post("/v1/campaigns/c:fit", {{"priors", {{"parameters", {{"joint3.dx", 1e-4}}}}}});
  ASSERT_EQ(held.status, 200) << held.text;
  const json& priors = held.body["priors"];
  EXPECT_GT(priors["num_priors"].get<int>(), 10);
  EXPECT_LT(priors["effective_parameters"].get<double>(), plain.body["summary"]["num_parameters"].get<double>());
  bool named = false;
  for (const json& d : priors["prior_determined"]) {
    if (d["parameter"] == "joint3.dx") {
      named = true;
      EXPECT_EQ(d["unit"], "mm");
      EXPECT_DOUBLE_EQ(d["prior_std"].get<double>(), 1e-4);
      EXPECT_LT(d["data_share"].get<double>(), 0.5);
    }
  }
  EXPECT_TRUE(named) << priors;
  for (const json& p : held.body["parameters"]) {
    if (p["name"] == "joint3.dx") EXPECT_LT(std::abs(p["value"].get<double>()), 1e-3) << p;
  }
}

TEST(FitPriorsTest, AutoReportsEveryScaleAndChoosesTheLeastHeldOutError) {
  TestServer s;
  MeasuredCampaign(s, 25);
  const Reply fit = s.Post("/v1/campaigns/c:fit", {{"priors", "auto"}, {"cross_validation", {{"folds", 4}}}});
  ASSERT_EQ(fit.status, 200) << fit.text;
  const json& candidates = fit.body["priors"]["candidates"];
  ASSERT_EQ(candidates.size(), 6u);
  EXPECT_TRUE(candidates[0]["scale"].is_null()) << "the fit without priors first";
  EXPECT_EQ(fit.body["priors"]["folds"], 4);
  int chosen = -1;
  for (std::size_t k = 0; k < candidates.size(); ++k) {
    if (candidates[k]["chosen"].get<bool>()) chosen = static_cast<int>(k);
  }
  ASSERT_GE(chosen, 0);
  for (const json& c : candidates) {
    EXPECT_LE(candidates[chosen]["cv_mean_mm"].get<double>(), c["cv_mean_mm"].get<double>()) << c;
  }
  // The stored calibration keeps them.
  EXPECT_EQ(s.Get("/v1/campaigns/c/calibration").body["priors"], fit.body["priors"]);
}

TEST(FitPriorsTest, BadPriorsAreRefusedNamingTheField) {
  TestServer s;
  MeasuredCampaign(s, 12);
  EXPECT_TRUE(NamesField(s.Post("/v1/campaigns/c:fit", {{"priors", {{"lengths_mm", -1.0}}}}), "priors.lengths_mm"));
  EXPECT_TRUE(NamesField(s.Post("/v1/campaigns/c:fit", {{"priors", {{"angles_deg", 0.0}}}}), "priors.angles_deg"));
  EXPECT_TRUE(NamesField(s.Post("/v1/campaigns/c:fit", {{"priors", {{"parameters", {{"joint9.dz", 1.0}}}}}}),
                         "priors.parameters.joint9.dz"));
  EXPECT_TRUE(NamesField(s.Post("/v1/campaigns/c:fit", {{"priors", {{"parameters", {{"joint2.dz", -2.0}}}}}}),
                         "priors.parameters.joint2.dz"));
  EXPECT_TRUE(NamesField(s.Post("/v1/campaigns/c:fit", {{"priors", "yes"}}), "priors"));
  EXPECT_TRUE(NamesField(s.Post("/v1/campaigns/c:fit", {{"priors", {{"lenghts_mm", 1.0}}}}), "priors.lenghts_mm"));
  EXPECT_TRUE(NamesField(s.Post("/v1/campaigns/c:fit", {{"priors", "auto"}, {"model", "auto"}}), "priors"));
  EXPECT_TRUE(NamesField(s.Post("/v1/campaigns/c:fit", {{"priors", "auto"}, {"scope", "frames"}}), "priors"));
  EXPECT_EQ(s.Get("/v1/campaigns/c/calibration").status, 404);
}

}  // namespace
}  // namespace robocal::server::testing
