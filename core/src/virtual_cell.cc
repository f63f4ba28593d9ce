// The virtual cell: hidden tracker placement and geometric errors drawn from a seed, and noisy tracker shots of
// the configurations its measurement cell (if any) lets the tracker see.
#include "robocal/core/virtual_cell.h"

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "robocal/core/joint_errors.h"
#include "robocal/core/kinematics.h"

namespace robocal {
namespace {

bool NonNegativeFinite(double value) { return std::isfinite(value) && value >= 0.0; }

// A rotation of angle |w| about w / |w|; the identity for w = 0.
Eigen::Matrix3d RotationFromVector(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  if (angle == 0.0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
}

// The tracker's pose in the robot's base frame. The tracker stands on its own tripod on the floor, so its
// origin is `distance` away from the base at any bearing, a little above or below the base (elevation up to
// +-0.2 rad), its vertical axis tilted by a fraction of a degree to a few degrees (levelling), and its yaw
// arbitrary. The resulting T_tracker_base is far from the identity, which is what registration must handle.
Transform DrawTrackerInBase(const VirtualCellOptions& o, Rng* rng) {
  const double bearing = rng->Uniform(0.0, 2.0 * std::numbers::pi);
  const double elevation = rng->Uniform(-0.2, 0.2);
  const double yaw = rng->Uniform(-std::numbers::pi, std::numbers::pi);
  const double tilt_x = o.tracker_tilt_sigma_rad * rng->Normal();
  const double tilt_y = o.tracker_tilt_sigma_rad * rng->Normal();
  Transform t = Transform::Identity();
  t.translation() =
      o.tracker_distance_mm * Eigen::Vector3d(std::cos(elevation) * std::cos(bearing),
                                              std::cos(elevation) * std::sin(bearing), std::sin(elevation));
  t.linear() = RotZ(yaw) * RotY(tilt_y) * RotX(tilt_x);
  return t;
}

// The joint harmonics go up to order 4 at most (by default orders 2-4: order 0 is the joint offset and order 1
// nearly a geometric error; the geometric model absorbs neither kind fully, orders 2-4 not at all).
constexpr int kLastHarmonic = 4;

// Configurations probed for a joint's largest gravity torque and the robot's reach (compliance_deflection_mm).
constexpr int kComplianceProbes = 200;

}  // namespace

bool VirtualCellOptions::IsValid(std::string* error) const {
  struct Named {
    const char* name;
    double value;
  };
  const Named non_negative[] = {
      {"joint_translation_sigma_mm", joint_translation_sigma_mm},
      {"joint_rotation_sigma_rad", joint_rotation_sigma_rad},
      {"tool_translation_sigma_mm", tool_translation_sigma_mm},
      {"compliance_deflection_mm", compliance_deflection_mm},
      {"tool_rotation_sigma_rad", tool_rotation_sigma_rad},
      {"tracker_distance_mm", tracker_distance_mm},
      {"tracker_tilt_sigma_rad", tracker_tilt_sigma_rad},
      {"noise.position_mm", noise.position_mm},
      {"noise.orientation_rad", noise.orientation_rad},
      {"outlier_min_mm", outlier_min_mm},
      {"joint_harmonic_sigma_rad", joint_harmonic_sigma_rad},
  };
  if (!ValidateReflectors(reflectors, error)) return false;
  if (!(noise.repeatability_mm >= 0.0 && noise.repeatability_mm <= 10.0)) {
    *error = "noise.repeatability_mm must be in [0, 10]";
    return false;
  }
  if (noise.tracker && !noise.tracker->IsValid(error)) {
    *error = "noise." + *error;
    return false;
  }
  if (!(outlier_rate >= 0.0 && outlier_rate <= 1.0)) {
    *error = "outlier_rate must be in [0, 1] (got " + std::to_string(outlier_rate) + ")";
    return false;
  }
  if (!(outlier_max_mm >= outlier_min_mm) || !std::isfinite(outlier_max_mm)) {
    *error = "outlier_max_mm must be finite and >= outlier_min_mm (got " + std::to_string(outlier_max_mm) + ")";
    return false;
  }
  for (const Named& n : non_negative) {
    if (!NonNegativeFinite(n.value)) {
      *error = std::string(n.name) + " must be finite and >= 0 (got " + std::to_string(n.value) + ")";
      return false;
    }
  }
  // Geometric errors are meant to be small: beyond these the "error" is a different robot and the first-order
  // language of the error model (and of its documentation) no longer applies.
  const Named bounded[] = {
      {"joint_rotation_sigma_rad", joint_rotation_sigma_rad},
      {"tool_rotation_sigma_rad", tool_rotation_sigma_rad},
      {"tracker_tilt_sigma_rad", tracker_tilt_sigma_rad},
  };
  for (const Named& n : bounded) {
    if (n.value > 0.1) {
      *error = std::string(n.name) + " must be <= 0.1 rad (got " + std::to_string(n.value) + ")";
      return false;
    }
  }
  if (joint_harmonic_min_order < 1 || joint_harmonic_max_order > kLastHarmonic ||
      joint_harmonic_min_order > joint_harmonic_max_order) {
    *error = "joint_harmonic_min_order and joint_harmonic_max_order must satisfy 1 <= min <= max <= " +
             std::to_string(kLastHarmonic) + " (got " + std::to_string(joint_harmonic_min_order) + ", " +
             std::to_string(joint_harmonic_max_order) + ")";
    return false;
  }
  if (compliance_deflection_mm > 10.0) {
    *error = "compliance_deflection_mm must be <= 10 mm (got " + std::to_string(compliance_deflection_mm) + ")";
    return false;
  }
  if (shots_per_pose < 1 || shots_per_pose > 1000) {
    *error = "shots_per_pose must be in [1, 1000] (got " + std::to_string(shots_per_pose) + ")";
    return false;
  }
  return true;
}

std::vector<Reflector> RealisticReflectors() {
  return {{"smr1", {60.0, 0.0, 20.0}, true}, {"smr2", {-30.0, 52.0, 20.0}, true}, {"smr3", {-30.0, -52.0, 20.0}, true}};
}

VirtualCellOptions Realistic(VirtualCellOptions options) {
  options.noise.tracker = TrackerUncertainty{};
  options.noise.repeatability_mm = kRealisticRepeatabilityMm;
  options.outlier_rate = kRealisticOutlierRate;
  options.outlier_min_mm = 1.0;
  options.outlier_max_mm = 5.0;
  return options;
}

VirtualCell::VirtualCell(const RobotModel& nominal, const VirtualCellOptions& options)
    : nominal_(nominal), true_model_(nominal), options_(options), rng_(options.seed) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("VirtualCellOptions: " + error);
  // Draw order is fixed (placement, then errors site by site), so the hidden robot depends on the seed and
  // the magnitudes only, not on the noise settings: a noise-free and a noisy cell with one seed share it.
  Transform T_base_tracker = DrawTrackerInBase(options, &rng_);
  if (options.measurement_cell) {
    cell_ = Cell::Build(nominal, *options.measurement_cell);
    // The placement is drawn in the nominal world frame (the base for the presets); the cell is in the base frame.
    T_base_tracker.translation() = nominal.T_world_base() * cell_->spec().tracker.position_mm;
  }
  RobotModelSpec spec = nominal.spec();
  // The nominal world frame is where the robot's program thinks the base stands; the tracker replaces it.
  spec.T_world_base = T_base_tracker.inverse() * nominal.T_world_base();
  true_model_ = RobotModel::Build(spec);

  true_errors_ = Eigen::VectorXd::Zero(nominal.num_error_parameters());
  const int tool_site = nominal.num_error_sites() - 1;
  for (int site = 1; site <= tool_site; ++site) {
    const bool tool = site == tool_site;
    const double sigma_mm = tool ? options.tool_translation_sigma_mm : options.joint_translation_sigma_mm;
    const double sigma_rad = tool ? options.tool_rotation_sigma_rad : options.joint_rotation_sigma_rad;
    for (int k = 0; k < 3; ++k) true_errors_[6 * site + k] = sigma_mm * rng_.Normal();
    for (int k = 3; k < 6; ++k) true_errors_[6 * site + k] = sigma_rad * rng_.Normal();
  }
  // The base site stays zero: any base error is one more rigid transform on top of the tracker placement,
  // which is already the large unknown.
  // Reflector offsets last, so that the robot a seed hides does not depend on the reflectors.
  true_reflector_errors_ = Eigen::VectorXd::Zero(3 * static_cast<Eigen::Index>(options.reflectors.size()));
  for (size_t k = 0; k < options.reflectors.size(); ++k) {
    if (options.reflectors[k].fixed) continue;
    for (int a = 0; a < 3; ++a) true_reflector_errors_[3 * k + a] = options.tool_translation_sigma_mm * rng_.Normal();
  }
  true_in_tool_ = ReflectorsInTool(nominal, options.reflectors, true_reflector_errors_);
  const int orders = options.joint_harmonic_max_order - options.joint_harmonic_min_order + 1;
  if (options.joint_harmonic_sigma_rad > 0.0) {
    harmonic_sin_.resize(nominal.num_joints(), orders);
    harmonic_cos_.resize(nominal.num_joints(), orders);
    for (int j = 0; j < nominal.num_joints(); ++j) {
      for (int k = 0; k < orders; ++k) {
        harmonic_sin_(j, k) = options.joint_harmonic_sigma_rad * rng_.Normal();
        harmonic_cos_(j, k) = options.joint_harmonic_sigma_rad * rng_.Normal();
      }
    }
  }
  true_compliance_ = Eigen::VectorXd::Zero(nominal.num_joints());
  if (options.compliance_deflection_mm > 0.0) {
    if (!nominal.has_masses()) {
      throw std::invalid_argument("VirtualCellOptions: compliance_deflection_mm needs a robot with link masses ('" +
                                  nominal.name() + "' has none)");
    }
    // Each joint's compliance turns the tool by about compliance_deflection_mm at the largest gravity torque it
    // bears (over probe configurations, no payload) and the robot's reach: c_i = d U / (tau_max,i reach), U
    // drawn from [0.5, 1.5]. The probes draw from their own generator, so the noise after them is unchanged.
    Rng probe(options.seed + 0x5DEECE66Dull);
    Eigen::VectorXd tau_max = Eigen::VectorXd::Zero(nominal.num_joints());
    double reach = 0.0;
    std::vector<Transform> joints(nominal.num_joints());
    Transform flange;
    for (int p = 0; p < kComplianceProbes; ++p) {
      const Eigen::VectorXd q = RandomConfiguration(nominal, &probe);
      tau_max = tau_max.cwiseMax(GravityTorques(nominal, q, Payload()).cwiseAbs());
      NominalChainInBase(nominal, q, joints.data(), &flange);
      reach = std::max(reach, (flange.translation() - joints[0].translation()).norm());
    }
    for (int j = 0; j < nominal.num_joints(); ++j) {
      const double u = rng_.Uniform(0.5, 1.5);
      // A joint gravity hardly loads (the vertical first axis) gets none: tau_max is round-off there.
      if (nominal.joint_type(j) != JointType::kRevolute || tau_max[j] < 1e-6 * tau_max.maxCoeff()) continue;
      true_compliance_[j] = options.compliance_deflection_mm * u / (tau_max[j] * std::max(reach, 1.0));
    }
  }
}

Eigen::VectorXd VirtualCell::JointError(const Eigen::VectorXd& q) const {
  Eigen::VectorXd out = Eigen::VectorXd::Zero(q.size());
  for (Eigen::Index j = 0; j < harmonic_sin_.rows() && j < q.size(); ++j) {
    for (Eigen::Index k = 0; k < harmonic_sin_.cols(); ++k) {
      const double order = static_cast<double>(options_.joint_harmonic_min_order + k);
      out[j] += harmonic_sin_(j, k) * std::sin(order * q[j]) + harmonic_cos_(j, k) * std::cos(order * q[j]);
    }
  }
  return out;
}

void VirtualCell::StartNoiseStream(std::uint64_t stream) {
  // A SplitMix64 step decorrelates neighbouring (seed, stream) pairs before they seed the Mersenne Twister.
  std::uint64_t z = options_.seed + 0x9E3779B97F4A7C15ull * (stream + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  rng_ = Rng(z ^ (z >> 31));
}

Eigen::VectorXd VirtualCell::JointDeflection(const Eigen::VectorXd& q, const Payload& payload) const {
  Eigen::VectorXd dq = JointError(q);
  if (options_.compliance_deflection_mm > 0.0) dq += true_compliance_.cwiseProduct(GravityTorques(nominal_, q, payload));
  return dq;
}

Transform VirtualCell::TruePose(const Eigen::VectorXd& q, const Payload& payload) const {
  // Sizes are checked by ForwardKinematics; a NaN joint would pass it and come back as a NaN "measurement".
  if (q.size() == true_model_.num_joints() && !q.allFinite()) {
    throw std::invalid_argument("VirtualCell: q is not finite");
  }
  std::string error;
  if (!payload.IsValid("payload", &error)) throw std::invalid_argument("VirtualCell: " + error);
  KinematicsWorkspace ws(true_model_);
  if (harmonic_sin_.size() == 0 && options_.compliance_deflection_mm == 0.0) {
    return ForwardKinematics(true_model_, q, true_errors_, &ws);
  }
  if (q.size() != true_model_.num_joints()) return ForwardKinematics(true_model_, q, true_errors_, &ws);  // throws
  return ForwardKinematics(true_model_, q + JointDeflection(q, payload), true_errors_, &ws);
}

Transform VirtualCell::Land(const Eigen::VectorXd& q, const Payload& payload) {
  Transform pose = TruePose(q, payload);
  if (options_.noise.repeatability_mm > 0.0) {
    const double sigma = options_.noise.RepeatabilitySigmaMm();
    for (int k = 0; k < 3; ++k) pose.translation()[k] += sigma * rng_.Normal();
  }
  return pose;
}

bool VirtualCell::Measurable(const Eigen::VectorXd& q) const {
  if (!cell_) {
    if (q.size() != nominal_.num_joints()) throw std::invalid_argument("VirtualCell: q has the wrong size");
    return true;
  }
  return IsFeasible(nominal_, *cell_, q);
}

std::vector<Measurement> VirtualCell::Measure(const Eigen::VectorXd& q, int shots, const Payload& payload) {
  const Transform truth = TruePose(q, payload);
  if (!Measurable(q)) {
    ++unmeasured_;
    return {};
  }
  const int count = shots > 0 ? shots : options_.shots_per_pose;
  std::vector<Measurement> out;
  out.reserve(count);
  // Each optional effect draws only when it is on, so a seed's draws without it are those of earlier releases.
  Transform visit = truth;
  if (options_.noise.repeatability_mm > 0.0) {
    const double sigma = options_.noise.RepeatabilitySigmaMm();
    for (int k = 0; k < 3; ++k) visit.translation()[k] += sigma * rng_.Normal();
  }
  const MeasurementNoise& noise = options_.noise;
  const double orientation_sigma = noise.tracker ? noise.tracker->OrientationSigmaRad() : noise.orientation_rad;
  // Every reflector of the tool (or the tool point), `count` shots each.
  const int targets = options_.reflectors.empty() ? 1 : static_cast<int>(options_.reflectors.size());
  out.reserve(static_cast<size_t>(count) * targets);
  for (int target = 0; target < targets; ++target) {
    const Transform aim = options_.reflectors.empty() ? visit : AtReflector(visit, true_in_tool_[target]);
    const Eigen::Matrix3d position_sqrt = noise.tracker
                                              ? noise.tracker->PositionSqrt(aim.translation())
                                              : Eigen::Matrix3d(noise.position_mm * Eigen::Matrix3d::Identity());
    for (int s = 0; s < count; ++s) {
      Measurement m;
      m.joints = q;
      m.payload = payload;
      m.reflector = options_.reflectors.empty() ? -1 : target;
      Eigen::Vector3d n, dw;
      for (int k = 0; k < 3; ++k) n[k] = rng_.Normal();
      for (int k = 0; k < 3; ++k) dw[k] = orientation_sigma * rng_.Normal();
      Eigen::Vector3d dp = position_sqrt * n;
      if (options_.outlier_rate > 0.0 && rng_.Uniform() < options_.outlier_rate) {
        Eigen::Vector3d direction;
        do {
          for (int k = 0; k < 3; ++k) direction[k] = rng_.Normal();
        } while (!(direction.norm() > 1e-9));
        dp += rng_.Uniform(options_.outlier_min_mm, options_.outlier_max_mm) * direction.normalized();
        outlier_shots_.push_back(shots_);
      }
      ++shots_;
      m.T_world_tool = aim;
      m.T_world_tool.translation() += dp;
      // Applied on the left, in the tracker frame, as the pose residual's rotation vector is taken.
      m.T_world_tool.linear() = RotationFromVector(dw) * visit.linear();
      out.push_back(std::move(m));
    }
  }
  return out;
}

std::vector<Measurement> VirtualCell::MeasureAll(const std::vector<Eigen::VectorXd>& configurations, int shots,
                                                 std::vector<int>* lost, const Payload& payload) {
  std::vector<Measurement> out;
  if (lost != nullptr) lost->clear();
  for (size_t i = 0; i < configurations.size(); ++i) {
    const Eigen::VectorXd& q = configurations[i];
    const int before = unmeasured_;
    std::vector<Measurement> shots_at_q = Measure(q, shots, payload);
    if (lost != nullptr && unmeasured_ > before) lost->push_back(static_cast<int>(i));
    out.insert(out.end(), std::make_move_iterator(shots_at_q.begin()), std::make_move_iterator(shots_at_q.end()));
  }
  return out;
}

}  // namespace robocal
