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
    std::vector<double> fold_mean;
    double sum = 0.0, sum_squares = 0.0;
    int count = 0;
    for (int f = 0; f < choice.folds && !out.cancelled; ++f) {
      std::vector<Measurement> training, held_out;
      for (size_t i = 0; i < measurements.size(); ++i) (fold[i] == f ? held_out : training).push_back(measurements[i]);
      IdentificationOptions o = options;
      if (options.progress) {
        o.progress = [&](double fraction) {
          if (options.progress((fits_done + fraction) / total_fits)) return true;
          out.cancelled = true;
          return false;
        };
      }
      const Calibration c = Identify(t.maps.empty() ? model : WithTermsFor(nominal, t, training), training, o);
      ++fits_done;
      if (out.cancelled) break;
      if (c.summary.termination == Termination::kFailure) {
        ++candidate.failed_folds;
        if (candidate.note.empty()) candidate.note = "fold " + std::to_string(f + 1) + ": " + c.summary.message;
        continue;
      }
      if (!c.summary.implausible_joint_terms.empty()) {
        // Fitted, but with a joint term no robot has: its error on this fold says nothing about other poses.
        ++candidate.failed_folds;
        if (candidate.note.empty()) {
          candidate.note = "fold " + std::to_string(f + 1) + ": implausible " + c.summary.implausible_joint_terms[0];
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
    if (out.cancelled) break;
    if (count > 0) {
      candidate.cv_mean_mm = sum / count;
      candidate.cv_rms_mm = std::sqrt(sum_squares / count);
      const double k = static_cast<double>(fold_mean.size());
      if (fold_mean.size() > 1) {
        double mean = 0.0, var = 0.0;
        for (double v : fold_mean) mean += v / k;
        for (double v : fold_mean) var += (v - mean) * (v - mean) / (k - 1.0);
        candidate.cv_standard_error_mm = std::sqrt(var / k);
      }
    }
    out.candidates.push_back(candidate);
  }
  if (out.cancelled) {
    out.message = "cancelled";
    return out;
  }
  for (size_t k = 0; k < out.candidates.size(); ++k) {
    const ModelCandidate& c = out.candidates[k];
    if (c.failed_folds > 0) continue;
    if (out.best < 0 || c.cv_mean_mm < out.candidates[out.best].cv_mean_mm) out.best = static_cast<int>(k);
  }
  if (out.best < 0) {
    out.message = "no model could be fitted on every fold: " +
                  (out.candidates.empty() ? std::string("no candidates") : out.candidates[0].note);
    return out;
  }
  const ModelCandidate& best = out.candidates[out.best];
  const double bar = best.cv_mean_mm + best.cv_standard_error_mm;
  for (size_t k = 0; k < out.candidates.size(); ++k) {
    if (out.candidates[k].failed_folds == 0 && out.candidates[k].cv_mean_mm <= bar) {
      out.chosen = static_cast<int>(k);
      break;
    }
  }
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

}  // namespace robocal
