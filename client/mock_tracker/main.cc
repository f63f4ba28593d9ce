// robocal-mock-tracker: a simulated robot and laser tracker driving the calibration service end to end.
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "mock_tracker.h"
#include "robocal/api/convert.h"
#include "robocal/client/csv.h"

namespace {

using nlohmann::json;

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
  --trials N            independent trials, each a new cell (hidden errors, tracker, noise) and new plans
                        from seed + trial; validation errors pooled (default 1; one trial of 10
                        configurations is a noisy comparison)
  --json                print the report as JSON instead of tables
  --dump-measurements FILE
                        offline: write the measurement batch the cell would upload (request body of
                        POST /v1/campaigns/{c}/measurements) to FILE ('-' for stdout) and exit; needs
                        --configurations FILE (a plan JSON as GET /v1/plans/{plan} returns it, or a joints
                        CSV) or --random N; --role calibration|validation (default calibration)
  --help                this text

Exit codes: 0 calibration improved accuracy, 1 service error, 2 usage error, 3 connection failure,
4 calibration did not improve accuracy.
)";

int Usage(const std::string& message) {
  std::cerr << "robocal-mock-tracker: " << message << "\n(see robocal-mock-tracker --help)\n";
  return 2;
}

bool ParseInt(const std::string& text, long long* out) {
  try {
    std::size_t used = 0;
    *out = std::stoll(text, &used);
    return used == text.size();
  } catch (const std::exception&) {
    return false;
  }
}

int Dump(const robocal::mock::MockTrackerOptions& options, const std::string& file, const std::string& configurations,
         int random, const std::string& role) {
  robocal::VirtualCell cell = robocal::mock::MakeCell(options);
  const robocal::RobotModel& model = cell.nominal();
  std::vector<std::vector<double>> wire;
  if (!configurations.empty()) {
    std::ifstream in(configurations);
    if (!in) return Usage("cannot read " + configurations);
    if (configurations.size() > 4 && configurations.substr(configurations.size() - 4) == ".csv") {
      wire = robocal::client::ReadJointsCsv(in, model.num_joints());
    } else {
      const json plan = json::parse(in);
      wire = plan.at("configurations").get<std::vector<std::vector<double>>>();
    }
  } else {
    robocal::mock::MockTrackerOptions o = options;
    o.num_validation = random;
    for (const auto& q : robocal::mock::ValidationConfigurations(model, o)) {
      wire.push_back(robocal::api::JointsToWire(model, q));
    }
  }
  const json batch = robocal::mock::MeasurementBatch(&cell, wire, role, options);
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
  std::string dump_file, configurations, role = "calibration";
  int random = 0;

  std::vector<std::string> args(argv + 1, argv + argc);
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--help" || a == "-h") {
      std::cout << kUsage;
      return 0;
    }
    if (a == "--json") {
      as_json = true;
      continue;
    }
    if (i + 1 >= args.size()) return Usage("unknown option or missing value: " + a);
    const std::string v = args[++i];
    long long n = 0;
    const bool is_int = ParseInt(v, &n);
    if (a == "--server") {
      client_options.server_url = v;
    } else if (a == "--token") {
      client_options.bearer_token = v;
    } else if (a == "--robot") {
      options.robot = v;
    } else if (a == "--count" && is_int) {
      options.count = static_cast<int>(n);
    } else if (a == "--type") {
      options.measurement_type = v;
    } else if (a == "--optimiser") {
      options.optimiser = v;
    } else if (a == "--objective") {
      options.objective = v;
    } else if (a == "--seed" && is_int && n >= 0) {
      options.seed = static_cast<std::uint64_t>(n);
    } else if (a == "--shots" && is_int) {
      options.shots_per_pose = static_cast<int>(n);
    } else if (a == "--trials" && is_int) {
      options.trials = static_cast<int>(n);
    } else if (a == "--validation" && is_int) {
      options.num_validation = static_cast<int>(n);
    } else if (a == "--h-mm") {
      try {
        options.h_mm = std::stod(v);
      } catch (const std::exception&) {
        return Usage("--h-mm needs a number");
      }
    } else if (a == "--compare") {
      if (v != "random") return Usage("--compare takes 'random'");
      options.compare_random = true;
    } else if (a == "--dump-measurements") {
      dump_file = v;
    } else if (a == "--configurations") {
      configurations = v;
    } else if (a == "--random" && is_int && n > 0) {
      random = static_cast<int>(n);
    } else if (a == "--role") {
      if (v != "calibration" && v != "validation") return Usage("--role is calibration or validation");
      role = v;
    } else {
      return Usage("unknown option or bad value: " + a + " " + v);
    }
  }
  std::string error;
  if (!options.IsValid(&error)) return Usage(error);

  try {
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
