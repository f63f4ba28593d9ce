// Drift checks (drift.h, docs/drift.md): the residual level against the calibration's own scatter, and the one
// parameter that best explains the residuals.
#include "robocal/core/drift.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "robocal/core/compensation.h"
#include "robocal/core/fit_diagnostics.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/random.h"
#include "robocal/core/reflectors.h"

namespace robocal {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The whitened squared residual sum of `shots` against (model, errors), and the position RMS (mm).
void Residuals(const RobotModel& model, const Eigen::VectorXd& errors, const std::vector<Measurement>& shots,
               const DriftCheckOptions& options, double* sum, double* rms_position_mm) {
  const std::vector<MeasurementResidualNorms> r =
      ComputeMeasurementResiduals(model, errors, shots, options.measurement_type, options.noise);
  double s = 0.0, p = 0.0;
  for (const MeasurementResidualNorms& m : r) {
    s += m.weighted * m.weighted;
    p += m.position_mm * m.position_mm;
  }
  *sum = s;
  *rms_position_mm = r.empty() ? kNaN : std::sqrt(p / static_cast<double>(r.size()));
}

// A fit of `parameters` only, by plain weighted least squares with the noise as given (no model error estimated,
// no outliers excluded: a check judges every shot it has).
Calibration FitOnly(const RobotModel& model, const std::vector<Measurement>& shots, const DriftCheckOptions& options,
                    std::vector<int> parameters) {
  std::sort(parameters.begin(), parameters.end());
  IdentificationOptions o;
  o.measurement_type = options.measurement_type;
  o.noise = options.noise;
  o.identifiability.noise = options.noise;
  o.parameters = std::move(parameters);
  o.register_base = options.register_frames;
  o.estimate_model_error = false;
  o.reject_outliers = false;
  return Identify(model, shots, o);
}

}  // namespace

std::vector<int> FrameParameters(const RobotModel& model, MeasurementType type, bool reflectors) {
  // The base site's six and the tool site's translations; its rotations where the measurements see them: a point
  // sees none, a point and an axis the two that tilt the axis, a pose (or nests about the tool) all three.
  const int tool = 6 * (model.num_error_sites() - 1);
  std::vector<int> out = {0, 1, 2, 3, 4, 5, tool, tool + 1, tool + 2};
  const int rotations = reflectors || type == MeasurementType::kPose ? 3
                        : type == MeasurementType::kPositionAxis      ? 2
                                                                       : 0;
  for (int k = 0; k < rotations; ++k) out.push_back(tool + 3 + k);
  return out;
}

bool DriftCheckOptions::IsValid(std::string* error) const {
  if (!(false_alarm_rate > 0.0 && false_alarm_rate < 0.5)) {
    *error = "false_alarm_rate must be in (0, 0.5)";
    return false;
  }
  if (null_squared_residuals.size() < 2) {
    *error = "null_squared_residuals: the calibration's residuals are needed (at least 2)";
    return false;
  }
  for (double v : null_squared_residuals) {
    if (!(v >= 0.0) || !std::isfinite(v)) {
      *error = "null_squared_residuals must be finite and >= 0";
      return false;
    }
  }
  if (!(null_correction >= 1.0) || !std::isfinite(null_correction) || null_draws < 100) {
    *error = "null_correction must be finite and >= 1, null_draws >= 100";
    return false;
  }
  std::string noise_error;
  if (!noise.IsValid(&noise_error)) {
    *error = "noise: " + noise_error;
    return false;
  }
  return true;
}

DriftCheck CheckDrift(const RobotModel& model, const std::vector<Measurement>& shots, const DriftCheckOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("CheckDrift: " + error);
  for (const Measurement& m : shots) {
    if (m.joints.size() != model.num_joints()) throw std::invalid_argument("CheckDrift: a shot of the wrong joint count");
  }
  DriftCheck out;
  out.num_measurements = static_cast<int>(shots.size());
  const int rows_per_shot = MeasurementRows(options.measurement_type);
  const int rows = rows_per_shot * out.num_measurements;
  const std::vector<int> frames =
      options.register_frames ? FrameParameters(model, options.measurement_type) : std::vector<int>{};
  out.dof = rows - static_cast<int>(frames.size());
  // Three position rows, each of the sigma the rows are whitened with (tracker, repeatability, model error).
  out.expected_rms_position_mm = std::sqrt(3.0) / options.noise.RowWeights(MeasurementType::kPosition)[0];
  if (out.dof < 2) {
    out.statistic = out.threshold = kNaN;
    out.message = std::to_string(out.num_measurements) + " shots give " + std::to_string(rows) + " rows: too few for " +
                  std::to_string(frames.size()) + " frame parameters and a check";
    return out;
  }

  // The registration (or the frames as kept) and its residuals.
  double sum0 = 0.0;
  const Calibration registered =
      options.register_frames ? FitOnly(model, shots, options, frames) : NominalCalibration(model);
  out.T_world_base = registered.T_world_base;
  out.T_flange_tool = registered.T_flange_tool;
  Residuals(registered.model, registered.errors, shots, options, &sum0, &out.rms_position_mm);
  out.statistic = sum0 / out.dof;

  // Test 1: the level against as many of the calibration's own measurements.
  Rng rng(options.seed);
  const std::vector<double>& null = options.null_squared_residuals;
  std::vector<double> draws(static_cast<std::size_t>(options.null_draws));
  const double null_rows = static_cast<double>(rows_per_shot * out.num_measurements);
  int above = 0;
  for (double& d : draws) {
    double s = 0.0;
    for (int i = 0; i < out.num_measurements; ++i) s += null[rng.Index(null.size())];
    d = options.null_correction * s / null_rows;
    if (d >= out.statistic) ++above;
  }
  std::sort(draws.begin(), draws.end());
  const double level = 1.0 - options.false_alarm_rate / 2.0;
  out.threshold = draws[std::min(draws.size() - 1, static_cast<std::size_t>(std::ceil(level * draws.size())) - 1)];
  out.p_value = static_cast<double>(above) / static_cast<double>(draws.size());
  const bool level_drifted = out.statistic > out.threshold;

  // Test 2: each candidate beside the frames.
  std::vector<int> candidates = options.candidates;
  if (candidates.empty()) {
    // Every geometric parameter the registration does not estimate, joint offsets first: each is tested alone
    // beside the frames, where it is determined even when the full set drops it (a joint offset of parallel axes).
    std::vector<int> offsets, others;
    for (int k = 0; k < model.num_geometric_parameters(); ++k) {
      if (std::find(frames.begin(), frames.end(), k) != frames.end()) continue;
      (model.IsJointOffsetParameter(k) ? offsets : others).push_back(k);
    }
    candidates = offsets;
    candidates.insert(candidates.end(), others.begin(), others.end());
  }
  out.num_candidates = static_cast<int>(candidates.size());
  std::vector<DriftSuspect> all;
  if (!candidates.empty() && out.dof >= 3) {
    out.drop_threshold =
        ChiSquareQuantile(1, options.false_alarm_rate / 2.0 / static_cast<double>(candidates.size()));
    for (int c : candidates) {
      std::vector<int> parameters = frames;
      parameters.push_back(c);
      const Calibration fit = FitOnly(model, shots, options, parameters);
      if (fit.summary.termination == Termination::kFailure) continue;
      DriftSuspect s;
      s.index = c;
      s.name = ParameterName(model, {}, c);
      for (const IdentifiedParameter& p : fit.parameters) {
        if (p.index == c) {
          s.change = p.value;
          s.std = p.std;
        }
      }
      double sum = 0.0;
      Residuals(fit.model, fit.errors, shots, options, &sum, &s.rms_position_mm);
      s.chi2_drop = std::max(0.0, sum0 - sum);
      all.push_back(s);
    }
    std::sort(all.begin(), all.end(), [](const DriftSuspect& a, const DriftSuspect& b) { return a.chi2_drop > b.chi2_drop; });
    if (!all.empty()) out.largest_drop = all.front().chi2_drop;
  }
  const bool parameter_drifted = out.largest_drop > out.drop_threshold && out.num_candidates > 0;
  out.drifted = level_drifted || parameter_drifted;
  for (const DriftSuspect& s : all) {
    if (s.chi2_drop > out.drop_threshold || (out.drifted && out.suspects.size() < 3 && !parameter_drifted)) {
      out.suspects.push_back(s);
    }
  }
  std::ostringstream m;
  m.precision(3);
  m << (out.drifted ? "drifted" : "holds") << ": residual level " << out.statistic << " (threshold " << out.threshold
    << ")";
  if (out.num_candidates > 0) {
    m << ", largest single-parameter drop " << out.largest_drop << " (threshold " << out.drop_threshold << ", "
      << out.num_candidates << " candidates)";
  }
  if (out.drifted && !out.suspects.empty()) m << "; best explained by " << out.suspects.front().name;
  out.message = m.str();
  return out;
}

}  // namespace robocal
