// Model choice by k-fold cross-validation over the calibration set.
#include "robocal/core/model_choice.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <sstream>
#include <stdexcept>

#include "robocal/core/kinematics.h"
#include "robocal/core/random.h"
#include "robocal/core/reflectors.h"

namespace robocal {
namespace {

// The fold of every measurement: distinct poses shuffled and dealt in turn.
std::vector<int> AssignFolds(const std::vector<Measurement>& measurements, int folds, std::uint64_t seed,
                             int* num_poses) {
  std::map<Eigen::VectorXd, int, LexicographicLess> pose_of;
  std::vector<int> pose(measurements.size());
  for (size_t i = 0; i < measurements.size(); ++i) {
    pose[i] = pose_of.emplace(PoseKey(measurements[i]), static_cast<int>(pose_of.size())).first->second;
  }
  *num_poses = static_cast<int>(pose_of.size());
  std::vector<int> order(pose_of.size());
  for (size_t p = 0; p < order.size(); ++p) order[p] = static_cast<int>(p);
  Rng rng(seed);
  for (size_t k = order.size(); k > 1; --k) std::swap(order[k - 1], order[rng.Index(k)]);
  std::vector<int> fold_of_pose(order.size());
  for (size_t k = 0; k < order.size(); ++k) fold_of_pose[order[k]] = static_cast<int>(k) % folds;
  std::vector<int> fold(measurements.size());
  for (size_t i = 0; i < measurements.size(); ++i) fold[i] = fold_of_pose[pose[i]];
  return fold;
}

// One candidate's held-out position error over the folds (ModelCandidate's and PriorScaleCandidate's figures).
struct HeldOutError {
  double mean_mm = 0.0;
  double rms_mm = 0.0;
  double standard_error_mm = 0.0;
  int failed_folds = 0;
  std::string note;
};

// The cross-validation of one candidate: `fit` (training measurements, fold) on all folds but one, the distance
// between measured and predicted position on the fold left out, in turn. A fit that fails or finds an implausible
// joint term counts as a failed fold. Stops after a fold when *cancelled is set (by `fit`'s progress).
HeldOutError CrossValidate(const std::vector<Measurement>& measurements, const std::vector<int>& fold, int folds,
                           const std::function<Calibration(const std::vector<Measurement>&, int)>& fit,
                           const bool* cancelled) {
  HeldOutError out;
  std::vector<double> fold_mean;
  double sum = 0.0, sum_squares = 0.0;
  int count = 0;
  for (int f = 0; f < folds && !*cancelled; ++f) {
    std::vector<Measurement> training, held_out;
    for (size_t i = 0; i < measurements.size(); ++i) (fold[i] == f ? held_out : training).push_back(measurements[i]);
    const Calibration c = fit(training, f);
    if (*cancelled) break;
    if (c.summary.termination == Termination::kFailure) {
      ++out.failed_folds;
      if (out.note.empty()) out.note = "fold " + std::to_string(f + 1) + ": " + c.summary.message;
      continue;
    }
    if (!c.summary.implausible_joint_terms.empty()) {
      // Fitted, but with a joint term no robot has: its error on this fold says nothing about other poses.
      ++out.failed_folds;
      if (out.note.empty()) {
        out.note = "fold " + std::to_string(f + 1) + ": implausible " + c.summary.implausible_joint_terms[0];
      }
      continue;
    }
    const std::vector<Eigen::Vector3d> in_tool = ReflectorsInTool(c.model, c.reflectors, Eigen::VectorXd());
    KinematicsWorkspace ws(c.model);
    double fold_sum = 0.0;
    for (const Measurement& m : held_out) {
      const Transform& tool = ForwardKinematics(c.model, m.joints, c.errors, &ws, m.payload);
      const Eigen::Vector3d predicted = m.reflector < 0 ? tool.translation() : tool * in_tool.at(m.reflector);
      const double e = (m.T_world_tool.translation() - predicted).norm();
      fold_sum += e;
      sum += e;
      sum_squares += e * e;
      ++count;
    }
    fold_mean.push_back(held_out.empty() ? 0.0 : fold_sum / static_cast<double>(held_out.size()));
  }
  if (count > 0) {
    out.mean_mm = sum / count;
    out.rms_mm = std::sqrt(sum_squares / count);
    const double k = static_cast<double>(fold_mean.size());
    if (fold_mean.size() > 1) {
      double mean = 0.0, var = 0.0;
      for (double v : fold_mean) mean += v / k;
      for (double v : fold_mean) var += (v - mean) * (v - mean) / (k - 1.0);
      out.standard_error_mm = std::sqrt(var / k);
    }
  }
  return out;
}

// The one-standard-error rule over candidates listed simplest first: the lowest mean among those without a
// failed fold (*best), and the first whose mean is within one standard error of it (returned); -1 for none.
template <typename Candidate>
int OneStandardErrorChoice(const std::vector<Candidate>& candidates, int* best) {
  *best = -1;
  for (size_t k = 0; k < candidates.size(); ++k) {
    const Candidate& c = candidates[k];
    if (c.failed_folds > 0) continue;
    if (*best < 0 || c.cv_mean_mm < candidates[*best].cv_mean_mm) *best = static_cast<int>(k);
  }
  if (*best < 0) return -1;
  const double bar = candidates[*best].cv_mean_mm + candidates[*best].cv_standard_error_mm;
  for (size_t k = 0; k < candidates.size(); ++k) {
    if (candidates[k].failed_folds == 0 && candidates[k].cv_mean_mm <= bar) return static_cast<int>(k);
  }
  return -1;
}

std::string Mm(double value) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(3);
  out << value << " mm";
  return out.str();
}

}  // namespace

bool ParseModelName(const std::string& text, JointErrorTerms* terms, bool* automatic, std::string* error) {
  *terms = {};
  *automatic = text == "auto";
  if (*automatic || text == "geometric") return true;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string part = text.substr(start, comma - start);
    if (part == "compliance") {
      terms->compliance = true;
    } else if (part.size() == 11 && part.rfind("harmonics=", 0) == 0 && part[10] >= '0' &&
               part[10] <= '0' + kMaxJointHarmonics) {
      terms->joint_harmonics = part[10] - '0';
    } else {
      *error = "'" + text + "' is not auto, geometric or a comma list of compliance and harmonics=N (N 0 to " +
               std::to_string(kMaxJointHarmonics) + "), e.g. compliance,harmonics=2";
      return false;
    }
    start = comma + 1;
  }
  return true;
}

bool ModelChoiceOptions::IsValid(std::string* error) const {
  if (folds < 2 || folds > 20) {
    *error = "folds must be in [2, 20], got " + std::to_string(folds);
    return false;
  }
  if (max_joint_harmonics < 0 || max_joint_harmonics > kMaxJointHarmonics) {
    *error = "max_joint_harmonics must be in [0, " + std::to_string(kMaxJointHarmonics) + "], got " +
             std::to_string(max_joint_harmonics);
    return false;
  }
  for (double spacing : map_knot_spacings_rad) {
    if (!(spacing >= kMinMapKnotSpacingRad * (1 - 1e-12) && spacing <= kMaxMapKnotSpacingRad * (1 + 1e-12))) {
      *error = "map_knot_spacings_rad must lie in [0.5, 90] degrees";
      return false;
    }
  }
  if (!(map_smoothness >= 0.0) || !std::isfinite(map_smoothness)) {
    *error = "map_smoothness must be finite and >= 0";
    return false;
  }
  return true;
}

std::vector<JointErrorTerms> ModelCandidates(const RobotModel& nominal, const ModelChoiceOptions& options) {
  std::vector<JointErrorTerms> out;
  for (int h = 0; h <= options.max_joint_harmonics; ++h) {
    out.push_back({.compliance = false, .joint_harmonics = h});
    if (nominal.has_masses()) out.push_back({.compliance = true, .joint_harmonics = h});
  }
  // Simplest first: a compliance is one parameter per joint, a harmonic order two.
  std::stable_sort(out.begin(), out.end(), [](const JointErrorTerms& a, const JointErrorTerms& b) {
    return (a.compliance ? 1 : 0) + 2 * a.joint_harmonics < (b.compliance ? 1 : 0) + 2 * b.joint_harmonics;
  });
  // Maps last (tens of coefficients per joint), coarsest first.
  std::vector<int> revolute;
  for (int i = 0; i < nominal.num_joints(); ++i) {
    if (nominal.joint_type(i) == JointType::kRevolute) revolute.push_back(i);
  }
  std::vector<double> spacings = options.map_knot_spacings_rad;
  std::sort(spacings.begin(), spacings.end(), std::greater<>());
  for (double spacing : revolute.empty() ? std::vector<double>() : spacings) {
    JointErrorTerms terms{.compliance = nominal.has_masses(), .joint_harmonics = 0};
    terms.maps.joints = revolute;
    terms.maps.knot_spacing_rad = spacing;
    terms.maps.smoothness = options.map_smoothness;
    out.push_back(terms);
  }
  return out;
}

ModelChoice ChooseModel(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                        const IdentificationOptions& options, const ModelChoiceOptions& choice) {
  std::string error;
  if (!choice.IsValid(&error)) throw std::invalid_argument("ModelChoiceOptions: " + error);
  if (!options.IsValid(&error)) throw std::invalid_argument("IdentificationOptions: " + error);
  if (!options.parameters.empty()) {
    throw std::invalid_argument("ChooseModel: options.parameters must be empty (each model chooses its own)");
  }
  if (!nominal.joint_terms().empty()) {
    throw std::invalid_argument("ChooseModel: the nominal model already has joint terms (" +
                                nominal.error_terms().Describe() + ")");
  }
  ModelChoice out;
  out.folds = choice.folds;
  int num_poses = 0;
  const std::vector<int> fold = AssignFolds(measurements, choice.folds, choice.seed, &num_poses);
  const std::vector<JointErrorTerms> terms = ModelCandidates(nominal, choice);
  if (num_poses < choice.folds) {
    out.message =
        std::to_string(num_poses) + " distinct poses cannot be dealt to " + std::to_string(choice.folds) + " folds";
    return out;
  }
  // Progress counts one fit more than the folds': the final fit on every pose (IdentifyWithModelChoice).
  const double total_fits = static_cast<double>(terms.size() * static_cast<size_t>(choice.folds)) + 1.0;
  int fits_done = 0;
  for (const JointErrorTerms& t : terms) {
    // A map's knots lie over the poses it is fitted on: each fold's own; its size is that of every pose's.
    const RobotModel model = WithTermsFor(nominal, t, measurements);
    ModelCandidate candidate;
    candidate.terms = t;
    candidate.num_parameters = model.num_error_parameters();
    const HeldOutError e = CrossValidate(
        measurements, fold, choice.folds,
        [&](const std::vector<Measurement>& training, int) {
          IdentificationOptions o = options;
          if (options.progress) {
            o.progress = [&](double fraction) {
              if (options.progress((fits_done + fraction) / total_fits)) return true;
              out.cancelled = true;
              return false;
            };
          }
          Calibration c = Identify(t.maps.empty() ? model : WithTermsFor(nominal, t, training), training, o);
          ++fits_done;
          return c;
        },
        &out.cancelled);
    if (out.cancelled) break;
    candidate.cv_mean_mm = e.mean_mm;
    candidate.cv_rms_mm = e.rms_mm;
    candidate.cv_standard_error_mm = e.standard_error_mm;
    candidate.failed_folds = e.failed_folds;
    candidate.note = e.note;
    out.candidates.push_back(candidate);
  }
  if (out.cancelled) {
    out.message = "cancelled";
    return out;
  }
  out.chosen = OneStandardErrorChoice(out.candidates, &out.best);
  if (out.best < 0) {
    out.message = "no model could be fitted on every fold: " +
                  (out.candidates.empty() ? std::string("no candidates") : out.candidates[0].note);
    return out;
  }
  const ModelCandidate& best = out.candidates[out.best];
  const ModelCandidate& chosen = out.candidates[out.chosen];
  out.message = "model " + chosen.terms.Describe() + " chosen by " + std::to_string(choice.folds) +
                "-fold cross-validation: held-out mean " + Mm(chosen.cv_mean_mm);
  if (out.chosen != out.best) {
    out.message += ", within one standard error of the best (" + best.terms.Describe() + ", " + Mm(best.cv_mean_mm) +
                   " +- " + Mm(best.cv_standard_error_mm) + ")";
  }
  return out;
}

Calibration IdentifyWithModelChoice(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                                    const IdentificationOptions& options, const ModelChoiceOptions& choice) {
  const ModelChoice mc = ChooseModel(nominal, measurements, options, choice);
  const auto attach = [&](Calibration* c) {
    c->summary.model_candidates = mc.candidates;
    c->summary.model_folds = mc.folds;
    c->summary.model_chosen = mc.chosen;
  };
  if (mc.chosen < 0) {
    // Nothing to choose from: the geometric fit says what is wrong with the data (or the cancellation).
    IdentificationOptions o = options;
    if (mc.cancelled) {
      // Asked to stop: no fit beyond the one iteration that says so.
      o.progress = [](double) { return false; };
    } else if (options.progress) {
      // After the folds: the last share of the way, never back.
      const double done = static_cast<double>(mc.candidates.size() * static_cast<size_t>(mc.folds));
      o.progress = [&options, done](double fraction) { return options.progress((done + fraction) / (done + 1.0)); };
    }
    Calibration c = Identify(nominal, measurements, o);
    attach(&c);
    if (mc.cancelled) {
      c.summary.termination = Termination::kNoConvergence;
      c.summary.message = "cancelled";
      c.summary.cancelled = true;
    } else if (c.summary.termination != Termination::kFailure) {
      c.summary.termination = Termination::kDegraded;
      c.summary.message = "model choice: " + mc.message + "; the geometric model was fitted: " + c.summary.message;
    }
    return c;
  }
  IdentificationOptions o = options;
  const double done = static_cast<double>(mc.candidates.size() * static_cast<size_t>(mc.folds));
  if (options.progress) {
    o.progress = [&](double fraction) { return options.progress((done + fraction) / (done + 1.0)); };
  }
  Calibration c = Identify(WithTermsFor(nominal, mc.candidates[mc.chosen].terms, measurements), measurements, o);
  attach(&c);
  c.summary.message = mc.message + "; " + c.summary.message;
  return c;
}

bool PriorChoiceOptions::IsValid(std::string* error) const {
  if (folds < 2 || folds > 20) {
    *error = "folds must be in [2, 20], got " + std::to_string(folds);
    return false;
  }
  if (scales.empty()) {
    *error = "scales must not be empty";
    return false;
  }
  for (double scale : scales) {
    if (!(scale > 0.0)) {
      *error = "scales must be > 0 (+infinity: no priors)";
      return false;
    }
  }
  std::string sub;
  if (!priors.IsValid(&sub)) {
    *error = "priors." + sub;
    return false;
  }
  return true;
}

PriorChoice ChoosePriorScale(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                             const IdentificationOptions& options, const PriorChoiceOptions& choice) {
  std::string error;
  if (!choice.IsValid(&error)) throw std::invalid_argument("PriorChoiceOptions: " + error);
  if (!options.IsValid(&error)) throw std::invalid_argument("IdentificationOptions: " + error);
  PriorStd(nominal, choice.priors, options.reflectors);  // throws for a name that is no parameter
  PriorChoice out;
  out.folds = choice.folds;
  int num_poses = 0;
  // The folds of ChooseModel with the same seed: one split of the poses serves both choices.
  const std::vector<int> fold = AssignFolds(measurements, choice.folds, choice.seed, &num_poses);
  if (num_poses < choice.folds) {
    out.message =
        std::to_string(num_poses) + " distinct poses cannot be dealt to " + std::to_string(choice.folds) + " folds";
    return out;
  }
  // The fit without priors (+infinity) first, then ever narrower priors; the scale with the least cross-validated
  // error is taken. The scale is a continuous weight of one prior rather than a choice among nested models, so the
  // one-standard-error rule of ChooseModel does not apply: on the IPA UR10 (Series B, N = 20, 30, 100 calibration
  // poses, 5 draws each; robocal-prior-study) the least CV error gave 6.6, 1.1 and 0.1 % lower held-out means, the
  // one-standard-error rule 2.8, 0.2 and 0 % (docs/identification.md, "Parameter priors"). What biased the priors
  // there was the frames' error (the tool 16 mm off its nominal length), which the base and tool sites' free priors
  // (ParameterPriors) now leave to the data.
  std::vector<double> scales = choice.scales;
  std::sort(scales.begin(), scales.end(), std::greater<>());
  scales.erase(std::unique(scales.begin(), scales.end()), scales.end());
  const double total_fits = static_cast<double>(scales.size() * static_cast<size_t>(choice.folds)) + 1.0;
  int fits_done = 0;
  for (double scale : scales) {
    IdentificationOptions o = options;
    o.priors.reset();
    if (std::isfinite(scale)) {
      o.priors = choice.priors;
      o.priors->scale *= scale;
    }
    const HeldOutError e = CrossValidate(
        measurements, fold, choice.folds,
        [&](const std::vector<Measurement>& training, int) {
          IdentificationOptions fold_options = o;
          if (options.progress) {
            fold_options.progress = [&](double fraction) {
              if (options.progress((fits_done + fraction) / total_fits)) return true;
              out.cancelled = true;
              return false;
            };
          }
          Calibration c = Identify(nominal, training, fold_options);
          ++fits_done;
          return c;
        },
        &out.cancelled);
    if (out.cancelled) break;
    out.candidates.push_back({.scale = scale,
                              .cv_mean_mm = e.mean_mm,
                              .cv_rms_mm = e.rms_mm,
                              .cv_standard_error_mm = e.standard_error_mm,
                              .failed_folds = e.failed_folds,
                              .note = e.note});
  }
  if (out.cancelled) {
    out.message = "cancelled";
    return out;
  }
  OneStandardErrorChoice(out.candidates, &out.best);
  out.chosen = out.best;
  if (out.best < 0) {
    out.message = "no prior scale could be fitted on every fold: " +
                  (out.candidates.empty() ? std::string("no candidates") : out.candidates[0].note);
    return out;
  }
  const auto describe = [](const PriorScaleCandidate& c) {
    std::ostringstream text;
    if (std::isfinite(c.scale)) {
      text << "priors x " << c.scale;
    } else {
      text << "no priors";
    }
    return text.str();
  };
  const PriorScaleCandidate& chosen = out.candidates[out.chosen];
  out.message = describe(chosen) + " chosen by " + std::to_string(choice.folds) +
                "-fold cross-validation: held-out mean " + Mm(chosen.cv_mean_mm) + " +- " +
                Mm(chosen.cv_standard_error_mm);
  return out;
}

Calibration IdentifyWithPriorChoice(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                                    const IdentificationOptions& options, const PriorChoiceOptions& choice) {
  const PriorChoice pc = ChoosePriorScale(nominal, measurements, options, choice);
  IdentificationOptions o = options;
  o.priors.reset();
  if (pc.chosen >= 0 && std::isfinite(pc.candidates[pc.chosen].scale)) {
    o.priors = choice.priors;
    o.priors->scale *= pc.candidates[pc.chosen].scale;
  }
  const double done = static_cast<double>(pc.candidates.size() * static_cast<size_t>(pc.folds));
  if (pc.cancelled) {
    // Asked to stop: no fit beyond the one iteration that says so.
    o.progress = [](double) { return false; };
  } else if (options.progress) {
    o.progress = [&options, done](double fraction) { return options.progress((done + fraction) / (done + 1.0)); };
  }
  Calibration c = Identify(nominal, measurements, o);
  c.summary.prior_candidates = pc.candidates;
  c.summary.prior_folds = pc.folds;
  c.summary.prior_chosen = pc.chosen;
  if (pc.cancelled) {
    c.summary.termination = Termination::kNoConvergence;
    c.summary.message = "cancelled";
    c.summary.cancelled = true;
  } else if (pc.chosen < 0) {
    // Nothing to choose from: the fit without priors says what is wrong with the data.
    if (c.summary.termination != Termination::kFailure) {
      c.summary.termination = Termination::kDegraded;
      c.summary.message = "priors: " + pc.message + "; fitted without priors: " + c.summary.message;
    }
  } else {
    c.summary.message = pc.message + "; " + c.summary.message;
  }
  return c;
}

}  // namespace robocal
