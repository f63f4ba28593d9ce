// robocal-mock-tracker: a simulated robot and laser tracker driving the calibration service end to end.
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <limits>
#include <string>
#include <vector>

#include "flags.h"
#include "mock_tracker.h"
#include "robocal/api/plans.h"
#include "robocal/client/csv.h"

namespace {

using nlohmann::json;

// Where a calibration dump's --random configurations are drawn from: apart from the validation poses of the
// same seed.
constexpr std::uint64_t kCalibrationDumpSeedOffset = 15485863;

constexpr const char* kUsage = R"(Usage: robocal-mock-tracker [options]

Simulates a robot with hidden geometric errors and a laser tracker measuring it (seeded, reproducible), and
drives the robocal service through the whole calibration: request a plan, create a campaign, move the robot
to each planned configuration and measure it, upload, fit, then measure validation poses reached with nominal
and with compensated joint commands, and print the paper's accuracy table (E_xyz, E_cos, E_tot: mean, std,
max, RP = mean + 3 std; before and after calibration).

Options:
  --server URL          service URL (default $ROBOCAL_SERVER or http://127.0.0.1:8080)
  --token TOKEN         bearer token (default $ROBOCAL_TOKEN)
  --robot NAME          preset robot: grinder5, puma560, ur5e (default grinder5)
  --count M             planned configurations (default 10)
  --type TYPE           pose, position_axis or position (default pose)
  --optimiser NAME      solis_wets, exchange or random (default solis_wets)
  --objective NAME      condition_number, o1..o5, log_det (default condition_number)
  --seed N              seeds the cell's hidden errors, tracker placement and noise, the plan and the
                        validation poses (default 1)
  --shots N             tracker shots per planned pose (default 10)
  --validation N        random validation poses within the joint limits (default 36)
  --h-mm H              E_tot = E_xyz + H * E_cos[rad] (default 30)
  --compare random      also calibrate from random configurations and print the improvement in percent
  --cell CELL|preset    measure in a cell: the id of a cell on the server, or "preset" for the robot's preset
                        cell (created as preset-<robot> if absent). Plans are made in it, the tracker
                        measures only the poses it can see, and the report says how many it could not
  --realistic           the realistic cell: the robot's preset cell (unless --cell names another), the
                        tracker's datasheet uncertainty model (radial 10 um + 0.3 um/m, transverse 15 um +
                        6 um/m MPE) and 0.03 mm robot repeatability (both sent with the plan and campaign),
                        and 2 % outliers of 1-5 mm; the report says how many outliers the fit excluded;
                        with --type position, three reflector nests unless --reflectors says otherwise
  --outliers RATE       share of shots made outliers, 0..0.5 (default 0, or 0.02 with --realistic)
  --outlier-size MIN,MAX
                        an outlier's size, mm, uniform in [MIN, MAX] in a random direction (default 1,5)
  --reflectors N        reflector nests on the tool, 0..3 (needs --type position): each pose shoots every
                        one and the campaign lists them, at positions measured on the tool plate (fixed:
                        the fit calibrates the tool point through them) (default 0: the tool point, or 3
                        with --realistic --type position)
  --free-nests          the nests' positions are known only roughly: the cell hides an offset error of
                        each, the fit identifies it, and the tool point keeps its nominal place on the
                        flange (the landing check at the tool point then shows the tool's own error)
  --trials N            independent trials, each a new cell (hidden errors, tracker, noise) and new plans
                        from seed + trial; validation errors pooled (default 1; one trial of 10
                        configurations is a noisy comparison)
  --json                print the report as JSON instead of tables
  --dump-measurements FILE
                        offline: write the measurement batch the cell would upload (request body of
                        POST /v1/campaigns/{c}/measurements) to FILE ('-' for stdout) and exit; needs
                        --configurations FILE (a plan JSON as GET /v1/plans/{plan} returns it, or a joints
                        CSV) or --random N; --role calibration|validation (default calibration). An ISO
                        9283 test plan's configurations are test shots: one per visit, each tagged with
                        its test_pose and cycle (docs/iso9283.md)
  --help                this text

Exit codes: 0 calibration improved accuracy, 1 service error, 2 usage error, 3 connection failure,
4 calibration did not improve accuracy.
)";

int Usage(const std::string& message) {
  std::cerr << "robocal-mock-tracker: " << message << "\n(see robocal-mock-tracker --help)\n";
  return 2;
}

// The value of an enum flag by its wire name ("--type pose").
template <typename E>
E EnumFlag(const std::string& flag, const std::string& text) {
  E value{};
  if (robocal::api::FromWireName(text, &value)) return value;
  std::string names;
  for (const std::string& n : robocal::api::WireNames<E>()) names += (names.empty() ? "" : ", ") + n;
  throw robocal::tools::BadFlag(flag + ": '" + text + "' is not one of " + names);
}

int Dump(const robocal::mock::MockTrackerOptions& options, const std::string& file, const std::string& configurations,
         int random, robocal::api::MeasurementRole role) {
  robocal::VirtualCell cell = robocal::mock::MakeCell(options);
  // A validation dump is another visit to the same robot: new noise, not the calibration dump's draws.
  if (role == robocal::api::MeasurementRole::kValidation) cell.StartNoiseStream(1);
  const robocal::RobotModel& model = cell.nominal();
  std::vector<std::vector<double>> wire;
  std::vector<robocal::api::TestTagWire> tags;
  if (!configurations.empty()) {
    std::ifstream in(configurations);
    if (!in) return Usage("cannot read " + configurations);
    if (configurations.size() > 4 && configurations.substr(configurations.size() - 4) == ".csv") {
      wire = robocal::client::ReadJointsCsv(in, model.num_joints());
    } else {
      try {
        const auto plan = robocal::api::FromWire<robocal::api::PlanResult>(json::parse(in));
        wire = plan.configurations;
        // An ISO 9283 test plan: its visits are test shots, each tagged with its pose and cycle.
        if (plan.test) {
          tags = plan.test->tags;
          role = robocal::api::MeasurementRole::kTest;
          cell.StartNoiseStream(2);
        }
      } catch (const std::exception& e) {  // not JSON, or not a plan (api::WireError names the field)
        return Usage(configurations + ": not a plan as GET /v1/plans/{plan} returns it: " + e.what());
      }
    }
  } else {
    robocal::mock::MockTrackerOptions o = options;
    o.num_validation = random;
    // A calibration dump draws its configurations apart from the validation poses of the same seed (which
    // RunMockTracker and a validation dump use), so that a fit is never judged on its own poses.
    if (role == robocal::api::MeasurementRole::kCalibration) o.seed += kCalibrationDumpSeedOffset;
    for (const auto& q : robocal::mock::ValidationConfigurations(cell, o)) {
      wire.push_back(robocal::api::JointsToWire(model, q));
    }
  }
  if (role == robocal::api::MeasurementRole::kTest && tags.empty()) {
    return Usage("--role test takes the shots of an ISO 9283 test plan: give it with --configurations PLAN.json");
  }
  const json batch = robocal::mock::MeasurementBatch(&cell, wire, role, options, tags);
  if (file == "-") {
    std::cout << batch.dump() << "\n";
  } else {
    std::ofstream out(file);
    out << batch.dump() << "\n";
    if (!out) {
      std::cerr << "robocal-mock-tracker: cannot write " << file << "\n";
      return 1;
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  robocal::mock::MockTrackerOptions options;
  robocal::client::ClientOptions client_options;
  if (const char* s = std::getenv("ROBOCAL_SERVER")) client_options.server_url = s;
  if (const char* t = std::getenv("ROBOCAL_TOKEN")) client_options.bearer_token = t;
  bool as_json = false;
  std::string dump_file, configurations;
  robocal::api::MeasurementRole role = robocal::api::MeasurementRole::kCalibration;
  int random = 0;
  bool role_given = false;

  std::vector<std::string> args(argv + 1, argv + argc);
  for (std::string& a : args) {
    if (a == "-h") a = "--help";
  }
  namespace tools = robocal::tools;
  // Ranges are MockTrackerOptions::IsValid's, checked below with its messages.
  auto integer = [](const std::string& flag, const std::string& v) {
    return static_cast<int>(
        tools::ParseIntegerFlag(flag, v, std::numeric_limits<int>::min(), std::numeric_limits<int>::max()));
  };
  try {
    for (const auto& [flag, v] : tools::SplitFlags(args, {"--json", "--help", "--realistic", "--free-nests"})) {
      if (flag == "--help") {
        std::cout << kUsage;
        return 0;
      } else if (flag == "--json") {
        as_json = true;
      } else if (flag == "--server") {
        client_options.server_url = v;
      } else if (flag == "--token") {
        client_options.bearer_token = v;
      } else if (flag == "--robot") {
        options.robot = v;
      } else if (flag == "--count") {
        options.count = integer(flag, v);
      } else if (flag == "--type") {
        options.measurement_type = EnumFlag<robocal::MeasurementType>(flag, v);
      } else if (flag == "--optimiser") {
        options.optimiser = EnumFlag<robocal::api::Optimiser>(flag, v);
      } else if (flag == "--objective") {
        options.objective = EnumFlag<robocal::ObservabilityIndex>(flag, v);
      } else if (flag == "--seed") {
        options.seed = tools::ParseSeedFlag(flag, v);
      } else if (flag == "--shots") {
        options.shots_per_pose = integer(flag, v);
      } else if (flag == "--cell") {
        if (v.empty()) return Usage("--cell takes a cell id or 'preset'");
        options.cell = v;
      } else if (flag == "--realistic") {
        options.realistic = true;
      } else if (flag == "--reflectors") {
        options.reflectors = integer(flag, v);
      } else if (flag == "--free-nests") {
        options.free_nests = true;
      } else if (flag == "--outliers") {
        options.outlier_rate = tools::ParseDoubleFlag(flag, v, std::numeric_limits<double>::lowest());
      } else if (flag == "--outlier-size") {
        const std::vector<std::string> range = tools::SplitList(flag, v);
        if (range.size() != 2) return Usage("--outlier-size takes MIN,MAX (mm)");
        options.outlier_size_mm = {tools::ParseDoubleFlag(flag, range[0], std::numeric_limits<double>::lowest()),
                                   tools::ParseDoubleFlag(flag, range[1], std::numeric_limits<double>::lowest())};
      } else if (flag == "--trials") {
        options.trials = integer(flag, v);
      } else if (flag == "--validation") {
        options.num_validation = integer(flag, v);
      } else if (flag == "--h-mm") {
        options.h_mm = tools::ParseDoubleFlag(flag, v, std::numeric_limits<double>::lowest());
      } else if (flag == "--compare") {
        if (v != "random") return Usage("--compare takes 'random'");
        options.compare_random = true;
      } else if (flag == "--dump-measurements") {
        dump_file = v;
      } else if (flag == "--configurations") {
        configurations = v;
      } else if (flag == "--random") {
        random = static_cast<int>(tools::ParseIntegerFlag(flag, v, 1, std::numeric_limits<int>::max()));
      } else if (flag == "--role") {
        role = EnumFlag<robocal::api::MeasurementRole>(flag, v);
        role_given = true;
      } else {
        return Usage("unknown option " + flag);
      }
    }
  } catch (const robocal::tools::BadFlag& e) {
    return Usage(e.what());
  }
  // The realistic cell measures in the robot's preset cell unless another cell is named.
  if (options.realistic && options.cell.empty()) options.cell = "preset";
  std::string error;
  if (!options.IsValid(&error)) return Usage(error);

  try {
    if (dump_file.empty() && (role_given || random > 0 || !configurations.empty())) {
      return Usage("--role, --random and --configurations belong to --dump-measurements");
    }
    if (!dump_file.empty()) {
      if (configurations.empty() == (random == 0)) {
        return Usage("--dump-measurements needs exactly one of --configurations FILE or --random N");
      }
      return Dump(options, dump_file, configurations, random, role);
    }
    if (!client_options.IsValid(&error)) return Usage(error);
    robocal::Client client(client_options);
    const auto report = robocal::mock::RunMockTracker(client, options, &std::cerr);
    if (as_json) {
      std::cout << robocal::mock::ReportToJson(report).dump(2) << "\n";
    } else {
      std::cout << robocal::mock::FormatReport(report, options);
    }
    return report.improved ? 0 : 4;
  } catch (const robocal::client::ServiceError& e) {
    std::cerr << "robocal-mock-tracker: service error: " << e.what() << "\n";
    return 1;
  } catch (const robocal::client::ConnectionError& e) {
    std::cerr << "robocal-mock-tracker: " << e.what() << "\n";
    return 3;
  } catch (const std::exception& e) {
    std::cerr << "robocal-mock-tracker: " << e.what() << "\n";
    return 1;
  }
}
