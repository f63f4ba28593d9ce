// Durability: a separate robocal-server process is killed with SIGKILL right after acknowledging uploads; on
// restart every acknowledged measurement is there, the database passes its integrity check, and an operation
// that was running is reported FAILED.
// Eigen first: glibc's resolver header (pulled in by httplib.h) defines a macro `_res` that breaks Eigen.
#include "robocal/api/calibration.h"
#include "robocal/api/campaigns.h"
#include "robocal/api/plans.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "server/storage/storage.h"

#include <unistd.h>

#include <filesystem>

#include <gtest/gtest.h>
#include <httplib.h>
#include <nlohmann/json.hpp>

#include "measurement_batch.h"
#include "server_process.h"

namespace robocal::server::testing {
namespace {

using nlohmann::json;

TEST(DurabilityTest, AcknowledgedUploadsSurviveSigkill) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / ("robocal_dur_" +
                                                                                    std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  const std::string db = (dir / "robocal.db").string();
  const RobotModel model = Preset("ur5e");
  std::int64_t acknowledged = 0;
  std::string operation;
  {
    ServerProcess server({"--db", db, "--log-level", "error"});
    httplib::Client client = GuardedClient(server.port());
    auto created = client.Post("/v1/campaigns", R"({"id":"dur","robot":"ur5e"})", "application/json");
    ASSERT_TRUE(created && created->status == 200);
    auto op = client.Post("/v1/plans",
                          R"({"robot":"ur5e","num_configurations":20,"async":true,)"
                          R"("options":{"k_max":1000000,"max_evaluations":400000}})",
                          "application/json");
    ASSERT_TRUE(op && op->status == 200);
    operation = json::parse(op->body)["id"];
    for (int b = 0; b < 20; ++b) {
      auto r = client.Post("/v1/campaigns/dur/measurements",
                           MeasurementBatch(model, "batch-" + std::to_string(b), 5, static_cast<std::uint64_t>(b)).dump(),
                           "application/json");
      ASSERT_TRUE(r && r->status == 200);
      acknowledged = json::parse(r->body)["campaign_total"];
    }
    server.Kill();  // right after the last acknowledgement
  }
  {
    auto storage = OpenSqliteStorage(db);
    EXPECT_EQ(storage->IntegrityCheck(), "ok");
    EXPECT_EQ(storage->CountMeasurements("dur"), acknowledged);
  }
  ServerProcess restarted({"--db", db, "--log-level", "error"});
  httplib::Client client = GuardedClient(restarted.port());
  auto campaign = client.Get("/v1/campaigns/dur");
  ASSERT_TRUE(campaign && campaign->status == 200);
  EXPECT_EQ(json::parse(campaign->body)["counts"]["calibration"], acknowledged);
  auto op = client.Get(("/v1/operations/" + operation).c_str());
  ASSERT_TRUE(op && op->status == 200);
  EXPECT_EQ(json::parse(op->body)["state"], "FAILED");
  restarted.Kill();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace robocal::server::testing
