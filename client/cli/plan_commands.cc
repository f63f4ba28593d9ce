// robocal plan, plan get, and operation wait | get | cancel (the long-running form of plans and fits).
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <optional>
#include <sstream>

#include "cli.h"
#include "command.h"
#include "robocal/client/csv.h"
#include "support.h"

namespace robocal::cli {
namespace {

void PrintIndices(std::ostream& out, const char* label, const api::Indices& x, const api::PredictedAccuracyWire& a) {
  out << std::left << std::setw(10) << label << std::right << "  cond " << std::setw(10) << Fixed(x.condition_number, 2)
      << "  O1 " << std::setw(10) << Fixed(x.o1, 4) << "  O2 " << std::setw(10) << Fixed(x.o2, 4) << "  O3 "
      << std::setw(10) << Fixed(x.o3, 6) << "  O4 " << std::setw(10) << Fixed(x.o4, 6) << "  O5 " << std::setw(10)
      << Fixed(x.o5, 4) << "  predicted rms " << Fixed(a.rms_position_mm, 4) << " mm\n";
}

void PrintPlan(const api::PlanResult& plan, std::ostream& out) {
  out << "plan " << plan.id << "  robot " << plan.robot << "  " << plan.configurations.size() << " "
      << api::WireName(plan.measurement_type) << " configurations  (" << api::WireName(plan.optimiser)
      << ", objective " << api::WireName(plan.objective) << ")\n";
  // In a cell, each configuration's check: its minimum clearance and the reflectors the tracker sees, each
  // with the incidence angle and distance ("smr1 12.3deg 2650mm").
  const bool checks = plan.cell && plan.configuration_checks.size() == plan.configurations.size();
  if (plan.cell) out << "in cell " << *plan.cell << "\n";
  out << std::setw(4) << "#";
  for (std::size_t j = 0; j < plan.joint_units.size(); ++j) {
    out << std::setw(12) << ("q" + std::to_string(j + 1) + "[" + plan.joint_units[j] + "]");
  }
  if (checks) out << std::setw(16) << "clearance[mm]" << "  measurable reflectors";
  out << "\n";
  for (std::size_t i = 0; i < plan.configurations.size(); ++i) {
    out << std::setw(4) << i + 1;
    for (double v : plan.configurations[i]) out << std::setw(12) << Fixed(v, 3);
    if (checks) {
      const api::ConfigurationCheckWire& check = plan.configuration_checks[i];
      out << std::setw(16) << Fixed(check.min_clearance_mm, 1) << " ";
      for (const api::ReflectorCheckWire& r : check.reflectors) {
        if (r.measurable) out << " " << r.id << " " << Fixed(r.incidence_deg, 1) << "deg " << Fixed(r.distance_mm, 0) << "mm";
      }
    }
    out << "\n";
  }
  PrintIndices(out, "plan", plan.indices, plan.predicted_accuracy);
  PrintIndices(out, "random", plan.baseline.indices, plan.baseline.predicted_accuracy);
  out << plan.identifiable_parameters.size() << " identifiable parameters; " << plan.summary.brief << "\n";
  if (plan.candidates) {
    out << "candidates: " << plan.candidates->num_usable << " of " << plan.candidates->num_candidates << " usable";
    for (const api::CandidateRejectionWire& r : plan.candidates->rejected) out << "; " << r.count << " " << r.reason;
    out << "\n";
  }
  if (plan.coverage && !plan.coverage->warning.empty()) out << "warning: " << plan.coverage->warning << "\n";
  if (plan.pose_count) {
    const api::PoseCountWire& c = *plan.pose_count;
    out << "predicted mean position error on the task against N (goal " << Fixed(c.accuracy_goal_mm, 3) << " mm";
    if (c.model_error_mm > 0.0) out << ", robot model error " << Fixed(c.model_error_mm, 3) << " mm";
    out << "):\n";
    for (const api::PoseCountPointWire& p : c.points) {
      out << std::setw(6) << p.num_configurations << std::setw(10) << Fixed(p.predicted_mean_mm, 4) << " mm"
          << (c.chosen && *c.chosen == p.num_configurations ? "  <- chosen" : "") << "\n";
    }
    if (!c.chosen) out << "no N up to " << c.points.back().num_configurations << " reaches the goal\n";
  }
}

std::string OutFile(const Invocation& in) {
  const std::string out_file = in.Option("--out");
  if (!out_file.empty() && !EndsWith(out_file, ".csv") && !EndsWith(out_file, ".json")) {
    throw UsageError("--out takes FILE.csv or FILE.json");
  }
  return out_file;
}

void WritePlanFile(Invocation& in, const api::PlanResult& plan, const std::string& out_file) {
  if (out_file.empty()) return;
  if (EndsWith(out_file, ".csv")) {
    const api::Robot robot = in.Client().GetRobot(plan.robot);
    std::ofstream file(out_file);
    client::WriteJointsCsv(file, robot.joints, plan.configurations);
    if (!file) throw UsageError("cannot write " + out_file);
  } else {
    std::ofstream file(out_file);
    PrintJson(file, plan);
    if (!file) throw UsageError("cannot write " + out_file);
  }
}

int Show(Invocation& in, const api::PlanResult& plan, const std::string& out_file) {
  WritePlanFile(in, plan, out_file);
  if (in.json) {
    PrintJson(in.out, plan);
  } else {
    PrintPlan(plan, in.out);
  }
  return kExitOk;
}

int ShowOperation(Invocation& in, const api::Operation& op) {
  if (in.json) {
    PrintJson(in.out, op);
    return kExitOk;
  }
  const double progress = std::isfinite(op.progress) ? op.progress : 0.0;
  in.out << op.id << " " << api::WireName(op.state) << " " << std::lround(progress * 100) << "%";
  if (op.plan) in.out << " plan " << *op.plan;
  if (op.fit) {
    in.out << " fit " << (op.fit->stored ? "stored" : "not stored") << " ("
           << api::WireName(op.fit->summary.termination) << ")";
  }
  if (op.error) in.out << " " << api::WireName(op.error->status) << ": " << op.error->message;
  in.out << "\n";
  return kExitOk;
}

// --candidates SOURCE: a tracker export with joint columns (with --format csv and the upload's column options), a
// joints CSV (as plan --out writes), a JSON file (a list of joint vectors, or the candidates object), or else a
// campaign's id.
api::PlanCandidatesWire CandidatesOption(Invocation& in, const std::string& robot_id) {
  const std::string source = in.Option("--candidates");
  api::PlanCandidatesWire candidates;
  if (in.Has("--format")) {
    candidates.file = TrackerFileRequest(in, in.Option("--format"), source);
  } else if (std::filesystem::exists(source)) {
    if (EndsWith(source, ".json")) {
      nlohmann::json value;
      try {
        value = nlohmann::json::parse(ReadFile(source));
        if (value.is_array()) {
          candidates.joints = value.get<std::vector<std::vector<double>>>();
        } else {
          candidates = api::FromWire<api::PlanCandidatesWire>(value);
        }
      } catch (const std::exception& e) {
        throw UsageError(source + ": " + e.what());
      }
    } else {
      candidates.joints = ReadJointsFile(source, in.Client().GetRobot(robot_id));
    }
  } else if (EndsWith(source, ".csv") || EndsWith(source, ".json")) {
    throw UsageError("--candidates: no file " + source);
  } else {
    candidates.campaign = source;
  }
  candidates.malformed = in.Enum("--malformed", candidates.malformed);
  return candidates;
}

// --task FILE.csv (joints CSV) or --task-box X0,Y0,Z0:X1,Y1,Z1 [--task-rpy R,P,Y/R,P,Y...] [--task-count N].
std::optional<api::PlanTaskWire> TaskOption(Invocation& in, const std::string& robot_id) {
  if (in.Has("--task") && in.Has("--task-box")) throw UsageError("--task and --task-box exclude each other");
  api::PlanTaskWire task;
  if (in.Has("--task")) {
    task.joints = ReadJointsFile(in.Option("--task"), in.Client().GetRobot(robot_id));
    return task;
  }
  if (!in.Has("--task-box")) {
    if (in.Has("--task-rpy") || in.Has("--task-count")) throw UsageError("--task-rpy and --task-count need --task-box");
    return std::nullopt;
  }
  const std::string box = in.Option("--task-box");
  const std::size_t colon = box.find(':');
  if (colon == std::string::npos) throw UsageError("--task-box takes X0,Y0,Z0:X1,Y1,Z1 (mm, base frame)");
  api::TaskBoxWire w;
  w.min_mm = Triple("--task-box", box.substr(0, colon));
  w.max_mm = Triple("--task-box", box.substr(colon + 1));
  if (in.Has("--task-rpy")) {
    std::istringstream list(in.Option("--task-rpy"));
    std::string item;
    while (std::getline(list, item, '/')) w.orientations_rpy_deg.push_back(Triple("--task-rpy", item));
  }
  w.count = static_cast<int>(in.Integer("--task-count", w.count, 1, 1000000));
  task.box = w;
  return task;
}

}  // namespace

int Plan(Invocation& in) {
  const std::string out_file = OutFile(in);
  api::PlanRequest request;
  request.robot = in.args[0];
  request.cell = in.Option("--cell");
  if (in.Option("--count") == "auto") {
    // The service names a missing goal (accuracy_goal_mm) and the range's bounds.
    request.num_configurations_auto = true;
    if (in.Has("--goal-mm")) request.accuracy_goal_mm = in.Number("--goal-mm", 0.0, 0.0);
    request.min_configurations = static_cast<int>(in.Integer("--min-count", request.min_configurations, 1, 100000));
    request.max_configurations = static_cast<int>(in.Integer("--max-count", request.max_configurations, 1, 100000));
  } else {
    if (in.Has("--goal-mm") || in.Has("--min-count") || in.Has("--max-count")) {
      throw UsageError("--goal-mm, --min-count and --max-count go with --count auto");
    }
    request.num_configurations = static_cast<int>(in.Integer("--count", 10, 1, 100000));
  }
  request.measurement_type = in.Enum("--type", MeasurementType::kPose);
  if (in.Has("--objective")) request.objective = in.Enum("--objective", ObservabilityIndex::kConditionNumber);
  if (in.Has("--candidates")) {
    request.candidates = CandidatesOption(in, request.robot);
  } else if (in.Has("--malformed") || in.Has("--format")) {
    throw UsageError("--malformed and --format go with --candidates");
  }
  request.task = TaskOption(in, request.robot);
  request.optimiser = in.Enum("--optimiser", api::Optimiser::kSolisWets);
  request.purpose = in.Enum("--purpose", request.purpose);
  request.seed = in.Seed("--seed", 1);
  if (in.Has("--tracker")) request.tracker = ParseTrackerFlag(in.Option("--tracker"));
  if (in.Has("--reflectors")) request.reflectors = ParseReflectorsFlag(in.Option("--reflectors"));
  if (!in.Has("--async")) return Show(in, in.Client().CreatePlan(request), out_file);
  const api::Operation started = in.Client().StartPlan(request);
  in.err << "operation " << started.id << "\n";
  const api::Operation done = WaitWithProgress(in, started.id);
  if (done.state == api::OperationState::kFailed || !done.plan) return ReportUnfinished(done, in.err);
  return Show(in, in.Client().GetPlan(*done.plan), out_file);
}

int PlanGet(Invocation& in) {
  const std::string out_file = OutFile(in);
  return Show(in, in.Client().GetPlan(in.args[0]), out_file);
}

int OperationWait(Invocation& in) {
  const api::Operation op = WaitWithProgress(in, in.args[0]);
  ShowOperation(in, op);
  return op.state == api::OperationState::kFailed ? kExitServiceError : kExitOk;
}

int OperationGet(Invocation& in) { return ShowOperation(in, in.Client().GetOperation(in.args[0])); }

int OperationCancel(Invocation& in) { return ShowOperation(in, in.Client().CancelOperation(in.args[0])); }

}  // namespace robocal::cli
