// The `robocal` binary end to end against the real server in-process: each command as a user types it, exit
// codes 0 / 1 / 2 / 3, and the CSV files it reads and writes.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "mock_tracker.h"
#include "robocal/client/csv.h"
#include "test_server.h"

namespace robocal {
namespace {

namespace fs = std::filesystem;

struct Result {
  int exit_code = -1;
  std::string out;
};

// Runs the CLI with a shell (stderr discarded) and returns its exit code and stdout.
Result RunCli(const std::string& args) {
  const std::string command = std::string(ROBOCAL_CLI) + " " + args + " 2>/dev/null";
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return {};
  Result r;
  char buffer[4096];
  while (std::size_t n = std::fread(buffer, 1, sizeof buffer, pipe)) r.out.append(buffer, n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

std::string Trim(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("robocal_cli_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }

  testing::TestServer server_;
  fs::path dir_;
};

TEST_F(CliTest, HelpOnEveryLevel) {
  for (const char* command :
       {"", "plan", "robot", "campaign", "upload", "fit", "compensate", "evaluate", "operation"}) {
    const Result r = RunCli(std::string(command) + " --help");
    EXPECT_EQ(r.exit_code, 0) << command;
    EXPECT_NE(r.out.find("Usage: robocal"), std::string::npos) << command;
  }
  EXPECT_NE(RunCli("--help").out.find("Exit codes"), std::string::npos);
}

TEST_F(CliTest, ExitCodes) {
  const std::string server = "--server " + server_.url();
  EXPECT_EQ(RunCli(server + " robots").exit_code, 0);
  EXPECT_EQ(RunCli(server + " frobnicate").exit_code, 2);
  EXPECT_EQ(RunCli(server + " plan").exit_code, 2);
  EXPECT_EQ(RunCli(server + " plan grinder5 --count many").exit_code, 2);
  EXPECT_EQ(RunCli(server + " fit no-such-campaign").exit_code, 1);
  EXPECT_EQ(RunCli(server + " plan grinder5 --type sideways").exit_code, 1);
  EXPECT_EQ(RunCli("--server http://127.0.0.1:1 robots").exit_code, 3);
  EXPECT_EQ(RunCli("--server 127.0.0.1:1 robots").exit_code, 2);
}

TEST_F(CliTest, WholeFlow) {
  const std::string server = "--server " + server_.url();
  const Result robots = RunCli(server + " robots --json");
  ASSERT_EQ(robots.exit_code, 0);
  EXPECT_EQ(nlohmann::json::parse(robots.out).at("robots").size(), 3u);

  std::ofstream(Path("cell7.json")) << R"({"id": "cell7", "from_preset": "grinder5"})";
  EXPECT_EQ(RunCli(server + " robot register " + Path("cell7.json")).exit_code, 0);
  EXPECT_EQ(RunCli(server + " robot register " + Path("cell7.json")).exit_code, 1);  // ALREADY_EXISTS

  const Result plan = RunCli(server + " plan grinder5 --count 10 --seed 3 --out " + Path("plan.csv"));
  ASSERT_EQ(plan.exit_code, 0);
  EXPECT_NE(plan.out.find("cond"), std::string::npos);
  const Result plan_json = RunCli(server + " plan grinder5 --count 10 --seed 3 --async --json");
  ASSERT_EQ(plan_json.exit_code, 0);
  const nlohmann::json plan_doc = nlohmann::json::parse(plan_json.out);
  const std::string plan_id = plan_doc.at("id");

  const Result created = RunCli(server + " campaign create grinder5 pose --plan " + plan_id);
  ASSERT_EQ(created.exit_code, 0);
  const std::string campaign = Trim(created.out);

  // Measurements from the simulated cell: calibration as CSV, validation as JSON.
  mock::MockTrackerOptions options;
  options.shots_per_pose = 2;
  VirtualCell cell = mock::MakeCell(options);
  std::ifstream plan_csv(Path("plan.csv"));
  const auto configurations = client::ReadJointsCsv(plan_csv, 5);
  ASSERT_EQ(configurations, plan_doc.at("configurations").get<std::vector<std::vector<double>>>());
  const auto batch = mock::MeasurementBatch(&cell, configurations, "calibration", options);
  std::vector<api::MeasurementWire> shots;
  for (const auto& m : batch.at("measurements")) shots.push_back(api::MeasurementFromJson(m));
  std::vector<client::JointInfo> joints(5);
  for (int i = 0; i < 5; ++i) joints[i] = {"q" + std::to_string(i + 1), "", i < 3 ? "mm" : "deg", 0, 0};
  {
    std::ofstream csv(Path("calibration.csv"));
    client::WriteMeasurementsCsv(csv, joints, shots);
  }
  std::ofstream(Path("validation.json")) << mock::MeasurementBatch(&cell, configurations, "validation", options);

  const Result uploaded = RunCli(server + " upload " + campaign + " " + Path("calibration.csv") + " --json");
  ASSERT_EQ(uploaded.exit_code, 0);
  EXPECT_EQ(nlohmann::json::parse(uploaded.out).at("count"), 20);
  const Result replay = RunCli(server + " upload " + campaign + " " + Path("calibration.csv"));
  EXPECT_NE(replay.out.find("replayed"), std::string::npos);
  EXPECT_EQ(RunCli(server + " upload " + campaign + " " + Path("validation.json")).exit_code, 0);

  const Result fit = RunCli(server + " fit " + campaign);
  ASSERT_EQ(fit.exit_code, 0);
  EXPECT_NE(fit.out.find("parameter"), std::string::npos);
  EXPECT_NE(fit.out.find("residuals"), std::string::npos);

  const Result compensated = RunCli(server + " compensate " + campaign + " " + Path("plan.csv"));
  ASSERT_EQ(compensated.exit_code, 0);
  EXPECT_NE(compensated.out.find("position_error_mm"), std::string::npos);
  EXPECT_EQ(std::count(compensated.out.begin(), compensated.out.end(), '\n'), 11);

  const Result evaluated = RunCli(server + " evaluate " + campaign);
  ASSERT_EQ(evaluated.exit_code, 0);
  EXPECT_NE(evaluated.out.find("E_xyz"), std::string::npos);
  const Result evaluated_json = RunCli(server + " evaluate " + campaign + " --json");
  const auto e = nlohmann::json::parse(evaluated_json.out);
  EXPECT_LT(e.at("calibrated").at("e_xyz_mm").at("mean").get<double>(),
            e.at("nominal").at("e_xyz_mm").at("mean").get<double>());

  EXPECT_EQ(RunCli(server + " campaign get " + campaign).exit_code, 0);
  EXPECT_EQ(RunCli(server + " operation get op-0000000000000000").exit_code, 1);
}

TEST_F(CliTest, TokenFromFlag) {
  testing::TestServer secured({"t0ken"});
  EXPECT_EQ(RunCli("--server " + secured.url() + " robots").exit_code, 1);
  EXPECT_EQ(RunCli("--server " + secured.url() + " --token t0ken robots").exit_code, 0);
}

}  // namespace
}  // namespace robocal
