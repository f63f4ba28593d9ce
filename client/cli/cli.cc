// The `robocal` subcommands over robocal::Client.
#include "cli.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <numbers>
#include <set>
#include <sstream>

#include "experiment_flags.h"
#include "robocal/api/convert.h"
#include "robocal/client/client.h"
#include "robocal/client/csv.h"
#include "robocal/core/accuracy.h"
#include "robocal/core/experiment.h"

namespace robocal::cli {
namespace {

using client::Client;
using nlohmann::json;

constexpr const char* kMainHelp = R"(Usage: robocal [global options] COMMAND [arguments] [options]

Command line client of the robocal calibration service. Wire units: mm and degrees (revolute joints in
degrees, prismatic joints in mm).

Commands:
  robots                         list preset and registered robots
  robot register FILE.json       register a robot model (DH / MDH / transform table; see the API docs)
  robot get ROBOT | robot delete ROBOT
  robot forward ROBOT IN.csv     nominal tool poses for joint vectors (CSV in, CSV out)
  plan ROBOT [options]           optimal measurement configurations (see robocal plan --help)
  plan get PLAN                  a stored plan (configurations and indices; --out FILE.csv|FILE.json)
  campaign create ROBOT TYPE     create a calibration campaign (TYPE: pose, position_axis, position)
  campaign list | campaign get CAMPAIGN
  campaign forward CAMPAIGN IN.csv
                                 tool poses of the calibrated robot (tracker frame), CSV in, CSV out
  upload CAMPAIGN FILE           upload tracker measurements (CSV or JSON)
  measurements CAMPAIGN          the stored measurements as CSV (the upload format) or JSON
  fit CAMPAIGN                   identify the parameters; prints the parameter table
  compensate CAMPAIGN IN.csv     compensated joints for nominal joint commands (CSV in, CSV out)
  evaluate CAMPAIGN              the accuracy table (E_xyz, E_cos, E_tot) on the validation measurements
  operation wait|get|cancel ID   long-running operations (async plans and fits); wait draws progress on stderr
  experiment [options]           the paper's simulated experiment, run locally (no server; see --help)

Global options (anywhere on the line):
  --server URL    service URL (default $ROBOCAL_SERVER, else http://127.0.0.1:8080)
  --token TOKEN   bearer token (default $ROBOCAL_TOKEN)
  --ca-cert FILE  https: trust the certificate authorities in FILE (PEM; default $ROBOCAL_CA_CERT, else the
                  system's), e.g. a lab server's self-signed certificate itself
  --insecure      https: do NOT verify the server's certificate. Anyone on the network path can then pose as
                  the server and read the token. Only for a first test against a self-signed lab server;
                  use --ca-cert instead.
  --json          print the service's JSON response instead of tables (for scripts)
  --help          help for robocal or for a command (robocal plan --help)

Exit codes: 0 ok, 1 service error (HTTP 4xx/5xx; the error's status, message and fields go to stderr),
2 usage error, 3 connection failure.
)";

constexpr const char* kRobotsHelp = R"(Usage: robocal robots

Lists the preset and registered robots: id, number of joints, description. --json: GET /v1/robots as is.
)";

constexpr const char* kPlanHelp = R"(Usage: robocal plan ROBOT [options]
       robocal plan get PLAN [--out FILE.csv|FILE.json]

Asks the service for M measurement configurations that make the calibration well conditioned, and prints
them (one row per configuration, in the joints' units) with their observability indices and predicted
accuracy against a random set of the same size.

Options:
  --count M            configurations (default 10)
  --type TYPE          pose, position_axis or position (default pose)
  --objective NAME     condition_number, o1, o2, o3, o4, o5, log_det (default condition_number)
  --optimiser NAME     solis_wets, random or exchange (default solis_wets)
  --seed N             seed of the search (default 1); the same seed gives the same plan
  --async              run as a long-running operation and wait for it with a progress bar on stderr
  --out FILE           also write the configurations: FILE.csv (joints CSV) or FILE.json (the plan)

plan get: prints a stored plan as above (GET /v1/plans/{plan}); --out writes it like a new one.
)";

constexpr const char* kRobotHelp = R"(Usage: robocal robot register FILE.json | robot get ROBOT | robot delete ROBOT
       robocal robot forward ROBOT IN.csv [--out OUT.csv]

register: FILE.json is the body of POST /v1/robots, e.g.
  {"id": "cell7", "from_preset": "ur5e", "tool": {"position_mm": [0, 0, 120], "rpy_deg": [0, 0, 0]}}
or a full table: {"id": ..., "convention": "dh"|"mdh"|"transform", "joints": [...], "base": ..., "tool": ...}.

forward: IN.csv is a joints CSV (header, one row per configuration, degrees / mm); writes the nominal model's
tool poses (world frame: the nominal base) as the joint columns, x_mm,y_mm,z_mm,qw,qx,qy,qz to OUT.csv or
stdout.
)";

constexpr const char* kCampaignHelp =
    R"(Usage: robocal campaign create ROBOT TYPE [--plan PLAN] [--id ID] [--description TEXT]
       robocal campaign list
       robocal campaign get CAMPAIGN
       robocal campaign forward CAMPAIGN IN.csv [--out OUT.csv]

create: TYPE is pose, position_axis or position (what the tracker measures). --plan links a plan (same robot).
Prints the campaign id.
forward: IN.csv is a joints CSV; writes the calibrated robot's tool poses in the tracker frame (the joint
columns, then x_mm,y_mm,z_mm,qw,qx,qy,qz) to OUT.csv or stdout. Needs a fit.
)";

constexpr const char* kMeasurementsHelp =
    R"(Usage: robocal measurements CAMPAIGN [--role calibration|validation] [--after SEQ] [--limit N] [--out FILE.csv]

The campaign's stored measurements in upload order, as the measurement CSV that `robocal upload` reads (the
joint columns, x_mm,y_mm,z_mm, and qw,qx,qy,qz unless the campaign measures position only), to FILE.csv or
stdout. --role: only one role (default both); --after: continue after that sequence number; --limit: at most
N measurements (default all). --json: {"measurements": [...]} with sequence, batch and role of each.
)";

constexpr const char* kUploadHelp =
    R"(Usage: robocal upload CAMPAIGN FILE [--role calibration|validation] [--request-id ID]

FILE is CSV (*.csv) or JSON. CSV: a header, then one row per tracker shot: the joint columns (degrees for
revolute, mm for prismatic joints, in joint order), x_mm,y_mm,z_mm (tool position, tracker frame) and
qw,qx,qy,qz (tool orientation; may be left out for position campaigns). JSON: a batch
{"request_id": ..., "role": ..., "measurements": [{"joints": [...], "pose": {...}}]}, or just the array.
The upload is atomic and idempotent: the same request id with the same content is stored once, so a repeated
upload is safe. Without --request-id (and none in the JSON) it is derived from the content.
--role defaults to calibration (or the JSON's role).
)";

constexpr const char* kFitHelp =
    R"(Usage: robocal fit CAMPAIGN [--parameters a,b,...] [--no-register-base] [--max-iterations N] [--async]

Identifies the error parameters from the calibration measurements and prints them (value and standard
deviation, mm or degrees), the parameters left out as unidentifiable and why, and the residuals before and after.
The fit is stored as the campaign's calibration, unless it stopped at the service's request deadline or was
cancelled: then it is printed with "NOT stored".

  --async              run as a long-running operation and wait for it with a progress bar on stderr
                       (robocal operation cancel ID stops it; a cancelled fit is not stored)
)";

constexpr const char* kCompensateHelp = R"(Usage: robocal compensate CAMPAIGN IN.csv [--out OUT.csv]

IN.csv: nominal joint commands (a joints CSV: header, one row per configuration, degrees / mm). Writes the
compensated joints that take the calibrated robot where the nominal model says the command goes, with
position_error_mm, orientation_error_deg and converged (0/1) columns, to OUT.csv or stdout.
)";

constexpr const char* kEvaluateHelp = R"(Usage: robocal evaluate CAMPAIGN [--h-mm H]

The paper's accuracy table on the campaign's validation measurements, nominal model against calibrated
model: E_xyz (position, um), E_cos (tool axis angle, urad shown as um at 1 m), E_tot = E_xyz + H E_cos;
mean, std, max and RP = mean + 3 std. H defaults to 30 mm.
)";

constexpr const char* kExperimentHelp = R"(Usage: robocal experiment [options]

The paper's simulated experiment, run locally by the calibration core (no server involved): per trial, a
robot with new hidden geometric errors; M configurations planned by Solis & Wets, by random selection and by
exchange; each plan measured by a simulated laser tracker and identified; then random validation poses
compensated on each calibration. Prints E_xyz, E_cos and E_tot (mean, std, max, RP = mean + 3 std) before and
after calibration per method, and the improvement over random selection. Progress goes to stderr. --json
prints the pooled results as JSON. The same flags as robocal-experiment:

)";

constexpr const char* kOperationHelp = R"(Usage: robocal operation wait ID | operation get ID | operation cancel ID

wait: polls until the operation is done, drawing progress on stderr; exit 1 if it failed.
)";

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Options that take a value; everything else starting with "--" is a flag.
const std::set<std::string> kValueOptions = {"--server",         "--token", "--count",      "--type",   "--objective",
                                             "--optimiser",      "--seed",  "--out",        "--plan",   "--id",
                                             "--description",    "--role",  "--request-id", "--h-mm",   "--parameters",
                                             "--max-iterations", "--limit", "--after",      "--ca-cert"};
const std::set<std::string> kFlags = {"--json", "--async", "--help", "--no-register-base", "--insecure"};

struct Args {
  std::vector<std::string> positional;
  /// `experiment`: its flags, left to the experiment's own parser.
  std::vector<std::string> experiment_flags;
  std::map<std::string, std::string> options;
  std::set<std::string> flags;

  bool Flag(const std::string& name) const { return flags.count(name) > 0; }
  std::string Option(const std::string& name, const std::string& fallback = "") const {
    const auto it = options.find(name);
    return it == options.end() ? fallback : it->second;
  }
  long long Int(const std::string& name, long long fallback, long long min, long long max) const {
    const auto it = options.find(name);
    if (it == options.end()) return fallback;
    try {
      std::size_t used = 0;
      const long long v = std::stoll(it->second, &used);
      if (used == it->second.size() && v >= min && v <= max) return v;
    } catch (const std::exception&) {
    }
    throw UsageError(name + " needs an integer in [" + std::to_string(min) + ", " + std::to_string(max) + "]");
  }
  double Number(const std::string& name, double fallback) const {
    const auto it = options.find(name);
    if (it == options.end()) return fallback;
    try {
      std::size_t used = 0;
      const double v = std::stod(it->second, &used);
      if (used == it->second.size() && std::isfinite(v)) return v;
    } catch (const std::exception&) {
    }
    throw UsageError(name + " needs a number");
  }
};

Args ParseArgs(const std::vector<std::string>& raw) {
  Args args;
  for (std::size_t i = 0; i < raw.size(); ++i) {
    const std::string& a = raw[i];
    const bool experiment = !args.positional.empty() && args.positional[0] == "experiment";
    const std::string name = a.substr(0, a.find('='));
    if (experiment && a != "-h" && !kFlags.count(name) && name != "--server" && name != "--token" &&
        name != "--ca-cert") {
      args.experiment_flags.push_back(a);  // the global options above stay global
    } else if (a == "-h") {
      args.flags.insert("--help");
    } else if (a.rfind("--", 0) == 0 && a.size() > 2) {
      const auto eq = a.find('=');
      const std::string name = a.substr(0, eq);
      if (kFlags.count(name)) {
        args.flags.insert(name);
      } else if (kValueOptions.count(name)) {
        if (eq != std::string::npos) {
          args.options[name] = a.substr(eq + 1);
        } else if (i + 1 < raw.size()) {
          args.options[name] = raw[++i];
        } else {
          throw UsageError(name + " needs a value");
        }
      } else {
        throw UsageError("unknown option " + a);
      }
    } else {
      args.positional.push_back(a);
    }
  }
  return args;
}

void Expect(const Args& args, std::size_t count, const char* usage) {
  if (args.positional.size() != count) throw UsageError(std::string("expected: ") + usage);
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw UsageError("cannot read " + path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

bool EndsWith(const std::string& text, const std::string& suffix) {
  return text.size() >= suffix.size() && text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string Fixed(double v, int digits) {
  if (!std::isfinite(v)) return "-";
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

void ProgressBar(std::ostream& err, const client::Operation& op) {
  const int width = 30;
  const int filled = static_cast<int>(std::lround(std::clamp(op.progress, 0.0, 1.0) * width));
  err << "\r" << op.id << " [" << std::string(filled, '#') << std::string(width - filled, ' ') << "] " << std::setw(3)
      << std::lround(op.progress * 100) << "% " << op.state << std::flush;
}

// Waits for operation `id`, drawing its progress bar on err, and ends the bar's line.
client::Operation WaitWithProgress(Client& c, const std::string& id, std::ostream& err) {
  const client::Operation done = c.WaitOperation(id, [&err](const client::Operation& op) {
    ProgressBar(err, op);
    return true;
  });
  err << "\n";
  return done;
}

// An async plan or fit that ended without its result: says why on err; the command's exit code.
int ReportUnfinished(const client::Operation& done, std::ostream& err) {
  const std::string message = done.error ? done.error->status + ": " + done.error->message : done.state;
  err << "robocal: operation " << done.id << " " << done.state << ": " << message << "\n";
  return kExitServiceError;
}

void PrintPlan(const client::PlanResult& plan, std::ostream& out) {
  out << "plan " << plan.id << "  robot " << plan.robot << "  " << plan.configurations.size() << " "
      << plan.measurement_type << " configurations  (" << plan.optimiser << ", objective " << plan.objective << ")\n";
  out << std::setw(4) << "#";
  for (std::size_t j = 0; j < plan.joint_units.size(); ++j) {
    out << std::setw(12) << ("q" + std::to_string(j + 1) + "[" + plan.joint_units[j] + "]");
  }
  out << "\n";
  for (std::size_t i = 0; i < plan.configurations.size(); ++i) {
    out << std::setw(4) << i + 1;
    for (double v : plan.configurations[i]) out << std::setw(12) << Fixed(v, 3);
    out << "\n";
  }
  auto indices = [&](const char* label, const client::Indices& x, const client::PredictedAccuracy& a) {
    out << std::left << std::setw(10) << label << std::right << "  cond " << std::setw(10)
        << Fixed(x.condition_number, 2) << "  O1 " << std::setw(10) << Fixed(x.o1, 4) << "  O2 " << std::setw(10)
        << Fixed(x.o2, 4) << "  O3 " << std::setw(10) << Fixed(x.o3, 6) << "  O4 " << std::setw(10) << Fixed(x.o4, 6)
        << "  O5 " << std::setw(10) << Fixed(x.o5, 4) << "  predicted rms " << Fixed(a.rms_position_mm, 4) << " mm\n";
  };
  indices("plan", plan.indices, plan.predicted_accuracy);
  indices("random", plan.baseline_indices, plan.baseline_predicted_accuracy);
  out << plan.identifiable_parameters.size() << " identifiable parameters; " << plan.summary << "\n";
}

void PrintCalibration(const client::CalibrationResult& c, std::ostream& out) {
  out << std::left << std::setw(14) << "parameter" << std::right << std::setw(14) << "value" << std::setw(14) << "std"
      << "  unit\n";
  for (const auto& p : c.parameters) {
    out << std::left << std::setw(14) << p.name << std::right << std::setw(14) << Fixed(p.value, 5) << std::setw(14)
        << Fixed(p.std, 5) << "  " << p.unit << "\n";
  }
  if (!c.dropped.empty()) {
    out << "not identifiable (left out):\n";
    for (const auto& d : c.dropped) out << "  " << d.name << ": " << d.reason << "\n";
  }
  out << "residuals rms position " << Fixed(c.residuals_before.rms_position_mm, 4) << " mm -> "
      << Fixed(c.residuals_after.rms_position_mm, 4) << " mm, rms orientation "
      << Fixed(c.residuals_before.rms_orientation_deg, 5) << " deg -> "
      << Fixed(c.residuals_after.rms_orientation_deg, 5) << " deg\n";
  out << "condition number " << Fixed(c.condition_number, 2) << "; " << c.termination << ": " << c.brief << "\n";
  if (!c.stored) out << "NOT stored as the campaign's calibration: " << c.message << "\n";
}

// The service reports E_cos in degrees; the core's table formatter takes radians.
AccuracyReport ToCore(const client::Accuracy& a) {
  auto stats = [](const client::Statistics& s, double scale) {
    return ErrorStatistics{s.count, s.mean * scale, s.std * scale, s.max * scale, s.rp * scale};
  };
  AccuracyReport r;
  r.h_mm = a.h_mm;
  r.e_xyz_mm = stats(a.e_xyz_mm, 1.0);
  r.e_cos_rad = stats(a.e_cos_deg, std::numbers::pi / 180.0);
  r.e_tot_mm = stats(a.e_tot_mm, 1.0);
  return r;
}

// The joints CSV at `path` for a robot, as a usage error when malformed (the user's file, not the service).
std::vector<std::vector<double>> ReadJointsFile(const std::string& path, const client::RobotInfo& robot) {
  std::istringstream in(ReadFile(path));
  std::vector<std::vector<double>> rows;
  try {
    rows = client::ReadJointsCsv(in, static_cast<int>(robot.joints.size()));
  } catch (const std::runtime_error& e) {
    throw UsageError(path + ": " + e.what());
  }
  if (rows.empty()) throw UsageError(path + ": no rows");
  return rows;
}

// `out_file` opened for writing, or `out` when it is empty.
class Output {
 public:
  Output(const std::string& out_file, std::ostream& out) : out_(out) {
    if (out_file.empty()) return;
    file_.open(out_file);
    if (!file_) throw UsageError("cannot write " + out_file);
  }
  std::ostream& stream() { return file_.is_open() ? file_ : out_; }

 private:
  std::ostream& out_;
  std::ofstream file_;
};

// robot forward / campaign forward: joints CSV in, poses CSV (the measurement format) or JSON out.
int WriteForward(const Args& args, const client::RobotInfo& robot, const std::vector<std::vector<double>>& joints,
                 const std::vector<api::PoseWire>& poses, std::ostream& out) {
  Output target(args.Option("--out"), out);
  if (args.Flag("--json")) {
    json list = json::array();
    for (const auto& p : poses) list.push_back(api::ToJson(p));
    target.stream() << json{{"poses", list}}.dump(2) << "\n";
    return kExitOk;
  }
  std::vector<api::MeasurementWire> rows;
  for (std::size_t i = 0; i < joints.size() && i < poses.size(); ++i) rows.push_back({joints[i], poses[i]});
  client::WriteMeasurementsCsv(target.stream(), robot.joints, rows);
  return kExitOk;
}

int Measurements(Client& c, const Args& args, std::ostream& out, std::ostream& err) {
  Expect(args, 2, "measurements CAMPAIGN [--role ROLE] [--after SEQ] [--limit N] [--out FILE.csv]");
  const std::string& campaign_id = args.positional[1];
  const std::string role = args.Option("--role");
  if (!role.empty() && role != "calibration" && role != "validation") {
    throw UsageError("--role is calibration or validation");
  }
  std::int64_t after = args.Int("--after", 0, 0, INT64_MAX);
  const long long limit = args.Int("--limit", INT64_MAX, 1, INT64_MAX);
  const std::string out_file = args.Option("--out");
  if (!out_file.empty() && !EndsWith(out_file, ".csv")) throw UsageError("--out takes FILE.csv");
  const client::Campaign campaign = c.GetCampaign(campaign_id);
  json raw = json::array();
  std::vector<api::MeasurementWire> measurements;
  for (;;) {
    const int page_size = static_cast<int>(std::min<long long>(1000, limit - static_cast<long long>(raw.size())));
    const client::MeasurementPage page = c.ListMeasurements(campaign.id, role, after, page_size);
    for (const auto& m : page.measurements) measurements.push_back(m.measurement);
    for (const json& m : page.raw.at("measurements")) raw.push_back(m);
    if (!page.next_after || static_cast<long long>(raw.size()) >= limit || page.measurements.empty()) break;
    after = *page.next_after;
  }
  Output target(out_file, out);
  if (args.Flag("--json")) {
    target.stream() << json{{"measurements", raw}}.dump(2) << "\n";
  } else {
    client::WriteMeasurementsCsv(target.stream(), c.GetRobot(campaign.robot).joints, measurements);
  }
  err << measurements.size() << " measurements of campaign " << campaign.id << "\n";
  return kExitOk;
}

json StatisticsJson(const ErrorStatistics& s, double scale) {
  return {{"count", s.count},
          {"mean", s.mean * scale},
          {"std", s.std * scale},
          {"max", s.max * scale},
          {"rp", s.rp * scale}};
}

// Wire units (mm, degrees), as the service reports accuracy.
json AccuracyJson(const AccuracyReport& r) {
  return {{"h_mm", r.h_mm},
          {"e_xyz_mm", StatisticsJson(r.e_xyz_mm, 1.0)},
          {"e_cos_deg", StatisticsJson(r.e_cos_rad, 180.0 / std::numbers::pi)},
          {"e_tot_mm", StatisticsJson(r.e_tot_mm, 1.0)}};
}

int Experiment(const Args& args, std::ostream& out, std::ostream& err) {
  if (args.positional.size() != 1) throw UsageError("expected: experiment [options] (no other arguments)");
  ExperimentOptions options;
  const std::string error = tools::ParseExperimentFlags(args.experiment_flags, &options);
  if (!error.empty()) throw UsageError(error);
  options.progress = [&err](int done, int total) { err << "\rtrial " << done << " of " << total << std::flush; };
  const ExperimentResult result = RunExperiment(options);
  err << "\r" << Fixed(result.seconds, 1) << " s          \n";
  if (!args.Flag("--json")) {
    out << FormatExperimentReport(result);
    return kExitOk;
  }
  json methods = json::array();
  for (const MethodResult& m : result.methods) {
    methods.push_back({{"method", m.method},
                       {"median_condition_number", api::Num(m.median_condition_number)},
                       {"after", AccuracyJson(m.after)},
                       {"failed_trials", m.failed_trials},
                       {"unconverged_targets", m.unconverged_targets}});
  }
  out << json{{"robot", options.robot},
              {"measurement_type", ToString(options.measurement_type)},
              {"num_configurations", options.num_configurations},
              {"trials", options.trials},
              {"num_validation", options.num_validation},
              {"seed", options.seed},
              {"before", AccuracyJson(result.before)},
              {"methods", methods}}
             .dump(2)
      << "\n";
  return kExitOk;
}

int Robots(Client& c, const Args& args, std::ostream& out) {
  const auto robots = c.ListRobots();
  if (args.Flag("--json")) {
    json list = json::array();
    for (const auto& r : robots) list.push_back(r.raw);
    out << json{{"robots", list}}.dump(2) << "\n";
    return kExitOk;
  }
  for (const auto& r : robots) {
    out << std::left << std::setw(16) << r.id << std::setw(8) << (r.preset ? "preset" : "") << r.joints.size()
        << " joints  " << r.description << std::right << "\n";
  }
  return kExitOk;
}

int Robot(Client& c, const Args& args, std::ostream& out) {
  const std::string& sub = args.positional.size() > 1 ? args.positional[1] : "";
  if (sub == "forward") {
    Expect(args, 4, "robot forward ROBOT IN.csv [--out OUT.csv]");
    const client::RobotInfo robot = c.GetRobot(args.positional[2]);
    const auto joints = ReadJointsFile(args.positional[3], robot);
    return WriteForward(args, robot, joints, c.RobotForward(robot.id, joints), out);
  }
  if (args.positional.size() != 3) {
    throw UsageError("expected: robot register FILE.json | robot get|delete ROBOT | robot forward ROBOT IN.csv");
  }
  client::RobotInfo robot;
  if (sub == "register") {
    json body;
    try {
      body = json::parse(ReadFile(args.positional[2]));
    } catch (const json::parse_error& e) {
      throw UsageError(args.positional[2] + " is not JSON: " + e.what());
    }
    robot = c.RegisterRobot(body);
  } else if (sub == "get") {
    robot = c.GetRobot(args.positional[2]);
  } else if (sub == "delete") {
    c.DeleteRobot(args.positional[2]);
    if (!args.Flag("--json"))
      out << "deleted " << args.positional[2] << "\n";
    else
      out << json{{"deleted", args.positional[2]}}.dump() << "\n";
    return kExitOk;
  } else {
    throw UsageError("unknown robot command " + sub);
  }
  if (args.Flag("--json")) {
    out << robot.raw.dump(2) << "\n";
  } else {
    out << robot.id << ": " << robot.joints.size() << " joints (" << robot.convention << "), "
        << robot.error_parameters.size() << " error parameters\n";
    for (const auto& j : robot.joints) {
      out << "  " << std::left << std::setw(8) << j.name << std::setw(10) << j.type << std::right << Fixed(j.min, 3)
          << " .. " << Fixed(j.max, 3) << " " << j.unit << "\n";
    }
  }
  return kExitOk;
}

void WritePlanFile(Client& c, const client::PlanResult& plan, const std::string& out_file) {
  if (EndsWith(out_file, ".csv")) {
    const client::RobotInfo robot = c.GetRobot(plan.robot);
    std::ofstream file(out_file);
    client::WriteJointsCsv(file, robot.joints, plan.configurations);
    if (!file) throw UsageError("cannot write " + out_file);
  } else if (EndsWith(out_file, ".json")) {
    std::ofstream file(out_file);
    file << plan.raw.dump(2) << "\n";
    if (!file) throw UsageError("cannot write " + out_file);
  }
}

int PlanCommand(Client& c, const Args& args, std::ostream& out, std::ostream& err) {
  const std::string out_file = args.Option("--out");
  if (!out_file.empty() && !EndsWith(out_file, ".csv") && !EndsWith(out_file, ".json")) {
    throw UsageError("--out takes FILE.csv or FILE.json");
  }
  // "plan get PLAN" (three words); "plan get" alone plans for a robot named "get".
  if (args.positional.size() == 3 && args.positional[1] == "get") {
    const client::PlanResult plan = c.GetPlan(args.positional[2]);
    WritePlanFile(c, plan, out_file);
    if (args.Flag("--json")) {
      out << plan.raw.dump(2) << "\n";
    } else {
      PrintPlan(plan, out);
    }
    return kExitOk;
  }
  Expect(args, 2, "plan ROBOT [options] | plan get PLAN");
  api::PlanRequest request;
  request.robot = args.positional[1];
  request.num_configurations = static_cast<int>(args.Int("--count", 10, 1, 100000));
  request.measurement_type = args.Option("--type", "pose");
  request.objective = args.Option("--objective", "condition_number");
  request.optimiser = args.Option("--optimiser", "solis_wets");
  request.seed = static_cast<std::uint64_t>(args.Int("--seed", 1, 0, INT64_MAX));
  client::PlanResult plan;
  if (args.Flag("--async")) {
    const client::Operation started = c.StartPlan(request);
    err << "operation " << started.id << "\n";
    const client::Operation done = WaitWithProgress(c, started.id, err);
    if (done.state == "FAILED" || done.plan.empty()) return ReportUnfinished(done, err);
    plan = c.GetPlan(done.plan);
  } else {
    plan = c.CreatePlan(request);
  }
  WritePlanFile(c, plan, out_file);
  if (args.Flag("--json")) {
    out << plan.raw.dump(2) << "\n";
  } else {
    PrintPlan(plan, out);
  }
  return kExitOk;
}

int CampaignCommand(Client& c, const Args& args, std::ostream& out) {
  if (args.positional.size() < 2) throw UsageError("expected: campaign create|list|get ...");
  const std::string& sub = args.positional[1];
  if (sub == "list") {
    Expect(args, 2, "campaign list");
    const auto campaigns = c.ListCampaigns();
    if (args.Flag("--json")) {
      json list = json::array();
      for (const auto& x : campaigns) list.push_back(x.raw);
      out << json{{"campaigns", list}}.dump(2) << "\n";
    } else {
      for (const auto& x : campaigns) out << x.id << "  " << x.robot << "  " << x.measurement_type << "\n";
    }
    return kExitOk;
  }
  if (sub == "forward") {
    Expect(args, 4, "campaign forward CAMPAIGN IN.csv [--out OUT.csv]");
    const client::Campaign campaign = c.GetCampaign(args.positional[2]);
    const client::RobotInfo robot = c.GetRobot(campaign.robot);
    const auto joints = ReadJointsFile(args.positional[3], robot);
    return WriteForward(args, robot, joints, c.CampaignForward(campaign.id, joints), out);
  }
  client::Campaign campaign;
  if (sub == "create") {
    Expect(args, 4, "campaign create ROBOT TYPE [--plan PLAN]");
    api::CreateCampaignRequest request;
    request.robot = args.positional[2];
    request.measurement_type = args.positional[3];
    request.plan = args.Option("--plan");
    request.id = args.Option("--id");
    request.description = args.Option("--description");
    campaign = c.CreateCampaign(request);
  } else if (sub == "get") {
    Expect(args, 3, "campaign get CAMPAIGN");
    campaign = c.GetCampaign(args.positional[2]);
  } else {
    throw UsageError("unknown campaign command " + sub);
  }
  if (args.Flag("--json")) {
    out << campaign.raw.dump(2) << "\n";
  } else if (sub == "create") {
    out << campaign.id << "\n";
  } else {
    out << campaign.id << "  robot " << campaign.robot << "  " << campaign.measurement_type << "  calibration "
        << campaign.calibration_count << "  validation " << campaign.validation_count
        << (campaign.calibrated ? "  calibrated" : "") << "\n";
  }
  return kExitOk;
}

int Upload(Client& c, const Args& args, std::ostream& out) {
  Expect(args, 3, "upload CAMPAIGN FILE");
  const std::string& campaign_id = args.positional[1];
  const std::string& path = args.positional[2];
  api::MeasurementBatchRequest batch;
  const std::string text = ReadFile(path);
  if (EndsWith(path, ".csv")) {
    const client::Campaign campaign = c.GetCampaign(campaign_id);
    const client::RobotInfo robot = c.GetRobot(campaign.robot);
    std::istringstream in(text);
    try {
      batch.measurements = client::ReadMeasurementsCsv(in, static_cast<int>(robot.joints.size()));
    } catch (const std::runtime_error& e) {
      throw UsageError(path + ": " + e.what());
    }
  } else {
    try {
      const json j = json::parse(text);
      const json& list = j.is_array() ? j : j.at("measurements");
      for (const json& m : list) batch.measurements.push_back(api::MeasurementFromJson(m));
      if (j.is_object()) {
        batch.request_id = j.value("request_id", "");
        batch.role = j.value("role", "calibration");
      }
    } catch (const json::exception& e) {
      throw UsageError(path + ": not a measurement batch: " + e.what());
    }
  }
  if (args.options.count("--role")) batch.role = args.Option("--role");
  if (args.options.count("--request-id")) batch.request_id = args.Option("--request-id");
  const client::UploadResult r = c.UploadMeasurements(campaign_id, batch);
  if (args.Flag("--json")) {
    out << r.raw.dump(2) << "\n";
  } else {
    out << (r.replayed ? "already stored (replayed): " : "stored ") << r.count << " " << batch.role
        << " measurements, batch " << r.batch_id << ", request id " << r.request_id << "; campaign total "
        << r.campaign_total << "\n";
  }
  return kExitOk;
}

int Fit(Client& c, const Args& args, std::ostream& out, std::ostream& err) {
  Expect(args, 2, "fit CAMPAIGN");
  api::FitRequest request;
  std::stringstream names(args.Option("--parameters"));
  for (std::string name; std::getline(names, name, ',');) {
    if (!name.empty()) request.parameters.push_back(name);
  }
  request.register_base = !args.Flag("--no-register-base");
  request.max_iterations = static_cast<int>(args.Int("--max-iterations", 100, 1, 1000));
  client::CalibrationResult result;
  if (args.Flag("--async")) {
    const client::Operation started = c.StartFit(args.positional[1], request);
    err << "operation " << started.id << "\n";
    const client::Operation done = WaitWithProgress(c, started.id, err);
    if (done.state == "FAILED" || !done.fit) return ReportUnfinished(done, err);
    result = *done.fit;
  } else {
    result = c.Fit(args.positional[1], request);
  }
  if (args.Flag("--json")) {
    out << result.raw.dump(2) << "\n";
  } else {
    PrintCalibration(result, out);
  }
  return kExitOk;
}

int Compensate(Client& c, const Args& args, std::ostream& out) {
  Expect(args, 3, "compensate CAMPAIGN IN.csv [--out OUT.csv]");
  const client::Campaign campaign = c.GetCampaign(args.positional[1]);
  const client::RobotInfo robot = c.GetRobot(campaign.robot);
  const auto nominal = ReadJointsFile(args.positional[2], robot);
  const auto results = c.CompensateJoints(campaign.id, nominal);
  Output output(args.Option("--out"), out);
  std::ostream& target = output.stream();
  if (args.Flag("--json")) {
    json list = json::array();
    for (const auto& r : results) {
      list.push_back({{"joints", r.joints},
                      {"position_error_mm", r.position_error_mm},
                      {"orientation_error_deg", r.orientation_error_deg},
                      {"converged", r.converged},
                      {"message", r.message}});
    }
    target << json{{"results", list}}.dump(2) << "\n";
  } else {
    client::WriteCompensationCsv(target, robot.joints, results);
  }
  return kExitOk;
}

int Evaluate(Client& c, const Args& args, std::ostream& out) {
  Expect(args, 2, "evaluate CAMPAIGN [--h-mm H]");
  api::EvaluateRequest request;
  request.h_mm = args.Number("--h-mm", 30.0);
  const client::Evaluation e = c.Evaluate(args.positional[1], request);
  if (args.Flag("--json")) {
    out << e.raw.dump(2) << "\n";
    return kExitOk;
  }
  out << FormatAccuracyTable(ToCore(e.nominal),
                             "nominal model, " + std::to_string(e.num_validation) + " validation measurements");
  out << FormatAccuracyTable(ToCore(e.calibrated), "calibrated model");
  out << "improvement:";
  for (const auto& [name, percent] : e.improvement_percent) out << " " << name << " " << Fixed(percent, 1) << " %";
  out << "\n";
  return kExitOk;
}

int OperationCommand(Client& c, const Args& args, std::ostream& out, std::ostream& err) {
  Expect(args, 3, "operation wait|get|cancel ID");
  const std::string& sub = args.positional[1];
  client::Operation op;
  if (sub == "wait") {
    op = WaitWithProgress(c, args.positional[2], err);
  } else if (sub == "get") {
    op = c.GetOperation(args.positional[2]);
  } else if (sub == "cancel") {
    op = c.CancelOperation(args.positional[2]);
  } else {
    throw UsageError("unknown operation command " + sub);
  }
  if (args.Flag("--json")) {
    out << op.raw.dump(2) << "\n";
  } else {
    out << op.id << " " << op.state << " " << std::lround(op.progress * 100) << "%";
    if (!op.plan.empty()) out << " plan " << op.plan;
    if (op.fit) out << " fit " << (op.fit->stored ? "stored" : "not stored") << " (" << op.fit->termination << ")";
    if (op.error) out << " " << op.error->status << ": " << op.error->message;
    out << "\n";
  }
  return sub == "wait" && op.state == "FAILED" ? kExitServiceError : kExitOk;
}

std::string HelpFor(const std::string& command) {
  if (command == "robots") return kRobotsHelp;
  if (command == "measurements") return kMeasurementsHelp;
  if (command == "experiment") return std::string(kExperimentHelp) + tools::kExperimentFlagsHelp;
  if (command == "plan") return kPlanHelp;
  if (command == "robot") return kRobotHelp;
  if (command == "campaign") return kCampaignHelp;
  if (command == "upload") return kUploadHelp;
  if (command == "fit") return kFitHelp;
  if (command == "compensate") return kCompensateHelp;
  if (command == "evaluate") return kEvaluateHelp;
  if (command == "operation") return kOperationHelp;
  return kMainHelp;
}

}  // namespace

int Run(const std::vector<std::string>& raw, const std::map<std::string, std::string>& env, std::ostream& out,
        std::ostream& err) {
  try {
    const Args args = ParseArgs(raw);
    const std::string command = args.positional.empty() ? "" : args.positional[0];
    if (args.Flag("--help")) {
      out << HelpFor(command);
      return kExitOk;
    }
    if (command.empty()) throw UsageError("no command");
    if (command == "experiment") return Experiment(args, out, err);  // local: no server
    client::ClientOptions options;
    if (auto it = env.find("ROBOCAL_SERVER"); it != env.end() && !it->second.empty()) options.server_url = it->second;
    if (auto it = env.find("ROBOCAL_TOKEN"); it != env.end()) options.bearer_token = it->second;
    if (auto it = env.find("ROBOCAL_CA_CERT"); it != env.end()) options.ca_cert_file = it->second;
    options.server_url = args.Option("--server", options.server_url);
    options.bearer_token = args.Option("--token", options.bearer_token);
    options.ca_cert_file = args.Option("--ca-cert", options.ca_cert_file);
    if (args.Flag("--insecure")) {
      options.verify_tls = false;
      err << "robocal: WARNING: --insecure: the server's TLS certificate is not verified; anyone on the network "
             "path can pose as the server and read the token\n";
    }
    std::string error;
    if (!options.IsValid(&error)) throw UsageError(error);
    Client c(options);
    if (command == "robots") return Robots(c, args, out);
    if (command == "robot") return Robot(c, args, out);
    if (command == "plan") return PlanCommand(c, args, out, err);
    if (command == "campaign") return CampaignCommand(c, args, out);
    if (command == "upload") return Upload(c, args, out);
    if (command == "measurements") return Measurements(c, args, out, err);
    if (command == "fit") return Fit(c, args, out, err);
    if (command == "compensate") return Compensate(c, args, out);
    if (command == "evaluate") return Evaluate(c, args, out);
    if (command == "operation") return OperationCommand(c, args, out, err);
    throw UsageError("unknown command " + command);
  } catch (const UsageError& e) {
    err << "robocal: " << e.what() << "\n(see robocal --help)\n";
    return kExitUsage;
  } catch (const client::ServiceError& e) {
    err << "robocal: " << e.http_status() << " " << e.status() << ": " << e.message() << "\n";
    for (const auto& d : e.details()) err << "  " << d.field << ": " << d.reason << "\n";
    return kExitServiceError;
  } catch (const client::ConnectionError& e) {
    err << "robocal: " << e.what() << "\n";
    return kExitConnection;
  } catch (const std::exception& e) {
    err << "robocal: " << e.what() << "\n";
    return kExitServiceError;
  }
}

}  // namespace robocal::cli
