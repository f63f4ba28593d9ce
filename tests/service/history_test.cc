// Drift checks and a robot's calibration history over HTTP, on SQLite and PostgreSQL: a robot registered from a
// calibration is checked (holds; a re-mastered joint is found and named), calibrated again, rolled back, and the
// history survives a restart; bad requests are named.
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "pg_test_database.h"
#include "robocal/api/robots.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"
#include "robocal/core/units.h"
#include "robocal/core/virtual_cell.h"
#include "temp_dir.h"
#include "test_server.h"

namespace robocal::server::testing {
namespace {

using nlohmann::json;

VirtualCellOptions CellOptions() {
  VirtualCellOptions o;
  o.seed = 5;
  o.noise.position_mm = 0.01;
  o.noise.orientation_rad = 2e-5;
  // Unmodelled joint error: the model error a geometric calibration leaves, which the check must tolerate.
  o.joint_harmonic_sigma_rad = 1.5e-4;
  return o;
}

// `count` shots of the cell at random poses (seeded), joints shifted by `offset_deg` on joint `joint` (0-based)
// as a re-mastered robot reports them.
json Shots(VirtualCell* cell, int count, std::uint64_t seed, int joint = -1, double offset_deg = 0.0) {
  Rng rng(seed);
  json list = json::array();
  for (const Measurement& m : cell->MeasureAll(RandomConfigurations(cell->nominal(), count, &rng), 1)) {
    std::vector<double> q = api::JointsToWire(cell->nominal(), m.joints);
    if (joint >= 0) q[joint] += offset_deg;
    list.push_back({{"joints", q}, {"pose", json(api::TransformToPose(m.T_world_tool))}});
  }
  return list;
}

void Calibrate(TestServer& s, VirtualCell* cell, const std::string& id, std::uint64_t seed) {
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", id}, {"robot", "ur5e"}}).status, 200);
  const Reply up = s.Post("/v1/campaigns/" + id + "/measurements",
                          {{"request_id", id}, {"measurements", Shots(cell, 60, seed)}});
  ASSERT_EQ(up.status, 200) << up.text;
  const Reply fit = s.Post("/v1/campaigns/" + id + ":fit", json::object());
  ASSERT_EQ(fit.status, 200) << fit.text;
}

class HistoryTest : public ::testing::TestWithParam<const char*> {
 protected:
  std::unique_ptr<Storage> Open() {
    if (std::string(GetParam()) == "postgresql") return OpenStorage(pg_.Url());
    return OpenStorage(dir_.File("robocal.db"));
  }
  TempDir dir_;
  PgTestDatabase pg_;
};

TEST_P(HistoryTest, ChecksCalibrationsAndRollbacksAreEntriesThatSurviveARestart) {
  VirtualCell cell(Preset("ur5e"), CellOptions());
  json first_joints;
  {
    TestServer s({}, {"s3cret"}, {}, Open());
    s.set_token("s3cret");
    Calibrate(s, &cell, "cal", 1);
    const Reply robot = s.Post("/v1/robots", {{"id", "ur5e-cal"}, {"from_calibration", "cal"}});
    ASSERT_EQ(robot.status, 200) << robot.text;
    first_joints = robot.body["joints"];

    // Unchanged: holds, with its statistics; the entry records it.
    Reply check = s.Post("/v1/robots/ur5e-cal:check", {{"measurements", Shots(&cell, 12, 21)}});
    ASSERT_EQ(check.status, 200) << check.text;
    EXPECT_EQ(check.body["verdict"], "holds") << check.text;
    EXPECT_LE(check.body["statistic"].get<double>(), check.body["threshold"].get<double>());
    EXPECT_EQ(check.body["campaign"], "cal");
    EXPECT_EQ(check.body["num_measurements"], 12);
    EXPECT_EQ(check.body["history_entry"], 2);
    // Joint 3 re-mastered by 0.05 deg: drifted, and its offset named with the change.
    check = s.Post("/v1/robots/ur5e-cal:check", {{"measurements", Shots(&cell, 12, 22, 2, 0.05)}});
    ASSERT_EQ(check.status, 200) << check.text;
    EXPECT_EQ(check.body["verdict"], "drifted");
    ASSERT_FALSE(check.body["suspects"].empty());
    const json& suspect = check.body["suspects"][0];
    EXPECT_EQ(suspect["parameter"], "joint3.rz");
    EXPECT_TRUE(suspect["joint_offset"].get<bool>());
    EXPECT_EQ(suspect["unit"], "deg");
    EXPECT_NEAR(suspect["change"].get<double>(), -0.05, 4.0 * suspect["std"].get<double>()) << suspect;

    // A second calibration put on the robot, then back to the first.
    Calibrate(s, &cell, "cal2", 2);
    Reply history = s.Post("/v1/robots/ur5e-cal:calibrate", {{"from_calibration", "cal2"}, {"note", "after service"}});
    ASSERT_EQ(history.status, 200) << history.text;
    EXPECT_EQ(history.body["current_entry"], 4);
    EXPECT_EQ(history.body["current_campaign"], "cal2");
    EXPECT_NE(s.Get("/v1/robots/ur5e-cal").body["joints"], first_joints);
    history = s.Post("/v1/robots/ur5e-cal:rollback", {{"entry", 1}, {"note", "cal2 was worse"}});
    ASSERT_EQ(history.status, 200) << history.text;
    EXPECT_EQ(history.body["current_entry"], 5);
    EXPECT_EQ(history.body["current_campaign"], "cal");
    EXPECT_EQ(s.Get("/v1/robots/ur5e-cal").body["joints"], first_joints);
  }
  // After a restart on the same database: every entry, in order, who and what.
  TestServer s({}, {"s3cret"}, {}, Open());
  s.set_token("s3cret");
  const Reply history = s.Get("/v1/robots/ur5e-cal/calibrations");
  ASSERT_EQ(history.status, 200) << history.text;
  const json& e = history.body["entries"];
  ASSERT_EQ(e.size(), 5u) << history.text;
  const std::vector<std::string> kinds = {"registered", "check", "check", "calibrated", "rollback"};
  for (std::size_t k = 0; k < 5; ++k) {
    EXPECT_EQ(e[k]["entry"], k + 1);
    EXPECT_EQ(e[k]["kind"], kinds[k]);
    EXPECT_EQ(e[k]["by"], "token 1");
    if (k > 0) EXPECT_GE(e[k]["at_unix_ms"].get<std::int64_t>(), e[k - 1]["at_unix_ms"].get<std::int64_t>());
  }
  EXPECT_EQ(e[1]["verdict"], "holds");
  EXPECT_EQ(e[2]["verdict"], "drifted");
  EXPECT_EQ(e[2]["suspects"][0], "joint3.rz");
  EXPECT_EQ(e[3]["campaign"], "cal2");
  EXPECT_EQ(e[3]["note"], "after service");
  EXPECT_EQ(e[4]["rolled_back_to"], 1);
  EXPECT_EQ(e[4]["campaign"], "cal");
  EXPECT_EQ(s.Get("/v1/robots/ur5e-cal").body["joints"], first_joints);
}

INSTANTIATE_TEST_SUITE_P(Backends, HistoryTest, ::testing::Values("sqlite", "postgresql"));

TEST(HistoryErrorsTest, BadRequestsAreNamed) {
  TestServer s({}, {}, {}, OpenSqliteStorage(":memory:"));
  VirtualCell cell(Preset("ur5e"), CellOptions());
  // A robot without a calibration cannot be checked.
  Reply r = s.Post("/v1/robots/ur5e:check", {{"measurements", Shots(&cell, 12, 3)}});
  EXPECT_EQ(r.status, 400);
  EXPECT_EQ(r.body["error"]["status"], "FAILED_PRECONDITION");
  EXPECT_NE(ReasonOf(r, "robot"), "");
  Calibrate(s, &cell, "cal", 1);
  ASSERT_EQ(s.Post("/v1/robots", {{"id", "r"}, {"from_calibration", "cal"}}).status, 200);
  // Bad shots, rate and frames; nothing is recorded.
  json bad = Shots(&cell, 12, 4);
  bad[3]["joints"] = {0, 0, 0};
  r = s.Post("/v1/robots/r:check", {{"measurements", bad}, {"false_alarm_rate", 0.9}, {"frames", "maybe"}});
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(ReasonOf(r, "measurements[3].joints"), "");
  EXPECT_NE(ReasonOf(r, "false_alarm_rate"), "");
  EXPECT_NE(ReasonOf(r, "frames"), "");
  r = s.Post("/v1/robots/r:check", json::object());
  EXPECT_EQ(ReasonOf(r, "measurements"), "required");
  // Too few shots for the registration: named, not judged.
  r = s.Post("/v1/robots/r:check", {{"measurements", Shots(&cell, 2, 5)}});
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(ReasonOf(r, "measurements").find("too few"), std::string::npos) << r.text;
  EXPECT_EQ(s.Get("/v1/robots/r/calibrations").body["entries"].size(), 1u);
  // Rollbacks to no entry or to a check; a calibration of another robot.
  EXPECT_EQ(ReasonOf(s.Post("/v1/robots/r:rollback", {{"entry", 9}}), "entry").find("no such entry"), 0u);
  ASSERT_EQ(s.Post("/v1/robots/r:check", {{"measurements", Shots(&cell, 12, 6)}}).status, 200);
  EXPECT_NE(ReasonOf(s.Post("/v1/robots/r:rollback", {{"entry", 2}}), "entry").find("check"), std::string::npos);
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "other"}, {"robot", "puma560"}}).status, 200);
  r = s.Post("/v1/robots/r:calibrate", {{"from_calibration", "other"}});
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(ReasonOf(r, "from_calibration").find("puma560"), std::string::npos) << r.text;
  EXPECT_EQ(s.Get("/v1/robots/nope/calibrations").status, 404);
  // Shots of too few distinct poses cannot register the frames: refused, not judged (and not recorded).
  json same = Shots(&cell, 1, 8);
  json repeated = json::array();
  for (int k = 0; k < 12; ++k) repeated.push_back(same[0]);
  r = s.Post("/v1/robots/r:check", {{"measurements", repeated}});
  EXPECT_EQ(r.status, 400) << r.text;
  EXPECT_NE(ReasonOf(r, "measurements"), "");
  // More shots than a check takes; a note with control characters.
  json many = json::array();
  for (int k = 0; k < 201; ++k) many.push_back(same[0]);
  EXPECT_NE(ReasonOf(s.Post("/v1/robots/r:check", {{"measurements", many}}), "measurements"), "");
  EXPECT_NE(ReasonOf(s.Post("/v1/robots/r:rollback", {{"entry", 1}, {"note", "a\u001bb"}}), "note"), "");
  // A campaign of an earlier robot registered under the same id: refused.
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "old-r"}, {"robot", "r"}}).status, 200);
  ASSERT_EQ(s.Delete("/v1/robots/r").status, 200);
  ASSERT_EQ(s.Post("/v1/robots", {{"id", "r"}, {"from_calibration", "cal"}}).status, 200);
  ASSERT_EQ(s.Post("/v1/campaigns/old-r/measurements", {{"request_id", "o"}, {"measurements", Shots(&cell, 30, 9)}}).status,
            200);
  ASSERT_EQ(s.Post("/v1/campaigns/old-r:fit", {{"scope", "frames"}}).status, 200);
  EXPECT_EQ(s.Post("/v1/robots/r:calibrate", {{"from_calibration", "old-r"}}).status, 200)
      << "the same definition (registered from the same calibration) is the same robot";
  // A check plan for a robot without a calibration.
  EXPECT_NE(ReasonOf(s.Post("/v1/plans", {{"robot", "ur5e"}, {"purpose", "check"}, {"num_configurations", 12}}), "purpose"),
            "");
  // A server without tokens records no one.
  EXPECT_TRUE(s.Get("/v1/robots/r/calibrations").body["entries"][0]["by"].is_null());
}

}  // namespace
}  // namespace robocal::server::testing
