// The service's calibration: the fit, and what a stored calibration answers (compensation, forward kinematics
// of the calibrated robot, accuracy on the validation measurements).
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <optional>
#include <sstream>

#include "robocal/core/accuracy.h"
#include "robocal/core/compensation.h"
#include "robocal/core/dh_table.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/identification.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/model_choice.h"
#include "robocal/core/prediction.h"
#include "robocal/server/service.h"
#include "robocal/urdf/urdf_export.h"
#include "service_support.h"

namespace robocal::server {
namespace {

using api::ApiError;
using api::Status;

// For a robot holding joint harmonics or error maps (a calibration registered as a robot): which of the fit's
// poses leave the joint ranges they were identified over (calibrated_from.joint_ranges for harmonics, a map's
// knots for a map), where a harmonic fitted over part of a turn extrapolates and a map is held at its end value
// (docs/robots.md). Empty when none does, or the robot holds none.
std::string BeyondCalibratedRanges(const api::RegisterRobotRequest& definition, const RobotModel& model,
                                   const std::vector<Measurement>& measurements) {
  const int n = model.num_joints();
  const bool have_ranges =
      definition.calibrated_from && definition.calibrated_from->joint_ranges.size() == static_cast<std::size_t>(n);
  // Per joint: the range its held terms cover (in the wire's unit), or none.
  std::vector<std::optional<std::pair<double, double>>> ranges(static_cast<std::size_t>(n));
  bool any = false;
  for (int i = 0; i < n; ++i) {
    const JointSpec& joint = model.spec().joints[static_cast<std::size_t>(i)];
    if (!joint.error_map.empty()) {
      ranges[i] = {joint.error_map.first_knot_rad * kDegPerRad, joint.error_map.last_knot_rad() * kDegPerRad};
    } else if (have_ranges && !joint.harmonics_rad.isZero(0.0)) {
      const api::JointRangeWire& r = definition.calibrated_from->joint_ranges[static_cast<std::size_t>(i)];
      ranges[i] = {r.min, r.max};
    }
    any = any || ranges[i].has_value();
  }
  if (!any) return "";
  bool harmonics = false, maps = false;
  std::vector<int> left(static_cast<std::size_t>(n), 0);
  int poses = 0;
  for (const Measurement& m : measurements) {
    const std::vector<double> q = api::JointsToWire(model, m.joints);
    bool outside = false;
    for (int i = 0; i < n; ++i) {
      if (!ranges[i]) continue;
      // 1e-6 deg / mm: the round trip through the core's radians moves a range's own end by an ulp.
      if (q[i] < ranges[i]->first - 1e-6 || q[i] > ranges[i]->second + 1e-6) {
        ++left[i];
        outside = true;
        (model.spec().joints[static_cast<std::size_t>(i)].error_map.empty() ? harmonics : maps) = true;
      }
    }
    poses += outside ? 1 : 0;
  }
  if (poses == 0) return "";
  std::ostringstream out;
  out << std::setprecision(4) << poses << " of " << measurements.size() << " shots leave the joint ranges the robot's "
      << (harmonics && maps ? "joint harmonics and error maps"
          : harmonics       ? "joint harmonics"
                            : "error maps")
      << " were identified over (";
  bool first = true;
  for (int i = 0; i < n; ++i) {
    if (left[i] == 0) continue;
    out << (first ? "" : ", ") << model.joint_name(i) << " " << ranges[i]->first << " .. " << ranges[i]->second << " "
        << api::JointUnit(model, i) << ": " << left[i] << " beyond";
    first = false;
  }
  out << "); there " << (harmonics ? "its harmonics extrapolate" : "") << (harmonics && maps ? " and " : "")
      << (maps ? "its maps hold their end values" : "");
  return out.str();
}

// Refuses, before any measurement is loaded, a fit whose Jacobian (rows x measurements x parameters) exceeds
// max_fit_jacobian_entries: its size bounds the fit's memory and the time of each iteration.
void CheckFitSize(const RobotModel& model, const IdentificationOptions& options, std::int64_t measurements,
                  bool parameters_requested, const api::Limits& limits) {
  // Within the limit with every error parameter: no need to know how many are identifiable (a probe of the model).
  if (!parameters_requested &&
      MeasurementRows(options.measurement_type) * measurements * model.num_error_parameters() <=
          limits.max_fit_jacobian_entries) {
    return;
  }
  const std::int64_t parameters =
      parameters_requested ? static_cast<std::int64_t>(options.parameters.size())
                           : static_cast<std::int64_t>(
                                 FindIdentifiableParameters(model, options.measurement_type, options.identifiability)
                                     .identifiable.size());
  const std::int64_t rows = MeasurementRows(options.measurement_type);
  const std::int64_t entries = rows * measurements * parameters;
  if (entries <= limits.max_fit_jacobian_entries) return;
  const std::int64_t most = limits.max_fit_jacobian_entries / std::max<std::int64_t>(1, rows * parameters);
  const std::string reason =
      api::OverLimit(entries,
                     "Jacobian entries (" + std::to_string(rows) + " rows x " + std::to_string(measurements) +
                         " calibration measurements x " + std::to_string(parameters) + " parameters)",
                     "max_fit_jacobian_entries", limits.max_fit_jacobian_entries) +
      "; this fit takes at most " + std::to_string(most) + " calibration measurements";
  std::vector<api::FieldViolation> details = {{"measurements", reason}};
  if (parameters_requested) details.push_back({"parameters", reason});
  throw ApiError(Status::kFailedPrecondition, "the fit is too large: " + reason, details);
}

// An offset named for a nest without shots cannot be estimated: FAILED_PRECONDITION naming the request's field.
void CheckFitReflectorsMeasured(const RobotModel& model, const std::vector<Reflector>& reflectors,
                                const std::vector<std::string>& parameters,
                                const std::vector<Measurement>& measurements) {
  if (reflectors.empty()) return;
  std::vector<char> measured(reflectors.size(), 0);
  for (const Measurement& m : measurements) {
    if (m.reflector >= 0) measured[static_cast<std::size_t>(m.reflector)] = 1;
  }
  const int n = model.num_error_parameters();
  for (std::size_t i = 0; i < parameters.size(); ++i) {
    const int index = ParameterIndex(model, reflectors, parameters[i]);
    if (index >= n && !measured[static_cast<std::size_t>((index - n) / 3)]) {
      const std::string reason =
          "reflector \"" + reflectors[static_cast<std::size_t>((index - n) / 3)].id + "\" has no measurements";
      throw ApiError(Status::kFailedPrecondition, "cannot fit " + parameters[i] + ": " + reason,
                     {{"parameters[" + std::to_string(i) + "]", reason}});
    }
  }
}

// The fit the request asks for: the model chosen by cross-validation ("model": "auto"), the priors' scale chosen
// by it ("priors": "auto"), or the one fit of the request's model.
Calibration IdentifyAsRequested(const RobotModel& model, const std::vector<Measurement>& measurements,
                                const IdentificationOptions& options, const api::FitRequest& req) {
  ModelChoiceOptions choice;
  choice.folds = req.cross_validation.folds;
  choice.seed = req.cross_validation.seed;
  if (req.cross_validation.joint_maps) choice.map_knot_spacings_rad = kMapKnotSpacingsRad;
  PriorChoiceOptions prior_choice;
  prior_choice.folds = req.cross_validation.folds;
  prior_choice.seed = req.cross_validation.seed;
  return req.model_auto    ? IdentifyWithModelChoice(model, measurements, options, choice)
         : req.priors_auto ? IdentifyWithPriorChoice(model, measurements, options, prior_choice)
                           : Identify(model, measurements, options);
}

// The fit as returned: the calibration's wire form over the measurements' `sequences`, what it says of poses
// beyond the robot's calibrated joint ranges, the campaign's names, and when.
api::CalibrationResult FitResultOf(const Calibration& calibration, const std::vector<std::int64_t>& sequences,
                                   const api::StoredCampaign& campaign, const RobotModel& model,
                                   const std::vector<Measurement>& measurements) {
  api::CalibrationResult result = api::ToWire(calibration, sequences);
  if (const std::string beyond = BeyondCalibratedRanges(campaign.robot_definition, model, measurements);
      !beyond.empty()) {
    result.summary.message += "; " + beyond;
    result.summary.brief += "; " + beyond;
  }
  result.campaign = campaign.id;
  result.robot = campaign.robot;
  result.measurement_type = campaign.type();
  result.created_unix_ms = NowUnixMs();
  return result;
}

// Stores a fit as its campaign's calibration (result.campaign), with the last measurement it saw.
void PutFitCalibration(Storage* storage, const Calibration& calibration, const api::CalibrationResult& result,
                       const std::vector<std::int64_t>& sequences) {
  api::StoredCalibration stored = api::ToStored(calibration, result);
  // What the fit saw, so that what recomputes from the stored measurements (the report) leaves out the
  // ones uploaded after it.
  if (!sequences.empty()) stored.last_calibration_sequence = sequences.back();
  storage->Put(kCalibrations, result.campaign, nlohmann::json(stored).dump());
}

}  // namespace

FitReply Service::Fit(const std::string& campaign_id, const nlohmann::json& body) {
  const api::StoredCampaign campaign = LoadCampaign(campaign_id);
  const RobotModel nominal = api::BuildModel(campaign.robot_definition);
  const std::vector<Reflector> reflectors = api::ToCore(campaign.reflectors);
  const api::FitRequest req = api::ParseFitRequest(body, nominal, options_.limits, reflectors);
  // The model the fit estimates: the robot with the request's joint terms ("auto" starts from the geometric one,
  // and the largest candidate sizes the fit).
  const RobotModel parsed_model = api::FitModel(req, nominal);
  const RobotModel largest =
      req.model_auto
          ? nominal.WithErrorTerms({.compliance = nominal.has_masses(), .joint_harmonics = kMaxJointHarmonics})
          : parsed_model;
  const std::int64_t count = storage_->CountMeasurements(campaign_id, "calibration");
  if (count == 0) {
    throw ApiError(Status::kFailedPrecondition, "the campaign has no calibration measurements",
                   {{"measurements", "upload measurements with role calibration first"}});
  }
  IdentificationOptions options =
      api::ToIdentificationOptions(req, parsed_model, campaign.type(), api::NoiseOf(campaign), reflectors);
  CheckFitSize(largest, options, count, !req.parameters.empty(), options_.limits);
  auto measurements = std::make_shared<std::vector<Measurement>>();
  auto sequences = std::make_shared<std::vector<std::int64_t>>();
  measurements->reserve(static_cast<std::size_t>(count));
  sequences->reserve(static_cast<std::size_t>(count));
  // Each carries its stale flag (set on upload): the fit leaves stale readings out and lists them.
  ForEachMeasurement(storage_, campaign_id, "calibration", [&](const StoredMeasurement& s) {
    measurements->push_back(MeasurementToCore(parsed_model, ReadMeasurement(s), campaign));
    sequences->push_back(s.sequence);
  });
  // Joint maps are placed over the measurements' range of each joint; the fit's size counts their coefficients.
  const RobotModel model = req.model.joint_maps ? api::FitModel(req, nominal, *measurements) : parsed_model;
  if (req.model.joint_maps) CheckFitSize(model, options, count, false, options_.limits);
  CheckFitReflectorsMeasured(model, reflectors, req.parameters, *measurements);

  // Identifies and returns the fit; stores it as the calibration only if `control` never stopped it: a fit cut
  // short by the deadline or a cancel is not the campaign's calibration, so it is returned, not stored.
  auto fit = [this, campaign, model, measurements, sequences, options, req](WorkControl& control) {
    IdentificationOptions o = options;
    o.progress = [this, &control](double fraction) {
      if (options_.on_fit_progress) options_.on_fit_progress();
      return control(fraction);
    };
    const Calibration calibration = IdentifyAsRequested(model, *measurements, o, req);
    if (calibration.summary.termination == Termination::kFailure) {
      throw ApiError(Status::kFailedPrecondition, "identification failed: " + calibration.summary.message,
                     {{"measurements", calibration.summary.message}});
    }
    api::CalibrationResult result = FitResultOf(calibration, *sequences, campaign, model, *measurements);
    result.stored = control.stop() == Stop::kNone && control.StillOwned();
    if (result.stored) PutFitCalibration(storage_, calibration, result, *sequences);
    return result;
  };

  if (req.async) {
    api::Operation op;
    op.id = NewId("op");
    op.kind = api::OperationKind::kFit;
    op.campaign = campaign_id;
    op.fit_request = req;
    return operations_.Start(op, [fit](WorkControl& control, api::Operation* done) {
      api::CalibrationResult result = fit(control);
      if (control.stop() == Stop::kCancel) {
        result.summary.message = "cancelled after " + std::to_string(result.summary.iterations) +
                                 " iterations; the best parameters so far, not stored";
      }
      done->fit = std::move(result);
    });
  }
  const TrimWhenDone trim(&trimmer_, true);
  WorkControl control(std::chrono::steady_clock::now() + options_.request_deadline);
  api::CalibrationResult result = fit(control);
  if (control.stop() == Stop::kDeadline) {
    DescribeDeadlineStop(options_.request_deadline, "the best parameters so far, not stored as the calibration",
                         "use async: true for longer fits", &result.summary);
  }
  return result;
}

Service::Calibrated Service::LoadCalibrated(const std::string& campaign_id) {
  api::StoredCampaign campaign = LoadCampaign(campaign_id);
  RobotModel model = api::BuildModel(campaign.robot_definition);
  const auto doc = storage_->Get(kCalibrations, campaign_id);
  if (!doc) {
    throw ApiError(Status::kFailedPrecondition, "campaign \"" + campaign_id + "\" is not calibrated (POST :fit)",
                   {{"campaign", "not calibrated"}});
  }
  const api::StoredCalibration stored = ReadStored<api::StoredCalibration>(*doc);
  try {
    Calibration calibration = api::Restore(model, stored);
    return {std::move(campaign), std::move(model), std::move(calibration), stored.result,
            stored.last_calibration_sequence};
  } catch (const api::WireError& e) {
    throw ApiError(Status::kInternal, "stored calibration of \"" + campaign_id + "\" is unreadable: " + e.what());
  }
}

api::CalibrationResult Service::GetCalibration(const std::string& campaign_id) {
  (void)LoadCampaign(campaign_id);
  const auto doc = storage_->Get(kCalibrations, campaign_id);
  if (!doc) throw ApiError(Status::kNotFound, "campaign \"" + campaign_id + "\" has no calibration yet (POST :fit)");
  return ReadStored<api::StoredCalibration>(*doc).result;
}

namespace {

// What a geometric export of a calibration with joint terms leaves out, said in the export.
std::string JointTermsNote(const Calibration& c) {
  const std::string fitted =
      c.model.joint_terms().empty() ? "" : "the calibration's " + c.model.error_terms().Describe() + " terms";
  const std::string held = c.model.has_fixed_joint_terms() ? "the joint terms the robot holds" : "";
  return fitted + (fitted.empty() || held.empty() ? "" : " and ") + held +
         " (joint deflections) are not written here: this is its geometry only; compensate through robocal "
         "for the rest";
}

}  // namespace

std::string Service::CalibrationUrdf(const std::string& campaign_id) {
  const Calibrated loaded = LoadCalibrated(campaign_id);
  const Calibration& c = loaded.calibration;
  // The geometric part of the errors (a model's joint terms follow them; a URDF has no place for them).
  const Eigen::VectorXd geometric = c.errors.head(loaded.model.num_geometric_parameters());
  // The nominal model with the calibrated base registration; the URDF holds the chain, not the registration.
  std::string text = loaded.campaign.robot_definition.urdf
                         ? urdf::ExportCalibratedUrdf(*loaded.campaign.robot_definition.urdf, loaded.model, geometric,
                                                      c.model.T_world_base())
                         : urdf::GenerateCalibratedUrdf(loaded.model, geometric, c.model.T_world_base());
  if (c.model.deflects()) {
    // After the XML declaration, if any: a comment may stand anywhere after it.
    const std::size_t declaration = text.rfind("<?xml", 0) == 0 ? text.find("?>") : std::string::npos;
    const std::size_t at = declaration == std::string::npos ? 0 : declaration + 2;
    text.insert(
        at, (at == 0 ? "" : "\n") + std::string("<!-- robocal: ") + JointTermsNote(c) + " -->" + (at == 0 ? "\n" : ""));
  }
  return text;
}

api::RegisterRobotRequest Service::CalibrationDh(const std::string& campaign_id, GeometryConvention convention) {
  const Calibrated loaded = LoadCalibrated(campaign_id);
  const Calibration& c = loaded.calibration;
  const char* name = ToString(convention);
  try {
    const RobotModelSpec spec =
        CalibratedDhSpec(c.model.WithErrorTerms({}), c.errors.head(c.model.num_geometric_parameters()), convention);
    // An id that registers as it is: the campaign's, with the convention (ids are at most 64 characters).
    const std::string suffix = std::string("-") + name;
    const std::string id = campaign_id.substr(0, 64 - suffix.size()) + suffix;
    return api::DefinitionOf(id, spec,
                             "robot '" + loaded.campaign.robot + "' as calibrated by campaign '" + campaign_id +
                                 "': " + name + " table from the calibrated joint axes, base = tracker -> frame 0" +
                                 (c.model.deflects() ? "; " + JointTermsNote(c) : ""));
  } catch (const DhTableError& e) {
    throw ApiError(Status::kFailedPrecondition,
                   "the calibration of \"" + campaign_id + "\" has no " + name + " table: " + e.what(),
                   {{"format", std::string("the calibrated kinematics cannot be written as a ") + name + " table (" +
                                   e.field() + ")"}});
  }
}

api::ForwardResult Service::CampaignForward(const std::string& campaign_id, const nlohmann::json& body) {
  const Calibrated loaded = LoadCalibrated(campaign_id);
  const api::ForwardRequest req = api::ParseForwardRequest(body, loaded.model, options_.limits);
  const TrimWhenDone trim(&trimmer_, req.joints.size() >= kLargeRequest);
  api::ForwardResult result;
  result.campaign = campaign_id;
  result.frame = "tracker";
  // Under the request's payload, else the campaign's (a compliance model deflects under it).
  const Payload payload = req.payload               ? api::ToCore(*req.payload)
                          : loaded.campaign.payload ? api::ToCore(*loaded.campaign.payload)
                                                    : Payload();
  result.poses = ForwardPoses(loaded.calibration.model, loaded.calibration.errors, req, payload);
  return result;
}

api::CompensatedTargets Service::Compensate(const std::string& campaign_id, const nlohmann::json& body) {
  const Calibrated loaded = LoadCalibrated(campaign_id);
  const RobotModel& model = loaded.model;
  const api::CompensateRequest req = api::ParseCompensateRequest(body, model, options_.limits);
  const TrimWhenDone trim(&trimmer_, req.targets.size() >= kLargeRequest);
  api::CompensatedTargets result;
  result.campaign = campaign_id;
  std::vector<CompensationTarget> targets;
  targets.reserve(req.targets.size());
  for (const api::CompensationTargetWire& t : req.targets) {
    CompensationTarget target;
    if (t.pose) {
      target.pose = api::PoseToTransform(*t.pose);
      target.frame = t.frame;
      if (!t.start_joints.empty()) target.start = api::JointsToCore(model, t.start_joints);
      target.configuration = t.configuration;
    } else {
      target.joints = api::JointsToCore(model, t.joints);
    }
    if (t.payload) {
      target.payload = api::ToCore(*t.payload);
    } else if (loaded.campaign.payload) {
      target.payload = api::ToCore(*loaded.campaign.payload);
    }
    targets.push_back(std::move(target));
  }
  // A program (sequence) is solved in order, each pose target from the previous result; otherwise the targets
  // are independent and solved on all threads.
  const std::vector<CompensationResult> solved =
      req.sequence ? CompensateSequence(loaded.calibration, model, targets)
                   : CompensateAll(loaded.calibration, model, targets, {}, options_.compensation_threads);
  // The accuracy each result will have: the fit's parameter covariance at its joints, the model error and the
  // campaign's repeatability (docs/compensation.md, "Predicted accuracy"). About 5 us a target, so it is spread
  // over the same threads as the solve.
  std::vector<Eigen::VectorXd> joints;
  std::vector<Payload> payloads;
  joints.reserve(solved.size());
  payloads.reserve(solved.size());
  for (std::size_t i = 0; i < solved.size(); ++i) {
    joints.push_back(solved[i].joints);
    payloads.push_back(targets[i].payload);
  }
  const std::vector<double> predicted = PredictPositionErrorBounds(
      loaded.calibration, joints, payloads, {.probability = 0.95, .repeatability_mm = loaded.campaign.repeatability_mm},
      options_.compensation_threads);
  result.results.reserve(solved.size());
  for (std::size_t i = 0; i < solved.size(); ++i) {
    api::Compensation c = api::ToWire(model, solved[i]);
    c.predicted_error_mm = predicted[i];
    if (const std::string beyond = BeyondMapKnots(loaded.calibration.model, solved[i].joints); !beyond.empty()) {
      c.message += (c.message.empty() ? "" : "; ") + beyond;
    }
    if (req.sequence && i > 0 && solved[i].joints.size() == model.num_joints() &&
        solved[i - 1].joints.size() == model.num_joints()) {
      // The largest revolute joint move from the previous result (prismatic axes are not compared in deg).
      double jump = -1.0;
      for (int k = 0; k < model.num_joints(); ++k) {
        if (model.joint_type(k) != JointType::kRevolute) continue;
        jump = std::max(jump, std::abs(solved[i].joints[k] - solved[i - 1].joints[k]) * kDegPerRad);
      }
      if (jump >= 0.0) {
        c.joint_jump_deg = jump;
        c.joint_jump = jump > req.max_joint_jump_deg;
      }
      c.branch_change = solved[i].configuration && solved[i - 1].configuration &&
                        *solved[i].configuration != *solved[i - 1].configuration;
    }
    result.results.push_back(std::move(c));
  }
  return result;
}

api::Evaluation Service::Evaluate(const std::string& campaign_id, const nlohmann::json& body) {
  const Calibrated loaded = LoadCalibrated(campaign_id);
  const api::EvaluateRequest req = api::ParseEvaluateRequest(body);
  const TrimWhenDone trim(&trimmer_, true);
  return EvaluateLoaded(loaded, req.h_mm);
}

api::Evaluation Service::EvaluateLoaded(const Calibrated& loaded, double h_mm, AccuracyReport* before_out,
                                        AccuracyReport* after_out) {
  const Calibration& calibration = loaded.calibration;
  const std::string& campaign_id = loaded.campaign.id;
  std::vector<Transform> measured, nominal, calibrated;
  KinematicsWorkspace ws(calibration.model);
  // With reflectors a shot is compared at its reflector's point: the given position for the nominal robot,
  // the identified one for the calibrated robot.
  const std::vector<Eigen::Vector3d> given =
      ReflectorsInTool(loaded.model, api::ToCore(loaded.campaign.reflectors), Eigen::VectorXd());
  const std::vector<Eigen::Vector3d> identified =
      ReflectorsInTool(loaded.model, calibration.reflectors, Eigen::VectorXd());
  ForEachMeasurement(storage_, campaign_id, "validation", [&](const StoredMeasurement& s) {
    const Measurement m = MeasurementToCore(loaded.model, ReadMeasurement(s), loaded.campaign);
    measured.push_back(m.T_world_tool);
    const Transform& before = ForwardKinematics(calibration.model, m.joints, Eigen::VectorXd(), &ws);
    nominal.push_back(m.reflector < 0 || static_cast<std::size_t>(m.reflector) >= given.size()
                          ? before
                          : AtReflector(before, given[m.reflector]));
    const Transform& after = ForwardKinematics(calibration.model, m.joints, calibration.errors, &ws, m.payload);
    calibrated.push_back(m.reflector < 0 || static_cast<std::size_t>(m.reflector) >= identified.size()
                             ? after
                             : AtReflector(after, identified[m.reflector]));
  });
  if (measured.empty()) {
    throw ApiError(Status::kFailedPrecondition, "the campaign has no validation measurements",
                   {{"measurements", "upload measurements with role validation first"}});
  }
  AccuracyReport before = ComputeAccuracy(nominal, measured, h_mm);
  AccuracyReport after = ComputeAccuracy(calibrated, measured, h_mm);
  api::Evaluation e;
  e.campaign = campaign_id;
  e.num_validation = static_cast<int>(measured.size());
  e.h_mm = h_mm;
  e.nominal = api::ToWire(before);
  e.calibrated = api::ToWire(after);
  e.improvement_percent = api::ImprovementOf(before, after);
  if (loaded.campaign.type() == MeasurementType::kPosition) {
    e.note = "position measurements carry no orientation: E_cos and E_tot compare against identity";
  }
  if (before_out != nullptr) *before_out = std::move(before);
  if (after_out != nullptr) *after_out = std::move(after);
  return e;
}

}  // namespace robocal::server
