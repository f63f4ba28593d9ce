// The ISO 9283 pose test (docs/iso9283.md): a test plan's poses and joint commands, and the characteristics of a
// campaign's test shots.
#include <Eigen/Eigenvalues>
#include <chrono>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "robocal/api/error.h"
#include "robocal/api/iso9283.h"
#include "robocal/core/compensation.h"
#include "robocal/core/identification.h"
#include "robocal/core/iso9283.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/units.h"
#include "robocal/server/service.h"
#include "service_support.h"

namespace robocal::server {
namespace {

using api::ApiError;
using api::Status;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr const char* kCubeField = "test.iso9283.cube";

std::string Mm(const Eigen::Vector3d& p) {
  std::ostringstream o;
  o.precision(6);
  o << "(" << p.x() << ", " << p.y() << ", " << p.z() << ") mm";
  return o.str();
}

// The optimisation figures a test plan has none of: null on the wire.
api::Indices NoIndices(int num_configurations) {
  return {.num_configurations = num_configurations,
          .num_parameters = 0,
          .condition_number = kNaN,
          .o1 = kNaN,
          .o2 = kNaN,
          .o3 = kNaN,
          .o4 = kNaN,
          .o5 = kNaN,
          .log_det = kNaN,
          .predicted_error_mm = kNaN,
          .singular_values = {},
          .scaling = ""};
}
api::PredictedAccuracyWire NoPrediction() {
  return {.num_validation = 0,
          .rms_position_mm = kNaN,
          .max_position_mm = kNaN,
          .rms_orientation_deg = kNaN,
          .rms_error_mm = kNaN};
}

// Joints for the test's poses on `calibration` (the nominal robot's NominalCalibration, or a calibrated one), each
// from the previous pose's joints, on `branch` (empty: the branch P1 is solved on); `start` the nominal joints of
// each pose for a calibrated robot (empty: none). `field` names the request member a failure is blamed on.
std::vector<Eigen::VectorXd> SolvePoses(const Calibration& calibration, const RobotModel& nominal,
                                        const std::array<Transform, kIso9283Poses>& poses, ArmConfiguration* branch,
                                        const std::vector<Eigen::VectorXd>& start,
                                        const std::function<std::string(const Eigen::VectorXd&)>& infeasible,
                                        const std::string& field, const std::string& whose) {
  std::vector<Eigen::VectorXd> joints;
  Eigen::VectorXd previous;
  for (int k = 0; k < kIso9283Poses; ++k) {
    CompensationTarget target;
    target.pose = poses[k];
    target.frame = TargetFrame::kBase;
    target.configuration = *branch;
    if (!start.empty()) target.start = start[k];
    const CompensationResult r = Compensate(calibration, nominal, target, {}, previous);
    const std::string where = Iso9283PoseName(k) + " at " + Mm(poses[k].translation());
    if (r.termination != Termination::kConvergence) {
      const std::string reason =
          where + " is out of the " + whose + " reach" +
          (branch->empty() ? std::string() : " on " + branch->ToString()) + ": " + r.message;
      if (start.empty()) throw ApiError(Status::kInvalidArgument, "the ISO 9283 cube: " + reason, {{field, reason}});
      throw ApiError(Status::kFailedPrecondition, "the ISO 9283 test: " + reason, {{field, reason}});
    }
    if (infeasible) {
      if (const std::string why = infeasible(r.joints); !why.empty()) {
        const std::string reason = where + " is not feasible in the cell: " + why;
        throw ApiError(start.empty() ? Status::kInvalidArgument : Status::kFailedPrecondition,
                       "the ISO 9283 test: " + reason, {{field, reason}});
      }
    }
    if (k == 0 && branch->empty() && r.configuration) *branch = *r.configuration;
    joints.push_back(r.joints);
    previous = r.joints;
  }
  return joints;
}

// The test's cube with the arm configuration to solve its poses on (empty: the one P1 is solved on), and what the
// plan says of it.
struct TestPlanCube {
  Iso9283Cube cube;
  ArmConfiguration branch;
  std::string message;
};

// The cube as the request gives it, or (cube "auto") the largest one the cell's workspace holds: searched among
// the configurations `feasible` accepts (empty without a cell, which "auto" refuses).
TestPlanCube ChooseTestPlanCube(const RobotModel& model, const api::PlanRequest& req,
                                const Eigen::Matrix3d& orientation,
                                const std::function<bool(const Eigen::VectorXd&)>& feasible) {
  const api::Iso9283TestWire& test = req.test->iso9283;
  TestPlanCube chosen;
  if (!test.cube_auto) {
    chosen.cube = api::ToCore(*test.cube);
    chosen.message = "the cube as given";
    return chosen;
  }
  // Without a cell the arm's whole reach counts, its own base and the floor included.
  if (!feasible) {
    throw ApiError(Status::kInvalidArgument, "cube \"auto\" needs the plan's cell",
                   {{kCubeField,
                     "\"auto\" searches the cell's workspace (reach, line of sight, obstacles): give "
                     "\"cell\", or the cube's center_mm and size_mm"}});
  }
  Iso9283CubeSearchOptions options;
  options.seed = req.seed;
  options.feasible = feasible;
  Iso9283CubeSearch search;
  try {
    search = LargestIso9283Cube(model, orientation, options);
  } catch (const std::invalid_argument& e) {
    throw ApiError(Status::kInvalidArgument, std::string("the ISO 9283 cube: ") + e.what(), {{kCubeField, e.what()}});
  }
  if (!search.found) {
    throw ApiError(Status::kFailedPrecondition, "no ISO 9283 cube: " + search.message, {{kCubeField, search.message}});
  }
  chosen.cube = search.cube;
  chosen.branch = search.configuration;
  chosen.message = "cube \"auto\": " + search.message;
  return chosen;
}

// The plan's poses with their joint commands (`joints`, one per pose), and its visits: `test.cycles` cycles of
// P1-P5, each visit a configuration of `result` and a tag of `plan`.
void AddTestPlanVisits(const RobotModel& model, const api::Iso9283TestWire& test,
                       const std::array<Transform, kIso9283Poses>& poses, const std::vector<Eigen::VectorXd>& joints,
                       api::Iso9283PlanWire* plan, api::PlanResult* result) {
  for (int k = 0; k < kIso9283Poses; ++k) {
    const Eigen::Vector3d& p = poses[k].translation();
    plan->poses.push_back({.name = Iso9283PoseName(k),
                           .position_mm = {p.x(), p.y(), p.z()},
                           .orientation_rpy_deg = test.orientation_rpy_deg,
                           .joints = api::JointsToWire(model, joints[k])});
  }
  for (int cycle = 1; cycle <= test.cycles; ++cycle) {
    for (int k = 0; k < kIso9283Poses; ++k) {
      result->configurations.push_back(plan->poses[k].joints);
      plan->tags.push_back({.test_pose = Iso9283PoseName(k), .cycle = cycle});
    }
  }
}

// A test plan's figures: none of an optimisation's (null on the wire), and a summary that says what the test is and
// how long its solving took since `start_time`.
void SummariseTestPlan(const api::Iso9283TestWire& test, const Iso9283Cube& cube, const std::string& message,
                       std::chrono::steady_clock::time_point start_time, api::PlanResult* result) {
  const int n = static_cast<int>(result->configurations.size());
  result->indices = NoIndices(n);
  result->baseline.indices = NoIndices(0);
  result->baseline.predicted_accuracy = NoPrediction();
  result->predicted_accuracy = NoPrediction();
  result->summary.termination = Termination::kConvergence;
  result->summary.method = "iso9283";
  result->summary.objective = result->objective;
  result->summary.initial = NoIndices(0);
  result->summary.message = message;
  std::ostringstream brief;
  brief << "ISO 9283 pose test: " << test.cycles << " cycles of P1-P5 in a " << cube.size_mm << " mm cube at "
        << Mm(cube.center_mm);
  result->summary.brief = brief.str();
  result->summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
}

}  // namespace

api::PlanResult Service::RunTestPlan(const RobotModel& model, const api::PlanRequest& req,
                                     const std::string& plan_id, const LoadedCell* cell) {
  const auto start_time = std::chrono::steady_clock::now();
  const api::Iso9283TestWire& test = req.test->iso9283;
  const Eigen::Vector3d rpy(test.orientation_rpy_deg[0], test.orientation_rpy_deg[1], test.orientation_rpy_deg[2]);
  const Eigen::Matrix3d orientation = RotationFromRpy(rpy * kRadPerDeg);
  std::function<bool(const Eigen::VectorXd&)> feasible;
  if (cell != nullptr) {
    feasible = [cell](const Eigen::VectorXd& q) { return IsFeasible(cell->model, cell->cell, q); };
  }
  TestPlanCube chosen = ChooseTestPlanCube(model, req, orientation, feasible);
  // The calibration that compensates the commands, before any pose is solved: a wrong campaign is named first.
  std::optional<Calibrated> compensating;
  if (!test.compensated_by.empty()) {
    const std::string field = "test.iso9283.compensated_by";
    try {
      compensating = LoadCalibrated(test.compensated_by);
    } catch (const ApiError& e) {
      const bool unknown = e.status() == Status::kNotFound;
      throw ApiError(unknown ? Status::kInvalidArgument : Status::kFailedPrecondition,
                     "campaign \"" + test.compensated_by + "\"" + (unknown ? " does not exist" : " is not calibrated"),
                     {{field, unknown ? "unknown campaign" : "not calibrated (POST :fit)"}});
    }
    if (compensating->campaign.robot != req.robot) {
      throw ApiError(Status::kFailedPrecondition,
                     "campaign \"" + test.compensated_by + "\" calibrated robot " + compensating->campaign.robot +
                         ", not " + req.robot,
                     {{field, "a calibration of another robot"}});
    }
  }
  const std::array<Transform, kIso9283Poses> poses = Iso9283Poses(chosen.cube, orientation);
  std::function<std::string(const Eigen::VectorXd&)> infeasible;
  if (cell != nullptr) {
    infeasible = [cell](const Eigen::VectorXd& q) {
      const ConfigurationCheck check = CheckConfiguration(cell->model, cell->cell, q);
      std::string reasons;
      for (const std::string& reason : check.reasons) reasons += (reasons.empty() ? "" : "; ") + reason;
      return reasons;
    };
  }
  ArmConfiguration& branch = chosen.branch;
  std::vector<Eigen::VectorXd> joints =
      SolvePoses(NominalCalibration(model), model, poses, &branch, {}, infeasible, kCubeField, "robot's");
  std::optional<std::string> compensated_by;
  if (compensating) {
    joints = SolvePoses(compensating->calibration, compensating->model, poses, &branch, joints, infeasible,
                        "test.iso9283.compensated_by", "calibrated robot's");
    compensated_by = test.compensated_by;
    chosen.message += "; joint commands compensated by the calibration of campaign \"" + test.compensated_by + "\"";
  }

  api::PlanResult result;
  PlanHeader(model, req, plan_id, &result);
  api::Iso9283PlanWire plan{.cube = api::ToWire(chosen.cube),
                            .cycles = test.cycles,
                            .orientation_rpy_deg = test.orientation_rpy_deg,
                            .compensated_by = compensated_by,
                            .configuration = branch.ToString(),
                            .poses = {},
                            .tags = {},
                            .message = chosen.message};
  AddTestPlanVisits(model, test, poses, joints, &plan, &result);
  SummariseTestPlan(test, chosen.cube, chosen.message, start_time, &result);
  result.created_unix_ms = NowUnixMs();
  if (cell != nullptr) {
    result.cell = cell->wire.id;
    for (int cycle = 1; cycle <= test.cycles; ++cycle) {
      for (const Eigen::VectorXd& q : joints) {
        result.configuration_checks.push_back(api::ToWire(CheckConfiguration(cell->model, cell->cell, q)));
      }
    }
  }
  result.test = std::move(plan);
  return result;
}

namespace {

// A test shot as stored.
struct TestShot {
  int pose = 0;
  int cycle = 0;
  std::int64_t sequence = 0;
  Measurement measurement;
};

// A campaign's test shots, each visit (pose and cycle) once, and what was left out.
struct TestShotsRead {
  std::vector<TestShot> shots;
  /// The visits measured again: each with the shot that counts and the one it replaced.
  std::vector<std::string> retaken;
  /// The stale shots left out.
  int stale = 0;
};

// The shots, each pose and cycle once: a visit measured again (a shot retaken) counts with its latest shot.
// FAILED_PRECONDITION for a shot without its pose and cycle, or when there are none.
TestShotsRead ReadTestShots(Storage* storage, const std::string& campaign_id, const api::StoredCampaign& campaign,
                            const RobotModel& model) {
  TestShotsRead read;
  std::vector<TestShot>& shots = read.shots;
  std::map<std::pair<int, int>, std::size_t> seen;
  ForEachMeasurement(storage, campaign_id, "test", [&](const StoredMeasurement& s) {
    const api::MeasurementWire w = ReadMeasurement(s);
    TestShot shot{.pose = Iso9283PoseIndex(w.test_pose),
                  .cycle = w.cycle,
                  .sequence = s.sequence,
                  .measurement = MeasurementToCore(model, w, campaign)};
    if (shot.pose < 0 || shot.cycle < 1) {
      throw ApiError(Status::kFailedPrecondition,
                     "test measurement " + std::to_string(s.sequence) + " has no ISO 9283 pose and cycle",
                     {{"measurements", "test shots need test_pose and cycle"}});
    }
    if (w.stale) {
      ++read.stale;
      return;
    }
    const auto [it, fresh] = seen.emplace(std::make_pair(shot.pose, shot.cycle), shots.size());
    if (!fresh) {
      read.retaken.push_back(w.test_pose + " cycle " + std::to_string(w.cycle) + ": measurement " +
                             std::to_string(s.sequence) + " (not " + std::to_string(shots[it->second].sequence) + ")");
      shots[it->second] = std::move(shot);
      return;
    }
    shots.push_back(std::move(shot));
  });
  if (shots.empty()) {
    throw ApiError(Status::kFailedPrecondition, "campaign \"" + campaign_id + "\" has no test measurements",
                   {{"measurements", "upload shots of role test, each with its test_pose and cycle"}});
  }
  return read;
}

// The commands, base frame: the test plan's poses, else the robot's model at each shot's joints, with the tool
// `calibration` registered when there is one (null: none; the point the tracker measures, as the fit found it).
std::vector<Transform> TestShotCommands(const RobotModel& model, const std::vector<TestShot>& shots,
                                        const std::optional<api::Iso9283PlanWire>& test_plan,
                                        const Calibration* calibration) {
  std::vector<Transform> commanded;  // base frame
  const Transform T_base_world_model = model.T_world_base().inverse();
  const Transform tool_change =
      calibration ? model.T_flange_tool().inverse() * calibration->T_flange_tool : Transform::Identity();
  KinematicsWorkspace ws(model);
  for (const TestShot& s : shots) {
    if (test_plan) {
      const api::Iso9283PlannedPoseWire& p = test_plan->poses[static_cast<std::size_t>(s.pose)];
      Transform t = Transform::Identity();
      t.linear() = RotationFromRpy(Eigen::Vector3d(p.orientation_rpy_deg[0], p.orientation_rpy_deg[1],
                                                   p.orientation_rpy_deg[2]) *
                                   kRadPerDeg);
      t.translation() = Eigen::Vector3d(p.position_mm[0], p.position_mm[1], p.position_mm[2]);
      commanded.push_back(t);
    } else {
      commanded.push_back(T_base_world_model *
                          ForwardKinematics(model, s.measurement.joints, Eigen::VectorXd(), &ws, s.measurement.payload) *
                          tool_change);
    }
  }
  return commanded;
}

// The tracker frame registered on the test shots themselves (T_world_base): their measured points onto their
// commands. FAILED_PRECONDITION when the commands do not span a plane.
Transform RegisterTrackerOnTestShots(const std::vector<TestShot>& shots, const std::vector<Transform>& commanded) {
  std::vector<Eigen::Vector3d> from, to;
  for (std::size_t i = 0; i < shots.size(); ++i) {
    from.push_back(commanded[i].translation());
    to.push_back(shots[i].measurement.T_world_tool.translation());
  }
  // The commands must span a plane: on a line (P1, P2 and P4 lie on one diagonal) the turn about it is free, and
  // the measured points' noise would choose it.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : from) mean += p / static_cast<double>(from.size());
  Eigen::Matrix3d spread = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : from) spread += (p - mean) * (p - mean).transpose();
  const Eigen::Vector3d eigen = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(spread).eigenvalues();
  try {
    if (!(eigen[1] > 1e-6 * eigen[2])) throw std::invalid_argument("commands on a line");
    return RegisterPoints(from, to);
  } catch (const std::invalid_argument&) {
    throw ApiError(
        Status::kFailedPrecondition,
        "the tracker frame cannot be registered on these test shots: their commands lie on a line (P1, P2 and "
        "P4 do: measure a third pose beside them) or at one point; or fit the campaign (\"scope\": "
        "\"frames\") on shots of role calibration first",
        {{"measurements", "too few test poses to register the tracker frame"}});
  }
}

// The report's notes on what the figures leave out: poses with one cycle, orientation, stale and retaken shots.
void AddIso9283Notes(const Iso9283Result& result, bool orientation, const TestShotsRead& read,
                     api::Iso9283ReportWire* report) {
  std::string once;
  for (const Iso9283PoseFigures& f : result.poses) {
    if (f.cycles < 2) once += (once.empty() ? "" : ", ") + Iso9283PoseName(f.pose);
  }
  if (!once.empty()) {
    report->notes.push_back("repeatability (RP, RD) needs at least 2 cycles of a pose: not measurable at " + once +
                            " (1 cycle), reported as null, not 0");
  }
  if (!orientation) report->notes.push_back("shots without orientation: no orientation characteristics");
  if (read.stale > 0) report->notes.push_back(std::to_string(read.stale) + " stale test shots were left out");
  if (!read.retaken.empty()) {
    std::string list;
    for (const std::string& r : read.retaken) list += (list.empty() ? "" : "; ") + r;
    report->notes.push_back("visits measured more than once count with their latest shot: " + list);
  }
}

}  // namespace

api::Iso9283ReportWire Service::Iso9283Report(const std::string& campaign_id) {
  const api::StoredCampaign campaign = LoadCampaign(campaign_id);
  if (!campaign.reflectors.empty()) {
    throw ApiError(Status::kFailedPrecondition, "ISO 9283 measures the tool point; the campaign has reflectors",
                   {{"campaign", "a campaign with reflectors"}});
  }
  const RobotModel model = api::BuildModel(campaign.robot_definition);
  api::Iso9283ReportWire report;
  report.campaign = campaign_id;
  report.measurement_type = campaign.type();
  const TestShotsRead read = ReadTestShots(storage_, campaign_id, campaign, model);
  const std::vector<TestShot>& shots = read.shots;
  report.num_shots = static_cast<int>(shots.size());

  // The frames' source: the campaign's calibration, if any.
  std::optional<Calibrated> loaded;
  if (storage_->Get(kCalibrations, campaign_id)) loaded = LoadCalibrated(campaign_id);

  // The test plan the campaign was made from, if any: its poses are the commands.
  std::optional<api::Iso9283PlanWire> test_plan;
  if (campaign.plan) {
    const auto doc = storage_->Get(kPlans, *campaign.plan);
    if (doc) test_plan = ReadStored<api::StoredPlan>(*doc).plan.test;
  }
  const std::vector<Transform> commanded =
      TestShotCommands(model, shots, test_plan, loaded ? &loaded->calibration : nullptr);
  report.commands = test_plan ? api::TestCommands::kPlan : api::TestCommands::kRobotModel;
  if (test_plan) report.plan = *campaign.plan;

  Transform T_world_base = Transform::Identity();
  if (loaded) {
    T_world_base = loaded->calibration.T_world_base;
    report.frames = api::TestFrames::kCalibration;
  } else {
    T_world_base = RegisterTrackerOnTestShots(shots, commanded);
    report.frames = api::TestFrames::kRegisteredOnTest;
    report.notes.push_back(
        "the campaign has no calibration: the tracker frame was registered on the test shots themselves, which "
        "absorbs the rigid part of the robot's error; fit the campaign (\"scope\": \"frames\") on shots of role "
        "calibration to tie the tracker to the base independently");
  }
  report.base = api::TransformToPose(T_world_base);

  const bool orientation = campaign.type() == MeasurementType::kPose;
  const Transform T_base_world = T_world_base.inverse();
  std::vector<Iso9283Shot> measured, calibrated;
  std::optional<KinematicsWorkspace> calibrated_ws;
  if (loaded) calibrated_ws.emplace(loaded->calibration.model);
  for (std::size_t i = 0; i < shots.size(); ++i) {
    const TestShot& s = shots[i];
    const Transform attained = T_base_world * s.measurement.T_world_tool;
    measured.push_back({.pose = s.pose, .cycle = s.cycle, .attained = attained, .commanded = commanded[i]});
    if (loaded) {
      const Transform predicted = ForwardKinematics(loaded->calibration.model, s.measurement.joints,
                                                    loaded->calibration.errors, &*calibrated_ws, s.measurement.payload);
      calibrated.push_back({.pose = s.pose, .cycle = s.cycle, .attained = attained,
                            .commanded = T_base_world * predicted});
    }
  }
  const Iso9283Result result = Iso9283Analyse(measured, orientation);
  report.cycles = result.cycles;
  report.measured = api::ToWire(result);
  if (loaded) report.calibrated = api::ToWire(Iso9283Analyse(calibrated, orientation));
  AddIso9283Notes(result, orientation, read, &report);
  return report;
}

}  // namespace robocal::server
