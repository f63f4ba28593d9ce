// robocal fit, compensate, evaluate, export, report: a campaign's calibration.
#include <cmath>
#include <iomanip>
#include <limits>
#include <optional>
#include <sstream>

#include "cli.h"
#include "command.h"
#include "robocal/client/csv.h"
#include "robocal/core/accuracy.h"
#include "robocal/core/model_choice.h"
#include "support.h"

namespace robocal::cli {
namespace {

// "geometric", "compliance", "harmonics 2", "compliance + harmonics 1".
std::string ModelName(const api::ModelWire& m) { return api::ToCore(m).Describe(); }

void PrintCalibration(const api::CalibrationResult& c, std::ostream& out) {
  out << std::left << std::setw(14) << "parameter" << std::right << std::setw(14) << "value" << std::setw(14) << "std"
      << "  unit\n";
  for (const api::ParameterEstimate& p : c.parameters) {
    // A compliance is some 1e-5 deg/(N*m): in significant digits.
    const bool small = p.unit != "mm" && p.unit != "deg";
    std::ostringstream value, std;
    if (small) {
      value << std::setprecision(4) << p.value;
      std << std::setprecision(3) << p.std;
    } else {
      value << Fixed(p.value, 5);
      std << Fixed(p.std, 5);
    }
    out << std::left << std::setw(14) << p.name << std::right << std::setw(14) << value.str() << std::setw(14)
        << std.str() << "  " << p.unit << "\n";
  }
  if (!c.dropped.empty()) {
    out << "not identifiable (left out):\n";
    for (const api::DroppedParameterWire& d : c.dropped) out << "  " << d.name << ": " << d.reason << "\n";
  }
  out << "residuals rms position " << Fixed(c.residuals_before.rms_position_mm, 4) << " mm -> "
      << Fixed(c.residuals_after.rms_position_mm, 4) << " mm, rms orientation "
      << Fixed(c.residuals_before.rms_orientation_deg, 5) << " deg -> "
      << Fixed(c.residuals_after.rms_orientation_deg, 5) << " deg\n";
  if (c.model_error.estimated) {
    const bool angle = c.measurement_type != MeasurementType::kPosition;
    out << "robot error the geometric model does not explain: " << Fixed(c.model_error.model_error_mm, 3) << " mm";
    if (angle) out << ", " << Fixed(c.model_error.model_error_deg, 4) << " deg";
    out << " RMS (tracker: " << Fixed(c.model_error.tracker_rms_mm, 3) << " mm";
    if (angle) out << ", " << Fixed(c.model_error.tracker_rms_deg, 4) << " deg";
    out << ")\n";
  }
  out << "model: " << ModelName(c.model) << "\n";
  if (c.priors) {
    out << "priors on " << c.priors->num_priors << " parameters, effective parameters "
        << Fixed(c.priors->effective_parameters, 1) << "\n";
    if (!c.priors->candidates.empty()) {
      out << "prior scale chosen by " << c.priors->folds << "-fold cross-validation (held-out E_xyz, mm):\n";
      for (const api::PriorScaleWire& p : c.priors->candidates) {
        out << (p.chosen ? "  * " : "    ") << (std::isfinite(p.scale) ? "x " + Fixed(p.scale, 2) : "none") << ": ";
        if (p.failed_folds > 0) {
          out << p.failed_folds << " fold(s) failed: " << p.note << "\n";
        } else {
          out << "mean " << Fixed(p.cv_mean_mm, 4) << " +- " << Fixed(p.cv_standard_error_mm, 4) << "\n";
        }
      }
    }
    if (!c.priors->prior_determined.empty()) {
      out << "determined by the prior rather than the data:";
      for (const api::PriorDeterminedWire& d : c.priors->prior_determined) out << " " << d.parameter;
      out << "\n";
    }
  }
  if (c.model_choice) {
    out << "chosen by " << c.model_choice->folds << "-fold cross-validation (held-out E_xyz, mm):\n";
    for (const api::ModelCandidateWire& m : c.model_choice->candidates) {
      out << (m.chosen ? "  * " : "    ") << m.description << ", " << m.num_parameters << " parameters: ";
      if (m.failed_folds > 0) {
        out << m.failed_folds << " fold(s) failed: " << m.note << "\n";
      } else {
        out << "mean " << Fixed(m.cv_mean_mm, 4) << " +- " << Fixed(m.cv_standard_error_mm, 4) << ", RMS "
            << Fixed(m.cv_rms_mm, 4) << "\n";
      }
    }
  }
  if (!c.outliers.empty()) {
    out << c.outliers.size() << " outlier(s) excluded (normalised residual over " << Fixed(c.robust.threshold, 2)
        << " sigma):";
    for (const api::OutlierWire& o : c.outliers) {
      out << " #" << o.sequence << (o.reflector.empty() ? "" : " " + o.reflector) << " ("
          << (o.cause == OutlierMeasurement::Cause::kStale ? "stale reading, " : "") << Fixed(o.normalized_residual, 1)
          << ")";
    }
    out << "\n";
  }
  out << "condition number " << Fixed(c.condition_number, 2) << "; " << api::WireName(c.summary.termination) << ": "
      << c.summary.brief << "\n";
  if (!c.stored) out << "NOT stored as the campaign's calibration: " << c.summary.message << "\n";
}

// "joint_maps=4deg" or "joint_maps=4deg:1-5" (the joints, 1-based, a range or a list joined by '+'): the spacing
// and the joints of a model's maps; false if `part` is not one.
bool ParseJointMapsPart(const std::string& part, api::JointMapsWire* maps) {
  const std::string key = "joint_maps=";
  if (part.rfind(key, 0) != 0) return false;
  std::string spacing = part.substr(key.size()), joints;
  if (const std::size_t colon = spacing.find(':'); colon != std::string::npos) {
    joints = spacing.substr(colon + 1);
    spacing = spacing.substr(0, colon);
  }
  if (spacing.size() > 3 && spacing.compare(spacing.size() - 3, 3, "deg") == 0) spacing.resize(spacing.size() - 3);
  maps->knot_spacing_deg = tools::ParseDoubleFlag("--model joint_maps", spacing, 0.0);
  std::size_t start = 0;
  while (!joints.empty() && start <= joints.size()) {
    const std::size_t plus = std::min(joints.find('+', start), joints.size());
    const std::string item = joints.substr(start, plus - start);
    const std::size_t dash = item.find('-');
    const int from =
        static_cast<int>(tools::ParseIntegerFlag("--model joint_maps joints", item.substr(0, dash), 1, 64));
    const int to =
        dash == std::string::npos
            ? from
            : static_cast<int>(tools::ParseIntegerFlag("--model joint_maps joints", item.substr(dash + 1), 1, 64));
    for (int j = from; j <= to; ++j) maps->joints.push_back(j);
    start = plus + 1;
  }
  return true;
}

// --model auto | geometric | a comma list of compliance, harmonics=N, joint_maps=Sdeg[:JOINTS] and smoothness=L
// (e.g. compliance,harmonics=2 or compliance,joint_maps=4deg:1-5).
void ParseModelOption(const std::string& text, api::FitRequest* request) {
  std::optional<api::JointMapsWire> maps;
  std::optional<double> smoothness;
  std::string rest;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string part = text.substr(start, comma - start);
    api::JointMapsWire parsed;
    if (ParseJointMapsPart(part, &parsed)) {
      maps = parsed;
    } else if (part.rfind("smoothness=", 0) == 0) {
      smoothness = tools::ParseDoubleFlag("--model smoothness", part.substr(11), 0.0);
    } else {
      rest += (rest.empty() ? "" : ",") + part;
    }
    start = comma + 1;
  }
  JointErrorTerms terms;
  std::string error;
  if (!ParseModelName(rest.empty() ? "geometric" : rest, &terms, &request->model_auto, &error)) {
    throw UsageError("--model: " + error + ", joint_maps=Sdeg[:JOINTS] and smoothness=L");
  }
  if (smoothness && !maps) throw UsageError("--model: smoothness=L applies to joint_maps only");
  request->model = api::ToWire(terms);
  if (maps) {
    if (request->model_auto) throw UsageError("--model: auto chooses its own model: leave out joint_maps");
    if (smoothness) maps->smoothness = *smoothness;
    request->model.joint_maps = maps;  // the service checks the spacing, the joints and the smoothness
  }
}

}  // namespace

// --priors auto | defaults | KEY=V,...: KEY a group of the priors object (lengths_mm, angles_deg, joint_offsets_deg,
// joint_offsets_mm, base_length_mm, base_angle_deg, tool_length_mm, tool_angle_deg, scale) or a parameter name
// (its value in the parameter's unit). The service checks names and ranges and names the field.
void ParsePriorsOption(const std::string& text, api::FitRequest* request) {
  if (text == "auto") {
    request->priors_auto = true;
    return;
  }
  api::PriorsWire priors;
  if (text != "defaults") {
    for (const std::string& item : tools::SplitList("--priors", text)) {
      const std::size_t eq = item.find('=');
      if (eq == std::string::npos)
        throw UsageError("--priors takes auto, defaults or KEY=VALUE,...; got '" + item + "'");
      const std::string key = item.substr(0, eq);
      const double value =
          tools::ParseDoubleFlag("--priors", item.substr(eq + 1), std::numeric_limits<double>::lowest());
      double* group = key == "lengths_mm"          ? &priors.lengths_mm
                      : key == "angles_deg"        ? &priors.angles_deg
                      : key == "joint_offsets_deg" ? &priors.joint_offsets_deg
                      : key == "joint_offsets_mm"  ? &priors.joint_offsets_mm
                      : key == "scale"             ? &priors.scale
                                                   : nullptr;
      std::optional<double>* frame = key == "base_length_mm"   ? &priors.base_length_mm
                                     : key == "base_angle_deg" ? &priors.base_angle_deg
                                     : key == "tool_length_mm" ? &priors.tool_length_mm
                                     : key == "tool_angle_deg" ? &priors.tool_angle_deg
                                                               : nullptr;
      if (group != nullptr) {
        *group = value;
      } else if (frame != nullptr) {
        *frame = value;
      } else {
        priors.parameters[key] = value;
      }
    }
  }
  request->priors = priors;
}

int Fit(Invocation& in) {
  api::FitRequest request;
  if (in.Has("--parameters")) request.parameters = tools::SplitList("--parameters", in.Option("--parameters"));
  request.register_base = !in.Has("--no-register-base");
  request.max_iterations = static_cast<int>(in.Integer("--max-iterations", 100, 1, 1000));
  request.reject_outliers = !in.Has("--keep-outliers");
  request.estimate_model_error = !in.Has("--no-model-error");
  request.scope = in.Enum("--scope", request.scope);
  if (in.Has("--model")) ParseModelOption(in.Option("--model"), &request);
  if (in.Has("--priors")) ParsePriorsOption(in.Option("--priors"), &request);
  if (in.Has("--folds") || in.Has("--cv-seed") || in.Has("--cv-maps")) {
    if (!request.model_auto && !request.priors_auto) {
      throw UsageError("--folds, --cv-seed and --cv-maps apply with --model auto or --priors auto only");
    }
    request.cross_validation.joint_maps = in.Has("--cv-maps");
    // Any integer: the service checks the range and names cross_validation.folds.
    request.cross_validation.folds = static_cast<int>(in.Integer("--folds", request.cross_validation.folds, 0, 1000));
    request.cross_validation.seed =
        static_cast<std::uint64_t>(in.Integer("--cv-seed", 1, 0, std::numeric_limits<std::int64_t>::max()));
  }
  // The service checks the range and names the field.
  request.outlier_probability =
      in.Number("--outlier-probability", request.outlier_probability, std::numeric_limits<double>::lowest());
  api::CalibrationResult result;
  if (in.Has("--async")) {
    const api::Operation started = in.Client().StartFit(in.args[0], request);
    in.err << "operation " << started.id << "\n";
    const api::Operation done = WaitWithProgress(in, started.id);
    if (done.state == api::OperationState::kFailed || !done.fit) return ReportUnfinished(done, in.err);
    result = *done.fit;
  } else {
    result = in.Client().Fit(in.args[0], request);
  }
  if (in.json) {
    PrintJson(in.out, result);
  } else {
    PrintCalibration(result, in.out);
  }
  return kExitOk;
}

int Compensate(Invocation& in) {
  const api::Campaign campaign = in.Client().GetCampaign(in.args[0]);
  const api::Robot robot = in.Client().GetRobot(campaign.robot);
  api::CompensateRequest request;
  TargetFrame frame = TargetFrame::kTracker;
  if (in.Has("--frame") && !ParseTargetFrame(in.Option("--frame"), &frame)) {
    throw UsageError("--frame must be tracker or base, got \"" + in.Option("--frame") + "\"");
  }
  std::istringstream text(ReadFile(in.args[1]));
  try {
    request.targets = client::ReadCompensationTargetsCsv(text, static_cast<int>(robot.joints.size()), frame);
  } catch (const std::runtime_error& e) {
    throw UsageError(in.args[1] + ": " + e.what());
  }
  if (request.targets.empty()) throw UsageError(in.args[1] + ": no rows");
  if (in.Has("--frame") && !request.targets[0].pose) throw UsageError("--frame applies to pose targets only");
  if (in.Has("--payload")) {
    const api::PayloadWire payload = ParsePayloadFlag(in.Option("--payload"));
    for (api::CompensationTargetWire& t : request.targets) t.payload = payload;
  }
  // Any positive number: the service says which it takes (its error names max_joint_jump_deg).
  request.sequence = in.Has("--sequence");
  request.max_joint_jump_deg = in.Number("--max-jump", request.max_joint_jump_deg, 0.0);
  if (in.Has("--max-jump") && !request.sequence) throw UsageError("--max-jump applies with --sequence only");
  const api::CompensatedTargets result = in.Client().Compensate(campaign.id, request);
  Output output(in.Option("--out"), in.out);
  if (in.json) {
    PrintJson(output.stream(), result);
  } else {
    client::WriteCompensationCsv(output.stream(), robot.joints, result.results, request.sequence);
  }
  return kExitOk;
}

int Export(Invocation& in) {
  const std::string format = in.Option("--format", "urdf");
  std::string text;
  if (format == "urdf") {
    text = in.Client().GetCalibrationUrdf(in.args[0]);
  } else if (format == "json") {
    text = nlohmann::json(in.Client().GetCalibration(in.args[0])).dump(2) + "\n";
  } else if (format == "dh" || format == "mdh") {
    const GeometryConvention convention =
        format == "dh" ? GeometryConvention::kStandardDh : GeometryConvention::kModifiedDh;
    text = nlohmann::json(in.Client().GetCalibrationDh(in.args[0], convention)).dump(2) + "\n";
  } else {
    throw UsageError("--format takes urdf, dh, mdh or json, got '" + format + "'");
  }
  Output(in.Option("--out"), in.out).stream() << text;
  return kExitOk;
}

int Report(Invocation& in) {
  std::optional<double> h_mm;
  // Any number: the service says which it takes (its error names h_mm and the range).
  if (in.Has("--h-mm")) h_mm = in.Number("--h-mm", 0.0, std::numeric_limits<double>::lowest());
  // Fetched before the file is opened: a refused report leaves no empty file behind.
  const std::string page = in.Client().GetCampaignReport(in.args[0], h_mm);
  const std::string file = in.Option("--out");
  Output(file, in.out).stream() << page;
  if (!file.empty()) {
    in.out << "report of campaign " << in.args[0] << " written to " << file << " (" << page.size() << " bytes)\n";
  }
  return kExitOk;
}

int Evaluate(Invocation& in) {
  api::EvaluateRequest request;
  // Any number: the service says which it takes (its error names h_mm and the range).
  request.h_mm = in.Number("--h-mm", request.h_mm, std::numeric_limits<double>::lowest());
  const api::Evaluation e = in.Client().Evaluate(in.args[0], request);
  if (in.json) {
    PrintJson(in.out, e);
    return kExitOk;
  }
  in.out << FormatAccuracyTable(api::ToCore(e.nominal),
                                "nominal model, " + std::to_string(e.num_validation) + " validation measurements");
  in.out << FormatAccuracyTable(api::ToCore(e.calibrated), "calibrated model");
  const api::Improvement& i = e.improvement_percent;
  in.out << "improvement: E_xyz mean " << Fixed(i.e_xyz_mean, 1) << " %, E_xyz RP " << Fixed(i.e_xyz_rp, 1)
         << " %, E_tot mean " << Fixed(i.e_tot_mean, 1) << " %, E_tot RP " << Fixed(i.e_tot_rp, 1) << " %\n";
  if (e.note) in.out << "note: " << *e.note << "\n";
  return kExitOk;
}

}  // namespace robocal::cli
