// The `robocal` binary end to end against the real server in-process: each command as a user types it, exit
// codes 0 / 1 / 2 / 3, and the CSV files it reads and writes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iterator>
#include <sstream>

#include "cli.h"
#include "mock_tracker.h"
#include "robocal/api/programs.h"
#include "robocal/api/robots.h"
#include "robocal/client/csv.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/planning.h"
#include "robocal/core/presets.h"
#include "robocal/core/virtual_cell.h"
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

// Runs the CLI in-process (cli::Run), for its stderr.
struct InProcess {
  int exit_code = -1;
  std::string out, err;
};
InProcess RunInProcess(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  InProcess r;
  r.exit_code = cli::Run(args, {}, out, err);
  r.out = out.str();
  r.err = err.str();
  return r;
}

// Joints named q1..q5 as the grinder's (three prismatic, two revolute), for writing CSV files.
std::vector<api::RobotJoint> GrinderJoints() {
  std::vector<api::RobotJoint> joints(5);
  for (int i = 0; i < 5; ++i) {
    joints[i].name = "q" + std::to_string(i + 1);
    joints[i].unit = i < 3 ? "mm" : "deg";
  }
  return joints;
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
  for (const char* command : {"", "robots", "plan", "robot", "campaign", "upload", "measurements", "fit", "compensate",
                              "compensate-program", "evaluate", "operation", "experiment", "cell"}) {
    const Result r = RunCli(std::string(command) + " --help");
    EXPECT_EQ(r.exit_code, 0) << command;
    EXPECT_NE(r.out.find("Usage: robocal " + std::string(command)), std::string::npos) << command;
  }
  const std::string main_help = RunCli("--help").out;
  EXPECT_NE(main_help.find("Exit codes"), std::string::npos);
  for (const char* mention :
       {"plan get", "robot forward", "campaign forward", "measurements", "experiment", "cell create", "cell check",
        "--ca-cert", "--insecure"}) {
    EXPECT_NE(main_help.find(mention), std::string::npos) << mention;
  }
  // robocal experiment takes robocal-experiment's flags, listed in its help.
  const std::string experiment_help = RunCli("experiment --help").out;
  for (const char* flag : {"--robot", "--type", "--configurations", "--trials", "--validation", "--h-mm", "--seed",
                           "--noise-mm", "--noise-deg", "--shots", "--cell"}) {
    EXPECT_NE(experiment_help.find(flag), std::string::npos) << flag;
  }
  EXPECT_NE(RunCli("plan --help").out.find("--cell"), std::string::npos);
}

TEST_F(CliTest, ExitCodes) {
  const std::string server = "--server " + server_.url();
  EXPECT_EQ(RunCli(server + " robots").exit_code, 0);
  EXPECT_EQ(RunCli(server + " frobnicate").exit_code, 2);
  EXPECT_EQ(RunCli(server + " plan").exit_code, 2);
  EXPECT_EQ(RunCli(server + " plan grinder5 --count many").exit_code, 2);
  EXPECT_EQ(RunCli(server + " fit no-such-campaign").exit_code, 1);
  // Enum values are checked by the CLI itself (the typed request has no place for another), naming the names.
  EXPECT_EQ(RunCli(server + " plan grinder5 --type sideways").exit_code, 2);
  EXPECT_EQ(RunCli(server + " campaign create grinder5 sideways").exit_code, 2);
  EXPECT_EQ(RunCli(server + " plan grinder5 --count 0").exit_code, 2);
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
  const auto batch = mock::MeasurementBatch(&cell, configurations, api::MeasurementRole::kCalibration, options);
  {
    std::ofstream csv(Path("calibration.csv"));
    client::WriteMeasurementsCsv(csv, GrinderJoints(), batch.measurements);
  }
  std::ofstream(Path("validation.json"))
      << nlohmann::json(mock::MeasurementBatch(&cell, configurations, api::MeasurementRole::kValidation, options));

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
  // The same fit as an operation: the fit comes back stored.
  const Result fit_async = RunCli(server + " fit " + campaign + " --async --json");
  ASSERT_EQ(fit_async.exit_code, 0);
  const auto fitted = nlohmann::json::parse(fit_async.out);
  EXPECT_TRUE(fitted.at("stored").get<bool>());
  EXPECT_FALSE(fitted.at("parameters").empty());

  const Result compensated = RunCli(server + " compensate " + campaign + " " + Path("plan.csv"));
  ASSERT_EQ(compensated.exit_code, 0);
  EXPECT_NE(compensated.out.find("position_error_mm"), std::string::npos);
  EXPECT_EQ(std::count(compensated.out.begin(), compensated.out.end(), '\n'), 11);
  // --json is the compensation result as the service sends it (the CLI's own copy once dropped iterations and
  // free_rotation_deg).
  const Result compensated_json = RunCli(server + " compensate " + campaign + " " + Path("plan.csv") + " --json");
  ASSERT_EQ(compensated_json.exit_code, 0);
  const auto compensation = api::FromWire<api::CompensatedTargets>(nlohmann::json::parse(compensated_json.out));
  EXPECT_EQ(compensation.campaign, campaign);
  ASSERT_EQ(compensation.results.size(), 10u);
  EXPECT_GT(compensation.results[0].iterations, 0);
  EXPECT_TRUE(nlohmann::json::parse(compensated_json.out).at("results")[0].contains("free_rotation_deg"));
  // --sequence: the rows are one program; the jump columns say how far the revolute joints move from the
  // previous row (empty on the first), flagged over --max-jump. The planned configurations are far apart.
  const Result program =
      RunCli(server + " compensate " + campaign + " " + Path("plan.csv") + " --sequence --max-jump 0.001");
  ASSERT_EQ(program.exit_code, 0);
  std::istringstream program_rows(program.out);
  std::string row;
  std::getline(program_rows, row);
  EXPECT_NE(row.find(",converged,joint_jump_deg,joint_jump"), std::string::npos) << row;
  std::getline(program_rows, row);
  EXPECT_EQ(row.substr(row.size() - 3), ",,0") << row;  // the first row: no jump
  int flagged = 0;
  while (std::getline(program_rows, row)) flagged += row.back() == '1' ? 1 : 0;
  EXPECT_EQ(flagged, 9) << program.out;
  EXPECT_EQ(RunCli(server + " compensate " + campaign + " " + Path("plan.csv") + " --max-jump 5").exit_code, 2);
  // Pose targets from a CSV: the calibrated robot's own poses (its forward kinematics at the planned joints,
  // tracker frame) come back converged; grinder5 has no named branches, so no branch columns, and a branch column
  // is the service's 400 naming the field.
  {
    const Result poses = RunCli(server + " campaign forward " + campaign + " " + Path("plan.csv") + " --json");
    ASSERT_EQ(poses.exit_code, 0);
    const auto forward = api::FromWire<api::ForwardResult>(nlohmann::json::parse(poses.out));
    std::ofstream csv(Path("poses.csv"));
    csv << std::setprecision(17) << "x_mm,y_mm,z_mm,qw,qx,qy,qz\n";
    for (std::size_t i = 0; i < 3; ++i) {
      const api::PoseWire& p = forward.poses[i];
      csv << p.position_mm[0] << "," << p.position_mm[1] << "," << p.position_mm[2] << "," << p.quaternion[0]
          << "," << p.quaternion[1] << "," << p.quaternion[2] << "," << p.quaternion[3] << "\n";
    }
  }
  const Result to_poses = RunCli(server + " compensate " + campaign + " " + Path("poses.csv"));
  ASSERT_EQ(to_poses.exit_code, 0);
  std::istringstream pose_rows(to_poses.out);
  std::string pose_row;
  std::getline(pose_rows, pose_row);
  EXPECT_EQ(pose_row.find("shoulder"), std::string::npos) << pose_row;
  int converged_rows = 0;
  while (std::getline(pose_rows, pose_row)) converged_rows += pose_row.substr(pose_row.size() - 2) == ",1" ? 1 : 0;
  EXPECT_EQ(converged_rows, 3) << to_poses.out;
  std::ofstream(Path("branch.csv")) << "x_mm,y_mm,z_mm,qw,qx,qy,qz,elbow\n500,300,100,1,0,0,0,up\n";
  const InProcess branch = RunInProcess({"--server", server_.url(), "compensate", campaign, Path("branch.csv")});
  EXPECT_NE(branch.exit_code, 0);
  EXPECT_NE(branch.err.find("targets[0].configuration"), std::string::npos) << branch.err;
  std::ofstream(Path("badflag.csv")) << "x_mm,y_mm,z_mm,qw,qx,qy,qz,elbow\n500,300,100,1,0,0,0,sideways\n";
  const InProcess bad_flag = RunInProcess({"--server", server_.url(), "compensate", campaign, Path("badflag.csv")});
  EXPECT_EQ(bad_flag.exit_code, 2);
  EXPECT_NE(bad_flag.err.find("line 2, column 8"), std::string::npos) << bad_flag.err;

  const Result evaluated = RunCli(server + " evaluate " + campaign);
  ASSERT_EQ(evaluated.exit_code, 0);
  EXPECT_NE(evaluated.out.find("E_xyz"), std::string::npos);
  const Result evaluated_json = RunCli(server + " evaluate " + campaign + " --json");
  const auto e = nlohmann::json::parse(evaluated_json.out);
  EXPECT_LT(e.at("calibrated").at("e_xyz_mm").at("mean").get<double>(),
            e.at("nominal").at("e_xyz_mm").at("mean").get<double>());

  const Result shown = RunCli(server + " campaign get " + campaign);
  EXPECT_EQ(shown.exit_code, 0);
  EXPECT_NE(shown.out.find("  calibrated"), std::string::npos) << shown.out;
  EXPECT_EQ(RunCli(server + " operation get op-0000000000000000").exit_code, 1);
}

// A cell: created from a file, listed, planned in (every configuration feasible, checked by the cell itself
// through `cell check`), and a configuration into the floor named as such.
TEST_F(CliTest, CellCreateCheckAndPlanInIt) {
  const std::string server = "--server " + server_.url();
  std::ofstream(Path("cell.json")) << R"({"id": "bench", "robot": "ur5e",
      "tracker": {"position_mm": [2500, -800, 300], "min_distance_mm": 1500, "max_distance_mm": 15000},
      "reflectors": [{"id": "smr1", "position_mm": [0, 0, 120], "normal": [0, 0, 1]}],
      "obstacles": [{"id": "floor", "box": {"min_mm": [-3000, -3000, -500], "max_mm": [3000, 3000, -10]}}],
      "clearance_mm": 20})";
  const Result created = RunCli(server + " cell create " + Path("cell.json"));
  ASSERT_EQ(created.exit_code, 0);
  EXPECT_NE(created.out.find("bench: robot ur5e"), std::string::npos) << created.out;
  EXPECT_NE(RunCli(server + " cell list").out.find("bench"), std::string::npos);
  const nlohmann::json cell = nlohmann::json::parse(RunCli(server + " cell get bench --json").out);
  EXPECT_EQ(cell.at("link_radii_mm").size(), 6u);
  // An option `cell get` does not take is a usage error naming it.
  EXPECT_EQ(RunCli(server + " cell get bench --count 3").exit_code, 2);

  const Result plan = RunCli(server + " plan ur5e --cell bench --count 6 --seed 3 --out " + Path("plan.csv") +
                             " --json");
  ASSERT_EQ(plan.exit_code, 0) << plan.out;
  const nlohmann::json planned = nlohmann::json::parse(plan.out);
  ASSERT_EQ(planned.at("configuration_checks").size(), 6u);
  EXPECT_EQ(planned.at("cell"), "bench");
  // The table shows each configuration's clearance and the reflector the tracker sees there.
  const Result table = RunCli(server + " plan get " + planned.at("id").get<std::string>());
  ASSERT_EQ(table.exit_code, 0) << table.out;
  EXPECT_NE(table.out.find("in cell bench"), std::string::npos) << table.out;
  EXPECT_NE(table.out.find("measurable reflectors"), std::string::npos) << table.out;
  std::size_t seen = 0;
  for (std::size_t at = table.out.find(" smr1 "); at != std::string::npos; at = table.out.find(" smr1 ", at + 1)) ++seen;
  EXPECT_EQ(seen, 6u) << table.out;
  // The planned configurations, checked again by the cell: every one feasible.
  const Result check = RunCli(server + " cell check bench " + Path("plan.csv"));
  ASSERT_EQ(check.exit_code, 0);
  std::istringstream rows(check.out);
  std::string line;
  std::getline(rows, line);
  EXPECT_EQ(line, "row,feasible,min_clearance_mm,clearance_pair,measurable,reasons");
  int feasible = 0;
  while (std::getline(rows, line)) feasible += line.find(",1,") != std::string::npos ? 1 : 0;
  EXPECT_EQ(feasible, 6) << check.out;
  // The arm straight down into the floor.
  std::ofstream(Path("down.csv")) << "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n0,90,0,0,0,0\n";
  const nlohmann::json down = nlohmann::json::parse(RunCli(server + " cell check bench " + Path("down.csv") + " --json").out);
  EXPECT_FALSE(down.at("results")[0].at("feasible").get<bool>());
  EXPECT_NE(down.at("results")[0].at("clearance_pair").get<std::string>().find("floor"), std::string::npos);
  EXPECT_EQ(RunCli(server + " cell delete bench").exit_code, 0);
  EXPECT_EQ(RunCli(server + " cell get bench").exit_code, 1);
}

TEST_F(CliTest, PlanGetMeasurementsAndForward) {
  const std::string server = "--server " + server_.url();
  const Result created = RunCli(server + " plan grinder5 --count 8 --seed 4 --json");
  ASSERT_EQ(created.exit_code, 0);
  const nlohmann::json plan = nlohmann::json::parse(created.out);
  const std::string plan_id = plan.at("id");
  const auto configurations = plan.at("configurations").get<std::vector<std::vector<double>>>();

  // plan get: the stored plan, printed, as JSON and as a joints CSV.
  const Result shown = RunCli(server + " plan get " + plan_id + " --out " + Path("stored.csv"));
  ASSERT_EQ(shown.exit_code, 0);
  EXPECT_NE(shown.out.find("plan " + plan_id), std::string::npos);
  EXPECT_NE(shown.out.find("random"), std::string::npos);  // the indices of the random baseline
  EXPECT_EQ(nlohmann::json::parse(RunCli(server + " plan get " + plan_id + " --json").out).at("configurations"),
            plan.at("configurations"));
  std::ifstream stored(Path("stored.csv"));
  EXPECT_EQ(client::ReadJointsCsv(stored, 5), configurations);
  EXPECT_EQ(RunCli(server + " plan get plan-0000000000000000").exit_code, 1);

  // robot forward: joints CSV in, poses CSV out, the rows in input order.
  const Result forward = RunCli(server + " robot forward grinder5 " + Path("stored.csv"));
  ASSERT_EQ(forward.exit_code, 0);
  std::istringstream forward_csv(forward.out);
  const auto poses = client::ReadMeasurementsCsv(forward_csv, 5);
  ASSERT_EQ(poses.size(), configurations.size());
  EXPECT_EQ(poses[3].joints, configurations[3]);
  EXPECT_TRUE(poses[3].pose.has_orientation);
  const auto forward_json =
      nlohmann::json::parse(RunCli(server + " robot forward grinder5 " + Path("stored.csv") + " --json").out);
  EXPECT_NEAR(forward_json.at("poses")[3].at("position_mm")[0].get<double>(), poses[3].pose.position_mm[0], 1e-6);
  std::ofstream(Path("short.csv")) << "x_mm,y_mm\n1,2\n";
  EXPECT_EQ(RunCli(server + " robot forward grinder5 " + Path("short.csv")).exit_code, 2);

  // A campaign with the cell's shots; measurements reads them back in the upload format.
  const std::string campaign = Trim(RunCli(server + " campaign create grinder5 pose --plan " + plan_id).out);
  mock::MockTrackerOptions options;
  options.shots_per_pose = 2;
  VirtualCell cell = mock::MakeCell(options);
  std::ofstream(Path("calibration.json"))
      << nlohmann::json(mock::MeasurementBatch(&cell, configurations, api::MeasurementRole::kCalibration, options));
  ASSERT_EQ(RunCli(server + " upload " + campaign + " " + Path("calibration.json")).exit_code, 0);
  const Result listed = RunCli(server + " measurements " + campaign + " --out " + Path("listed.csv"));
  ASSERT_EQ(listed.exit_code, 0);
  std::ifstream listed_csv(Path("listed.csv"));
  const auto shots = client::ReadMeasurementsCsv(listed_csv, 5);
  ASSERT_EQ(shots.size(), 16u);
  EXPECT_EQ(shots[15].joints, configurations[7]);
  const auto all = nlohmann::json::parse(RunCli(server + " measurements " + campaign + " --json").out);
  ASSERT_EQ(all.at("measurements").size(), 16u);
  const std::string third = all.at("measurements")[2].at("sequence").dump();
  const auto page = nlohmann::json::parse(
      RunCli(server + " measurements " + campaign + " --role calibration --after " + third + " --limit 5 --json").out);
  ASSERT_EQ(page.at("measurements").size(), 5u);
  EXPECT_EQ(page.at("measurements")[0], all.at("measurements")[3]);
  EXPECT_EQ(RunCli(server + " measurements " + campaign + " --role sideways").exit_code, 2);
  // What measurements writes, upload reads: a second campaign gets the same shots.
  const std::string copy = Trim(RunCli(server + " campaign create grinder5 pose").out);
  ASSERT_EQ(RunCli(server + " upload " + copy + " " + Path("listed.csv")).exit_code, 0);
  EXPECT_EQ(
      nlohmann::json::parse(RunCli(server + " campaign get " + copy + " --json").out).at("counts").at("calibration"),
      16);

  // campaign forward: the calibrated robot in the tracker frame, close to what the tracker measured.
  EXPECT_EQ(RunCli(server + " campaign forward " + campaign + " " + Path("stored.csv")).exit_code, 1);  // no fit
  ASSERT_EQ(RunCli(server + " fit " + campaign).exit_code, 0);
  const Result calibrated =
      RunCli(server + " campaign forward " + campaign + " " + Path("stored.csv") + " --out " + Path("calibrated.csv"));
  ASSERT_EQ(calibrated.exit_code, 0);
  std::ifstream calibrated_csv(Path("calibrated.csv"));
  const auto predicted = client::ReadMeasurementsCsv(calibrated_csv, 5);
  ASSERT_EQ(predicted.size(), 8u);
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_NEAR(predicted[0].pose.position_mm[axis], shots[0].pose.position_mm[axis], 0.2) << axis;
  }
}

TEST_F(CliTest, OperationWait) {
  ClientOptions options;
  options.server_url = server_.url();
  Client c(options);
  api::PlanRequest request;
  request.robot = "grinder5";
  request.num_configurations = 8;
  request.options.k_max = 10;
  const api::Operation started = c.StartPlan(request);
  const std::string server = "--server " + server_.url();
  const Result waited = RunCli(server + " operation wait " + started.id);
  ASSERT_EQ(waited.exit_code, 0);
  EXPECT_NE(waited.out.find(started.id + " SUCCEEDED 100% plan "), std::string::npos) << waited.out;
  const auto done = nlohmann::json::parse(RunCli(server + " operation get " + started.id + " --json").out);
  EXPECT_EQ(done.at("state"), "SUCCEEDED");
  EXPECT_EQ(RunCli(server + " operation cancel " + started.id).exit_code, 0);  // already done: a no-op
  EXPECT_EQ(RunCli(server + " operation wait").exit_code, 2);
}

TEST_F(CliTest, Experiment) {
  const Result run = RunCli("experiment --trials 1 --validation 5 --seed 3 --json");
  ASSERT_EQ(run.exit_code, 0);
  const auto result = nlohmann::json::parse(run.out);
  EXPECT_EQ(result.at("methods").size(), 3u);
  EXPECT_EQ(result.at("before").at("e_xyz_mm").at("count"), 5);
  // Its accuracies are the service's shape (api::Accuracy: mm and degrees).
  EXPECT_EQ(api::FromWire<api::Accuracy>(result.at("methods")[0].at("after")).e_tot_mm.count, 5);
  const Result table = RunCli("experiment --trials=1 --validation 5 --seed 3 --server http://127.0.0.1:1");
  ASSERT_EQ(table.exit_code, 0);  // local: the server is not asked
  EXPECT_NE(table.out.find("Solis & Wets against random selection"), std::string::npos);
  EXPECT_EQ(RunCli("experiment --trials 0").exit_code, 2);
  EXPECT_EQ(RunCli("experiment --robot kuka").exit_code, 2);
  EXPECT_EQ(RunCli("experiment --frobnicate 1").exit_code, 2);
}

// Each command takes the options its table entry declares, and the global ones; any other is a usage error
// naming the option and the command (once silently ignored).
TEST_F(CliTest, AnOptionACommandDoesNotTakeIsAUsageError) {
  const std::string url = server_.url();
  const InProcess robots = RunInProcess({"--server", url, "robots", "--count", "3"});
  EXPECT_EQ(robots.exit_code, 2);
  EXPECT_NE(robots.err.find("robots does not take the option --count"), std::string::npos) << robots.err;
  const InProcess list = RunInProcess({"--server", url, "campaign", "list", "--role=validation"});
  EXPECT_EQ(list.exit_code, 2);
  EXPECT_NE(list.err.find("campaign list does not take the option --role"), std::string::npos) << list.err;
  const InProcess fit = RunInProcess({"--server", url, "fit", "c1", "--out", "fit.csv"});
  EXPECT_EQ(fit.exit_code, 2);
  EXPECT_NE(fit.err.find("fit does not take the option --out (its options: --parameters"), std::string::npos)
      << fit.err;
  EXPECT_EQ(RunInProcess({"--server", url, "plan", "get", "p1", "--count", "3"}).exit_code, 2);
  // An option the command does not take, written as a switch before an argument, takes that argument as its
  // value: the option is named, not the argument count.
  const InProcess swallowed = RunInProcess({"--server", url, "cell", "get", "--verbose", "bench"});
  EXPECT_EQ(swallowed.exit_code, 2);
  EXPECT_NE(swallowed.err.find("cell get does not take the option --verbose"), std::string::npos) << swallowed.err;
  // The global options stay valid everywhere, before or after the command.
  EXPECT_EQ(RunInProcess({"robots", "--json", "--server", url}).exit_code, 0);
  EXPECT_EQ(RunInProcess({"--json", "--server=" + url, "campaign", "list"}).exit_code, 0);
  // A command's help lists exactly its options.
  const InProcess help = RunInProcess({"measurements", "--help"});
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.out.find("Usage: robocal measurements CAMPAIGN [--role calibration|validation] [--after SEQ] "
                          "[--limit N] [--out FILE.csv]"),
            std::string::npos)
      << help.out;
  const InProcess unknown = RunInProcess({"robot", "frobnicate", "x"});
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_NE(unknown.err.find("robot commands: register, import, get, delete, history, calibrate, rollback, forward"), std::string::npos) << unknown.err;
}

// robot import: a public URDF (UR5) becomes a robot with its joint names, the chain's links said; without
// --base / --tip it is a usage error, an unknown link the service's named field.
TEST_F(CliTest, RobotImportFromAUrdfFile) {
  const std::string server = "--server " + server_.url();
  const std::string file = std::string(ROBOCAL_URDF_DATA) + "/ur5_robot.urdf";
  const Result imported = RunCli(server + " robot import " + file + " --base base_link --tip tool0 --id ur5-lab");
  ASSERT_EQ(imported.exit_code, 0);
  EXPECT_NE(imported.out.find("ur5-lab: 6 joints (transform), 48 error parameters, from URDF base_link -> tool0"),
            std::string::npos)
      << imported.out;
  EXPECT_NE(imported.out.find("shoulder_pan_joint"), std::string::npos) << imported.out;
  const Result shown = RunCli(server + " robot get ur5-lab --json");
  EXPECT_EQ(nlohmann::json::parse(shown.out).at("urdf").at("tip_link"), "tool0");
  const InProcess no_tip = RunInProcess({"--server", server_.url(), "robot", "import", file, "--base", "base_link"});
  EXPECT_EQ(no_tip.exit_code, 2);
  EXPECT_NE(no_tip.err.find("--tip"), std::string::npos) << no_tip.err;
  const InProcess bad_link =
      RunInProcess({"--server", server_.url(), "robot", "import", file, "--base", "base_link", "--tip", "hand"});
  EXPECT_EQ(bad_link.exit_code, 1);
  EXPECT_NE(bad_link.err.find("tip_link: no link \"hand\""), std::string::npos) << bad_link.err;
}

// campaign create --reflectors: nests with flange positions, fixed or identified (campaign get lists them);
// a malformed list is a usage error naming the flag, reflectors on a pose campaign the service's field.
TEST_F(CliTest, CampaignCreateWithReflectors) {
  const std::string server = "--server " + server_.url();
  const Result created = RunCli(server +
                                " campaign create ur5e position --id nests-1 --json --reflectors "
                                "smr1:60,0,20/smr2:-30,52,20:fixed/smr3:-30,-52.5,20");
  ASSERT_EQ(created.exit_code, 0) << created.out;
  const nlohmann::json campaign = nlohmann::json::parse(created.out);
  ASSERT_EQ(campaign.at("reflectors").size(), 3u);
  EXPECT_EQ(campaign["reflectors"][1]["id"], "smr2");
  EXPECT_EQ(campaign["reflectors"][1]["fixed"], true);
  EXPECT_EQ(campaign["reflectors"][2]["position_mm"][1], -52.5);
  EXPECT_EQ(campaign["reflectors"][0].value("fixed", false), false);
  const Result shown = RunCli(server + " campaign get nests-1");
  EXPECT_NE(shown.out.find("reflector smr2 at -30 52 20 mm (flange), fixed"), std::string::npos) << shown.out;
  EXPECT_NE(shown.out.find("reflector smr1 at 60 0 20 mm (flange), offset identified"), std::string::npos)
      << shown.out;
  for (const char* bad : {"smr1", "smr1:1,2", "smr1:1,2,3:loose", "smr1:1,2,x"}) {
    const InProcess r =
        RunInProcess({"--server", server_.url(), "campaign", "create", "ur5e", "position", "--reflectors", bad});
    EXPECT_EQ(r.exit_code, 2) << bad;
    EXPECT_NE(r.err.find("--reflectors"), std::string::npos) << r.err;
  }
  const InProcess pose =
      RunInProcess({"--server", server_.url(), "campaign", "create", "ur5e", "pose", "--reflectors", "smr1:1,2,3"});
  EXPECT_EQ(pose.exit_code, 1);
  EXPECT_NE(pose.err.find("reflectors: need position measurements"), std::string::npos) << pose.err;
}

// campaign create --payload: the payload the robot carries (campaign get shows it); bad ones are named.
TEST_F(CliTest, CampaignCreateWithAPayload) {
  const std::string server = "--server " + server_.url();
  const Result created = RunCli(server + " campaign create ur5e pose --id loaded-1 --json --payload 4.5@0,10,80");
  ASSERT_EQ(created.exit_code, 0) << created.out;
  const nlohmann::json campaign = nlohmann::json::parse(created.out);
  EXPECT_EQ(campaign.at("payload").at("mass_kg"), 4.5);
  EXPECT_EQ(campaign["payload"]["com_mm"], nlohmann::json::parse("[0, 10, 80]"));
  const Result shown = RunCli(server + " campaign get loaded-1");
  EXPECT_NE(shown.out.find("payload 4.5 kg at 0 10 80 mm (flange)"), std::string::npos) << shown.out;
  const Result plain = RunCli(server + " campaign create ur5e pose --id loaded-2 --json --payload 2");
  ASSERT_EQ(plain.exit_code, 0) << plain.out;
  EXPECT_EQ(nlohmann::json::parse(plain.out)["payload"]["com_mm"], nlohmann::json::parse("[0, 0, 0]"));
  for (const char* bad : {"x", "2@1,2", "2@1,2,z"}) {
    const InProcess r = RunInProcess({"--server", server_.url(), "campaign", "create", "ur5e", "pose", "--payload", bad});
    EXPECT_EQ(r.exit_code, 2) << bad;
    EXPECT_NE(r.err.find("--payload"), std::string::npos) << r.err;
  }
  const InProcess negative =
      RunInProcess({"--server", server_.url(), "campaign", "create", "ur5e", "pose", "--payload", "-1"});
  EXPECT_EQ(negative.exit_code, 1);
  EXPECT_NE(negative.err.find("payload.mass_kg"), std::string::npos) << negative.err;
}

// export --format dh|mdh of a robot without parallel neighbouring axes: a definition that robot register takes.
TEST_F(CliTest, ExportDhTableRegistersAsARobot) {
  const std::string server = "--server " + server_.url();
  nlohmann::json joints = nlohmann::json::array();
  const double a[6] = {50, 300, 40, 10, 0, 5}, d[6] = {400, 30, -20, 350, 15, 90};
  const double alpha[6] = {90, -90, 90, -90, 90, 0};
  for (int i = 0; i < 6; ++i) {
    joints.push_back({{"name", "j" + std::to_string(i + 1)}, {"type", "revolute"}, {"a_mm", a[i]},
                      {"alpha_deg", alpha[i]}, {"d_mm", d[i]}, {"theta_deg", 0}, {"min_deg", -170},
                      {"max_deg", 170}});
  }
  const nlohmann::json skew = {{"id", "skew"}, {"convention", "dh"}, {"joints", joints}};
  std::ofstream(Path("skew.json")) << skew;
  ASSERT_EQ(RunCli(server + " robot register " + Path("skew.json")).exit_code, 0);
  ASSERT_EQ(Trim(RunCli(server + " campaign create skew pose --id skew-1").out), "skew-1");
  const RobotModel model = api::BuildModel(api::ParseRegisterRobotRequest(skew, api::Limits{}));
  VirtualCellOptions cell_options;
  cell_options.seed = 2;
  VirtualCell cell(model, cell_options);
  Rng rng(3);
  nlohmann::json shots = nlohmann::json::array();
  for (const Measurement& m : cell.MeasureAll(RandomConfigurations(model, 25, &rng), 1)) {
    shots.push_back({{"joints", api::JointsToWire(model, m.joints)}, {"pose", api::TransformToPose(m.T_world_tool)}});
  }
  std::ofstream(Path("skew-shots.json")) << nlohmann::json{{"role", "calibration"}, {"measurements", shots}};
  ASSERT_EQ(RunCli(server + " upload skew-1 " + Path("skew-shots.json")).exit_code, 0);
  ASSERT_EQ(RunCli(server + " fit skew-1").exit_code, 0);
  for (const std::string format : {"dh", "mdh"}) {
    const std::string file = Path("skew-1-" + format + ".json");
    ASSERT_EQ(RunCli(server + " export skew-1 --format " + format + " --out " + file).exit_code, 0);
    std::stringstream text;
    text << std::ifstream(file).rdbuf();
    const nlohmann::json table = nlohmann::json::parse(text.str());
    EXPECT_EQ(table.at("convention"), format);
    EXPECT_EQ(table.at("joints").size(), 6u);
    EXPECT_EQ(RunCli(server + " robot register " + file).exit_code, 0) << text.str();
    EXPECT_EQ(RunCli(server + " robot get skew-1-" + format + " --json").exit_code, 0);
  }
}

// upload --format sa|csv: the tracker's point export, matched to the campaign's plan; a bad line is named and
// nothing is stored; upload-only options without --format are usage errors.
TEST_F(CliTest, UploadTrackerExports) {
  const std::string server = "--server " + server_.url();
  const Result plan = RunCli(server + " plan grinder5 --type position --count 6 --seed 5 --json");
  ASSERT_EQ(plan.exit_code, 0);
  const nlohmann::json planned = nlohmann::json::parse(plan.out);
  const std::string plan_id = planned.at("id");
  ASSERT_EQ(Trim(RunCli(server + " campaign create grinder5 position --id pts-1 --plan " + plan_id).out), "pts-1");
  const RobotModel model = Preset("grinder5");
  std::ofstream sa(Path("export.txt"));
  sa << "// Units: mm\n";
  for (std::size_t k = 0; k < planned.at("configurations").size(); ++k) {
    const Eigen::VectorXd q =
        api::JointsToCore(model, planned.at("configurations")[k].get<std::vector<double>>());
    const Eigen::Vector3d p = ForwardKinematics(model, q).translation();
    sa << "A G P" << (k + 1) << " " << p.x() << " " << p.y() << " " << p.z() << "\n";
  }
  sa.close();
  const Result stored = RunCli(server + " upload pts-1 " + Path("export.txt") + " --format sa");
  ASSERT_EQ(stored.exit_code, 0);
  EXPECT_NE(stored.out.find("stored 6 calibration measurements from " + Path("export.txt")), std::string::npos)
      << stored.out;
  std::ofstream(Path("export.txt"), std::ios::app) << "A G P2 1 2\n";
  const InProcess bad =
      RunInProcess({"--server", server_.url(), "upload", "pts-1", Path("export.txt"), "--format", "sa"});
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("line 8: expected 6 fields"), std::string::npos) << bad.err;
  EXPECT_EQ(RunCli(server + " upload pts-1 " + Path("export.txt") + " --plan " + plan_id).exit_code, 2);
  EXPECT_EQ(RunCli(server + " upload pts-1 " + Path("export.txt") + " --format dxf").exit_code, 2);
  EXPECT_EQ(RunCli(server + " upload pts-1 " + Path("export.txt") + " --format sa --columns x=X").exit_code, 2);
  const Result campaign = RunCli(server + " campaign get pts-1 --json");
  EXPECT_EQ(nlohmann::json::parse(campaign.out).at("counts").at("calibration"), 6);
}

// An export that carries its joints, as real ones do: European CSV (';', decimal commas), a Latin-1 header
// (the degree sign), joints in rad and the pose as extrinsic X-Y-Z Euler angles in degrees; 40 rows of a
// virtual cell's exact poses, 25 drawn as calibration and the rest validation. Then the calibration moves to a
// new robot, whose frames fit on the same shots needs nothing more.
TEST_F(CliTest, UploadAnExportWithJointsAndMoveTheCalibration) {
  const std::string server = "--server " + server_.url();
  const RobotModel model = Preset("ur5e");
  VirtualCellOptions o;
  o.seed = 3;
  o.noise = {0.0, 0.0};
  VirtualCell cell(model, o);
  Rng rng(11);
  std::string text = "n;q1 [rad];q2;q3;q4;q5;q6;X;Y;Z;A [\xB0];B;C\r\n";  // \xB0: the degree sign in Latin-1
  const auto european = [](double v) {
    std::ostringstream s;
    s << std::setprecision(17) << v;
    std::string t = s.str();
    std::replace(t.begin(), t.end(), '.', ',');
    return t;
  };
  for (int k = 0; k < 40; ++k) {
    const Eigen::VectorXd q = RandomConfiguration(model, &rng);
    const Transform pose = cell.TruePose(q);
    // R = Rz(yaw) Ry(pitch) Rx(roll): extrinsic X-Y-Z with the angles (roll, pitch, yaw).
    const Eigen::Vector3d rpy = RpyFromRotation(pose.linear());
    text += std::to_string(k);
    for (int j = 0; j < 6; ++j) text += ";" + european(q[j]);
    for (int j = 0; j < 3; ++j) text += ";" + european(pose.translation()[j]);
    for (int j = 0; j < 3; ++j) text += ";" + european(rpy[j] * 180.0 / M_PI);
    text += "\r\n";
  }
  std::ofstream(Path("export.csv"), std::ios::binary) << text;
  ASSERT_EQ(Trim(RunCli(server + " campaign create ur5e pose --id joints-1").out), "joints-1");
  const InProcess stored = RunInProcess(
      {"--server", server_.url(), "upload", "joints-1", Path("export.csv"), "--format", "csv", "--unit", "mm",
       "--decimal", ",", "--columns", "x=X,y=Y,z=Z", "--joints", "q1 [rad],q2,q3,q4,q5,q6", "--joint-unit", "rad",
       "--orientation-columns", "A [\xC2\xB0],B,C", "--euler", "XYZ", "--euler-convention", "extrinsic",
       "--angle-unit", "deg", "--calibration-rows", "25", "--seed", "4"});
  ASSERT_EQ(stored.exit_code, 0) << stored.err;
  EXPECT_NE(stored.err.find("is not UTF-8: read as Latin-1"), std::string::npos) << stored.err;
  EXPECT_NE(stored.out.find("stored 25 calibration measurements"), std::string::npos) << stored.out;
  EXPECT_NE(stored.out.find("stored 15 validation measurements"), std::string::npos) << stored.out;
  // The exact poses fit to round-off: the joints, units and angles were read right.
  const Result fit = RunCli(server + " --json fit joints-1");
  ASSERT_EQ(fit.exit_code, 0);
  const nlohmann::json calibration = nlohmann::json::parse(fit.out);
  EXPECT_LT(calibration.at("residuals_after").at("rms_position_mm").get<double>(), 1e-6) << fit.out;
  EXPECT_LT(calibration.at("residuals_after").at("rms_orientation_deg").get<double>(), 1e-6) << fit.out;

  // The calibration as a robot of its own, and a frames fit on its shots: nothing left to fit.
  const Result robot = RunCli(server + " robot register --from-calibration joints-1 --id ur5e-cal");
  ASSERT_EQ(robot.exit_code, 0);
  EXPECT_NE(robot.out.find("calibrated from campaign joints-1 (robot ur5e)"), std::string::npos) << robot.out;
  ASSERT_EQ(Trim(RunCli(server + " campaign create ur5e-cal pose --id joints-2").out), "joints-2");
  ASSERT_EQ(RunInProcess({"--server", server_.url(), "upload", "joints-2", Path("export.csv"), "--format", "csv",
                          "--unit", "mm", "--decimal", ",", "--columns", "x=X,y=Y,z=Z", "--joints",
                          "q1 [rad],q2,q3,q4,q5,q6", "--joint-unit", "rad", "--orientation-columns",
                          "A [\xC2\xB0],B,C", "--euler", "XYZ", "--euler-convention", "extrinsic", "--angle-unit",
                          "deg", "--encoding", "latin-1"})
                .exit_code,
            0);
  const Result frames = RunCli(server + " --json fit joints-2 --scope frames");
  ASSERT_EQ(frames.exit_code, 0);
  const nlohmann::json moved = nlohmann::json::parse(frames.out);
  EXPECT_EQ(moved.at("parameters").size(), 12u);
  EXPECT_LT(moved.at("residuals_after").at("rms_position_mm").get<double>(), 1e-6) << frames.out;
  // Usage errors: a joint unit without joints, both orientation forms, a split with a role.
  EXPECT_EQ(RunCli(server + " upload joints-2 " + Path("export.csv") + " --format csv --joint-unit rad").exit_code, 2);
  EXPECT_EQ(RunCli(server + " upload joints-2 " + Path("export.csv") +
                   " --format csv --euler XYZ --quaternion-order wxyz --orientation-columns a,b,c")
                .exit_code,
            2);
  EXPECT_EQ(RunCli(server + " upload joints-2 " + Path("export.csv") +
                   " --format csv --calibration-rows 5 --role validation")
                .exit_code,
            2);
}

// campaign list says which campaigns are calibrated, in its table and as JSON (list items once carried no
// calibrated, and every campaign read as uncalibrated).
TEST_F(CliTest, CampaignListShowsCountsAndCalibrated) {
  const std::string server = "--server " + server_.url();
  const Result plan = RunCli(server + " plan grinder5 --count 8 --seed 5 --json");
  ASSERT_EQ(plan.exit_code, 0);
  const auto configurations =
      nlohmann::json::parse(plan.out).at("configurations").get<std::vector<std::vector<double>>>();
  const std::string calibrated = Trim(RunCli(server + " campaign create grinder5 pose --id cal-1").out);
  const std::string fresh = Trim(RunCli(server + " campaign create grinder5 position --id fresh-1").out);
  ASSERT_EQ(calibrated, "cal-1");
  ASSERT_EQ(fresh, "fresh-1");
  mock::MockTrackerOptions options;
  options.shots_per_pose = 2;
  VirtualCell cell = mock::MakeCell(options);
  std::ofstream(Path("shots.json"))
      << nlohmann::json(mock::MeasurementBatch(&cell, configurations, api::MeasurementRole::kCalibration, options));
  ASSERT_EQ(RunCli(server + " upload cal-1 " + Path("shots.json")).exit_code, 0);
  ASSERT_EQ(RunCli(server + " fit cal-1").exit_code, 0);
  // export: the calibrated robot as a URDF (to a file) or as the calibration's JSON; other formats are usage errors.
  ASSERT_EQ(RunCli(server + " export cal-1 --out " + Path("cal-1.urdf")).exit_code, 0);
  std::stringstream urdf;
  urdf << std::ifstream(Path("cal-1.urdf")).rdbuf();
  EXPECT_NE(urdf.str().find("<link name=\"robocal_tool\"/>"), std::string::npos) << urdf.str();
  EXPECT_NE(urdf.str().find("<robot name=\"grinder5\">"), std::string::npos);
  const Result exported_json = RunCli(server + " export cal-1 --format json");
  EXPECT_EQ(nlohmann::json::parse(exported_json.out).at("campaign"), "cal-1");
  EXPECT_EQ(RunCli(server + " export cal-1 --format dxf").exit_code, 2);
  // The grinder's Z and C axes are one line: the calibration has no DH table, and the service says why.
  const InProcess no_table = RunInProcess({"--server", server_.url(), "export", "cal-1", "--format", "dh"});
  EXPECT_EQ(no_table.exit_code, 1);
  EXPECT_NE(no_table.err.find("joint 'Z' and joint 'C' are"), std::string::npos) << no_table.err;
  // report: the HTML page to a file (-o is --out), its parameter rows the calibration's; refused before a fit
  // (exit 1, nothing written), and a bad --h-mm named.
  const Result report = RunCli(server + " report cal-1 -o " + Path("cal-1.html"));
  ASSERT_EQ(report.exit_code, 0);
  EXPECT_NE(report.out.find("written to " + Path("cal-1.html")), std::string::npos) << report.out;
  std::stringstream page;
  page << std::ifstream(Path("cal-1.html")).rdbuf();
  EXPECT_EQ(page.str().rfind("<!DOCTYPE html>", 0), 0u);
  const nlohmann::json calibration = nlohmann::json::parse(exported_json.out);
  for (const auto& p : calibration.at("parameters")) {
    EXPECT_NE(page.str().find("<tr data-parameter=\"" + p.at("name").get<std::string>() + "\">"), std::string::npos);
  }
  const InProcess early = RunInProcess({"--server", server_.url(), "report", "fresh-1", "--out", Path("fresh-1.html")});
  EXPECT_EQ(early.exit_code, 1);
  EXPECT_NE(early.err.find("FAILED_PRECONDITION"), std::string::npos) << early.err;
  EXPECT_FALSE(std::ifstream(Path("fresh-1.html")).good()) << "a refused report left a file";
  const InProcess bad_h = RunInProcess({"--server", server_.url(), "report", "cal-1", "--h-mm=-5"});
  EXPECT_EQ(bad_h.exit_code, 1);
  EXPECT_NE(bad_h.err.find("h_mm"), std::string::npos) << bad_h.err;
  EXPECT_NE(RunCli("report --help").out.find("Usage: robocal report CAMPAIGN [--out FILE.html] [--h-mm H]"),
            std::string::npos);

  const Result table = RunCli(server + " campaign list");
  ASSERT_EQ(table.exit_code, 0);
  std::istringstream lines(table.out);
  std::string header, first, second;
  std::getline(lines, header);
  std::getline(lines, first);
  std::getline(lines, second);
  for (const char* column : {"campaign", "robot", "type", "calibration", "validation", "calibrated"}) {
    EXPECT_NE(header.find(column), std::string::npos) << column << " in " << header;
  }
  auto words = [](const std::string& line) {
    std::istringstream in(line);
    std::vector<std::string> w;
    for (std::string word; in >> word;) w.push_back(word);
    return w;
  };
  EXPECT_EQ(words(first), (std::vector<std::string>{"cal-1", "grinder5", "pose", "16", "0", "yes"})) << table.out;
  EXPECT_EQ(words(second), (std::vector<std::string>{"fresh-1", "grinder5", "position", "0", "0", "no"}))
      << table.out;

  const Result json = RunCli(server + " campaign list --json");
  ASSERT_EQ(json.exit_code, 0);
  const auto list = api::FromWire<api::CampaignList>(nlohmann::json::parse(json.out));
  ASSERT_EQ(list.campaigns.size(), 2u);
  EXPECT_TRUE(list.campaigns[0].calibrated);
  EXPECT_EQ(list.campaigns[0].counts.calibration, 16);
  EXPECT_FALSE(list.campaigns[1].calibrated);
  // Each item is the campaign as campaign get --json prints it.
  EXPECT_EQ(nlohmann::json(list.campaigns[0]), nlohmann::json::parse(RunCli(server + " campaign get cal-1 --json").out));
}

// A URScript program of a calibrated ur5e through `robocal compensate-program`: one file to stdout with the report
// on stderr, or --out DIR; every byte but the targets' numbers as it was; bad arguments as usage errors.
TEST_F(CliTest, CompensateProgramGivesTheProgramBackCompensated) {
  client::ClientOptions client_options;
  client_options.server_url = server_.url();
  client::Client client(client_options);
  mock::MockTrackerOptions options;
  options.robot = "ur5e";
  options.count = 24;
  options.num_validation = 4;
  options.shots_per_pose = 1;
  const mock::MockTrackerReport report = mock::RunMockTracker(client, options, nullptr);
  const std::string campaign = report.trials.at(0).planned.campaign.id;
  // Two joint moves and a straight move to the pose of the second (metres, rotation vector).
  const RobotModel ur5e = Preset("ur5e");
  Eigen::VectorXd q(6);
  q << 0.4, -1.2, 1.3, -1.7, 1.4, 0.3;
  const Transform pose = ur5e.T_world_base().inverse() * ForwardKinematics(ur5e, q);
  const Eigen::Vector3d r = RotationVector(pose.linear());
  std::ostringstream script;
  script << std::fixed << std::setprecision(6) << "def cell():\r\n  # taught\r\n  movej([0.1, -1.5, 1.4, -1.4, 1.5, 0.0], a=1.4, v=1.05)\r\n"
         << "  movej([" << q[0] << ", " << q[1] << ", " << q[2] << ", " << q[3] << ", " << q[4] << ", " << q[5]
         << "])\n  movel(p[" << pose.translation().x() / 1000 << ", " << pose.translation().y() / 1000 << ", "
         << pose.translation().z() / 1000 << ", " << r.x() << ", " << r.y() << ", " << r.z() << "], a=1.2, v=0.25)\nend\n";
  std::ofstream(Path("cell.script"), std::ios::binary) << script.str();

  const InProcess piped = RunInProcess({"--server", server_.url(), "compensate-program", campaign, Path("cell.script")});
  ASSERT_EQ(piped.exit_code, 0) << piped.err;
  EXPECT_NE(piped.out, script.str());
  // The same lines, comments and line ends; only numbers changed.
  auto shape = [](const std::string& text) {
    std::string out;
    for (char c : text) out += (c >= '0' && c <= '9') || c == '.' || c == '-' ? '#' : c;
    std::string squeezed;
    for (char c : out) if (c != '#' || squeezed.empty() || squeezed.back() != '#') squeezed += c;
    return squeezed;
  };
  EXPECT_EQ(shape(piped.out), shape(script.str()));
  EXPECT_NE(piped.err.find("urscript: 3 targets (2 joint, 1 Cartesian), 3 rewritten, 0 kept as written"),
            std::string::npos) << piped.err;

  const Result written = RunCli("--server " + server_.url() + " compensate-program " + campaign + " " +
                                Path("cell.script") + " --out " + Path("out") + " --max-path-deviation 0.01");
  ASSERT_EQ(written.exit_code, 0);
  EXPECT_NE(written.out.find("cell.script:5  (inline)  cartesian"), std::string::npos) << written.out;
  std::ifstream in(Path("out/cell.script"), std::ios::binary);
  const std::string file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(file.substr(0, 20), "def cell():\r\n  # tau");

  const Result json = RunCli("--server " + server_.url() + " compensate-program " + campaign + " " +
                             Path("cell.script") + " --json");
  ASSERT_EQ(json.exit_code, 0);
  const auto reply = api::FromWire<api::CompensateProgramResult>(nlohmann::json::parse(json.out));
  EXPECT_EQ(reply.files.at("cell.script"), piped.out);
  ASSERT_EQ(reply.targets.size(), 3u);
  EXPECT_EQ(reply.targets[2].kind, programs::TargetKind::kCartesian);

  // Usage errors: several files without --out, an unknown dialect; a malformed number is the service's 400.
  std::ofstream(Path("b.script")) << "movej([0, 0, 0, 0, 0, 0])\n";
  EXPECT_EQ(RunCli("--server " + server_.url() + " compensate-program " + campaign + " " + Path("cell.script") + " " +
                   Path("b.script")).exit_code, 2);
  EXPECT_EQ(RunCli("--server " + server_.url() + " compensate-program " + campaign + " " + Path("b.script") +
                   " --dialect cobol").exit_code, 2);
  std::ofstream(Path("bad.script")) << "# x\nmovej([0, 0.1.2, 0, 0, 0, 0])\n";
  const InProcess bad = RunInProcess({"--server", server_.url(), "compensate-program", campaign, Path("bad.script")});
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("line 2, column"), std::string::npos) << bad.err;
}

TEST_F(CliTest, TokenFromFlag) {
  testing::TestServer secured({"t0ken"});
  EXPECT_EQ(RunCli("--server " + secured.url() + " robots").exit_code, 1);
  EXPECT_EQ(RunCli("--server " + secured.url() + " --token t0ken robots").exit_code, 0);
}

}  // namespace
}  // namespace robocal
