// The building blocks of the wire shapes: strict reading, enum names, numbers, poses, identifiers.
#include "robocal/api/wire.h"

#include <cstdio>

#include "robocal/api/json_reader.h"

namespace robocal::api {

// ------------------------------------------------------------------------------------------------ enums

const char* EnumTable<MeasurementType>::Name(MeasurementType v) { return ToString(v); }
const char* EnumTable<Termination>::Name(Termination v) { return ToString(v); }
const char* EnumTable<JointType>::Name(JointType v) { return ToString(v); }
const char* EnumTable<GeometryConvention>::Name(GeometryConvention v) { return ToString(v); }
const char* EnumTable<TargetFrame>::Name(TargetFrame v) { return ToString(v); }
const char* EnumTable<ColumnScaling>::Name(ColumnScaling v) { return ToString(v); }
const char* EnumTable<ObservabilityIndex>::Name(ObservabilityIndex v) { return ToString(v); }
const char* EnumTable<Status>::Name(Status v) { return ToString(v); }
const char* EnumTable<CellRule>::Name(CellRule v) { return ToString(v); }

const char* EnumTable<Optimiser>::Name(Optimiser v) {
  switch (v) {
    case Optimiser::kSolisWets:
      return "solis_wets";
    case Optimiser::kRandom:
      return "random";
    case Optimiser::kExchange:
      return "exchange";
  }
  return "?";
}

const char* EnumTable<MeasurementRole>::Name(MeasurementRole v) {
  switch (v) {
    case MeasurementRole::kCalibration:
      return "calibration";
    case MeasurementRole::kValidation:
      return "validation";
    case MeasurementRole::kTest:
      return "test";
  }
  return "?";
}

const char* EnumTable<OperationKind>::Name(OperationKind v) { return v == OperationKind::kFit ? "fit" : "plan"; }

const char* EnumTable<FitScope>::Name(FitScope v) { return v == FitScope::kFrames ? "frames" : "all"; }

const char* EnumTable<MalformedCandidates>::Name(MalformedCandidates v) {
  return v == MalformedCandidates::kReject ? "reject" : "refuse";
}

const char* EnumTable<OperationState>::Name(OperationState v) {
  switch (v) {
    case OperationState::kRunning:
      return "RUNNING";
    case OperationState::kSucceeded:
      return "SUCCEEDED";
    case OperationState::kFailed:
      return "FAILED";
    case OperationState::kCancelled:
      return "CANCELLED";
  }
  return "?";
}

// ------------------------------------------------------------------------------------------------ reading

WireError::WireError(std::string path, std::string reason)
    : std::runtime_error((path.empty() ? std::string("document") : path) + ": " + reason),
      path_(std::move(path)),
      reason_(std::move(reason)) {}

std::string WirePath(const std::string& path, const std::string& member) {
  if (path.empty()) return member;
  if (member.empty()) return path;
  return member.front() == '[' ? path + member : path + "." + member;
}

namespace detail {
void ThrowWire(const std::string& path, const std::string& reason) { throw WireError(path, reason); }
std::string IndexPathOf(const std::string& path, std::size_t index) {
  return path + "[" + std::to_string(index) + "]";
}
}  // namespace detail

WireReader::WireReader(const nlohmann::json& value, std::string path) : object_(&value), path_(std::move(path)) {
  if (!value.is_object()) throw WireError(path_, "expected an object");
}

const nlohmann::json& WireReader::Member(const char* key) const {
  const auto it = object_->find(key);
  if (it == object_->end()) throw WireError(WirePath(path_, key), "required");
  return *it;
}

// ------------------------------------------------------------------------------------------------ writing

nlohmann::json Num(double value) { return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(); }

nlohmann::json Nums(const std::vector<double>& values) {
  nlohmann::json a = nlohmann::json::array();
  for (double v : values) a.push_back(Num(v));
  return a;
}

// ------------------------------------------------------------------------------------------------ common

bool IsValidRequestId(const std::string& request_id) {
  return !request_id.empty() && std::none_of(request_id.begin(), request_id.end(),
                                             [](char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7F; });
}

bool IsValidId(const std::string& id) {
  if (id.empty() || id.size() > 64) return false;
  for (std::size_t i = 0; i < id.size(); ++i) {
    const char c = id[i];
    const bool alnum = (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9');
    if (!(alnum || (i > 0 && (c == '_' || c == '-' || c == '.')))) return false;
  }
  return true;
}

std::string OverLimit(std::int64_t value, const std::string& what, const std::string& limit_name, std::int64_t limit) {
  return std::to_string(value) + " " + what + " exceed the server's limit " + limit_name + " = " +
         std::to_string(limit);
}

// FNV-1a (64 bit) rather than std::hash: it must give the same digits on every platform and in every run,
// because the server stores it and compares a retried batch's hash with it. Not a security property: a
// request_id is the caller's own.
std::string ContentHash(const std::string& text) {
  std::uint64_t h = 14695981039346656037ULL;  // FNV-1a 64-bit offset basis
  for (unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ULL;  // FNV-1a 64-bit prime
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

// ------------------------------------------------------------------------------------------------ poses

bool ParsePose(const nlohmann::json& value, const std::string& path, bool orientation_required,
               Problems* problems, PoseWire* out) {
  const std::size_t before = problems->size();
  ObjectReader r(value, path, problems);
  if (!r.ok()) return false;
  PoseWire pose;
  if (r.FixedNumbers("position_mm", true, pose.position_mm.data(), 3)) {
    for (int i = 0; i < 3; ++i) {
      if (std::abs(pose.position_mm[i]) > kMaxLengthMm) {
        problems->Add(IndexPath(JoinPath(path, "position_mm"), i), "implausibly large (limit 1e9 mm)");
      }
    }
  }
  const bool has_q = r.Has("quaternion"), has_rpy = r.Has("rpy_deg");
  if (has_q && has_rpy) {
    problems->Add(JoinPath(path, "rpy_deg"), "give either quaternion or rpy_deg, not both");
  } else if (has_q) {
    std::array<double, 4> q{};
    if (r.FixedNumbers("quaternion", true, q.data(), 4)) {
      const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
      if (!(std::abs(norm - 1.0) < 1e-3)) {
        problems->Add(JoinPath(path, "quaternion"), "must be a unit quaternion [w,x,y,z] (norm " +
                                                        nlohmann::json(norm).dump() + ")");
      } else {
        for (int i = 0; i < 4; ++i) pose.quaternion[i] = q[i] / norm;
      }
    }
  } else if (has_rpy) {
    std::array<double, 3> rpy{};
    if (r.FixedNumbers("rpy_deg", true, rpy.data(), 3)) {
      bool ok = true;
      for (int i = 0; i < 3; ++i) {
        if (std::abs(rpy[i]) > 360.0) {
          problems->Add(IndexPath(JoinPath(path, "rpy_deg"), i), "must be in [-360, 360] degrees");
          ok = false;
        }
      }
      if (ok) {
        const Eigen::Quaterniond q(RotationFromRpy(Eigen::Vector3d(rpy[0], rpy[1], rpy[2]) * kRadPerDeg));
        pose.quaternion = {q.w(), q.x(), q.y(), q.z()};
      }
    }
  } else if (orientation_required) {
    problems->Add(JoinPath(path, "quaternion"), "required (or rpy_deg)");
  } else {
    pose.has_orientation = false;
  }
  r.RejectUnknown(WireFieldNames<PoseResultWire>());  // a request may send a pose as a reply wrote it
  if (problems->size() != before) return false;
  *out = pose;
  return true;
}

namespace detail {

bool WritePoseQuaternion(const PoseWire& pose, nlohmann::json* value) {
  if (!pose.has_orientation) return false;
  *value = pose.quaternion;
  return true;
}

void ReadPoseQuaternion(const nlohmann::json* value, const std::string& path, PoseWire* pose) {
  pose->has_orientation = value != nullptr && !value->is_null();
  if (pose->has_orientation) {
    ReadWire(*value, path, &pose->quaternion);
  } else {
    pose->quaternion = {1.0, 0.0, 0.0, 0.0};
  }
}

void ReadResultQuaternion(const nlohmann::json* value, const std::string& path, PoseWire* pose) {
  if (value == nullptr) ThrowWire(path, "required");
  ReadWire(*value, path, &pose->quaternion);
  pose->has_orientation = true;
}

bool WritePoseRpy(const PoseWire& pose, nlohmann::json* value) {
  if (!pose.has_orientation) return false;
  const Eigen::Vector3d rpy = RpyFromRotation(PoseToTransform(pose).linear()) * kDegPerRad;
  *value = {rpy.x(), rpy.y(), rpy.z()};
  return true;
}

void SkipDerived(const nlohmann::json*, const std::string&, PoseWire*) {}

}  // namespace detail

Payload ToCore(const PayloadWire& p) {
  return {.mass_kg = p.mass_kg, .com_mm = Eigen::Vector3d(p.com_mm[0], p.com_mm[1], p.com_mm[2])};
}

Transform PoseToTransform(const PoseWire& p) {
  Transform t = Transform::Identity();
  t.translation() = Eigen::Vector3d(p.position_mm[0], p.position_mm[1], p.position_mm[2]);
  t.linear() = Eigen::Quaterniond(p.quaternion[0], p.quaternion[1], p.quaternion[2], p.quaternion[3])
                   .normalized()
                   .toRotationMatrix();
  return t;
}

PoseWire TransformToPose(const Transform& pose) {
  PoseWire p;
  const Eigen::Vector3d t = pose.translation();
  p.position_mm = {t.x(), t.y(), t.z()};
  Eigen::Quaterniond q(pose.linear());
  q.normalize();
  if (q.w() < 0) q.coeffs() *= -1.0;
  p.quaternion = {q.w(), q.x(), q.y(), q.z()};
  return p;
}

// ------------------------------------------------------------------------------------------------ small shapes

std::vector<DroppedParameterWire> ToWire(const std::vector<DroppedParameter>& dropped) {
  std::vector<DroppedParameterWire> out;
  for (const DroppedParameter& d : dropped) out.push_back({.name = d.name, .reason = d.reason});
  return out;
}

MeasurementNoise ToCore(const NoiseWire& noise) {
  return MeasurementNoise{noise.position_mm, noise.orientation_deg * kRadPerDeg, std::nullopt};
}

bool RequestReader<TrackerModelWire>::Read(const nlohmann::json& value, const std::string& path, Problems* problems,
                                           TrackerModelWire* out) {
  const std::size_t before = problems->size();
  TrackerModelWire t;
  ObjectReader r(value, path, problems);
  if (!r.ok()) return false;
  // [constant um, um per m]: the constant positive, the slope >= 0; 1 mm (1000 um) bounds what any tracker
  // could mean.
  const auto pair = [&](const char* key, std::array<double, 2>* value) {
    std::array<double, 2> read{};
    if (!r.FixedNumbers(key, false, read.data(), 2)) return;
    if (!(read[0] >= kMinTrackerUm && read[0] <= 1000.0)) {
      problems->Add(JoinPath(path, key) + "[0]", "the constant (um) must be in [0.001, 1000]");
    } else if (!(read[1] >= 0.0 && read[1] <= 1000.0)) {
      problems->Add(JoinPath(path, key) + "[1]", "the slope (um per m) must be in [0, 1000]");
    } else {
      *value = read;
    }
  };
  pair("radial_um", &t.radial_um);
  pair("transverse_um", &t.transverse_um);
  r.Number("orientation_deg", false, &t.orientation_deg, kMinTrackerOrientationDeg, 90.0);
  r.Number("mpe_sigmas", false, &t.mpe_sigmas, 0.1, 10.0);
  r.RejectUnknown(WireFieldNames<TrackerModelWire>());
  if (problems->size() != before) return false;
  *out = t;
  return true;
}

TrackerUncertainty ToCore(const TrackerModelWire& t) {
  TrackerUncertainty out;
  out.radial_um = t.radial_um[0];
  out.radial_um_per_m = t.radial_um[1];
  out.transverse_um = t.transverse_um[0];
  out.transverse_um_per_m = t.transverse_um[1];
  out.orientation_deg = t.orientation_deg;
  out.mpe_sigmas = t.mpe_sigmas;
  return out;
}

MeasurementNoise ToCore(const NoiseWire& noise, const std::optional<TrackerModelWire>& tracker) {
  MeasurementNoise out = ToCore(noise);
  if (tracker) out.tracker = ToCore(*tracker);
  return out;
}

// The shapes' to_json / from_json, instantiated here once (ROBOCAL_WIRE_DECLARE).
ROBOCAL_WIRE_DEFINE(FieldViolation);
ROBOCAL_WIRE_DEFINE(ErrorInfo);
ROBOCAL_WIRE_DEFINE(PoseWire);
ROBOCAL_WIRE_DEFINE(PoseResultWire);
ROBOCAL_WIRE_DEFINE(JointRangeWire);
ROBOCAL_WIRE_DEFINE(PayloadWire);
ROBOCAL_WIRE_DEFINE(DroppedParameterWire);
ROBOCAL_WIRE_DEFINE(NoiseWire);
ROBOCAL_WIRE_DEFINE(TrackerModelWire);

}  // namespace robocal::api
