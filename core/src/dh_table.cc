#include "robocal/core/dh_table.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>

#include "robocal/core/identification.h"
#include "robocal/core/joint_errors.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/units.h"

namespace robocal {
namespace {

// Two axes whose directions differ by less than this (rad) are parallel: treating them so moves a point a metre
// away by a nanometre at most.
constexpr double kParallelRad = 1e-12;
// Two parallel axes closer than this (mm) are the same line.
constexpr double kCoincident = 1e-12;
// A pair of axes parallel in the nominal model within this (rad) is "parallel" for the refusal's explanation.
constexpr double kNominallyParallel = 1e-9;
// Two parallel axes of the nominal model closer than this (mm) are "one line" for the refusal's explanation.
constexpr double kNominallyCoincident = 1e-9;
// No robot's table has a length beyond this (mm): a nominal table that does comes from axes nearly, not exactly,
// parallel, whose common normal lies far away.
constexpr double kMaxDhLengthMm = 1e5;

struct Line {
  Eigen::Vector3d point;
  Eigen::Vector3d dir;  // unit
};

struct Frame {
  Eigen::Vector3d o, x, z;
};

// The component of the unit vector v perpendicular to the unit vector z, normalised; that of `fallback` (a unit
// vector perpendicular to v) where v is within 30 degrees of z, so that a small turn of z never turns the result
// much.
Eigen::Vector3d Perpendicular(const Eigen::Vector3d& v, const Eigen::Vector3d& z, const Eigen::Vector3d& fallback) {
  Eigen::Vector3d p = v - v.dot(z) * z;
  if (p.norm() < 0.5) p = fallback - fallback.dot(z) * z;
  return p.normalized();
}

Eigen::Vector3d Foot(const Line& line, const Eigen::Vector3d& point) {
  return line.point + line.dir.dot(point - line.point) * line.dir;
}

// The angle from u to v about the unit axis k (both perpendicular to k).
double AngleAbout(const Eigen::Vector3d& u, const Eigen::Vector3d& v, const Eigen::Vector3d& k) {
  return std::atan2(k.dot(u.cross(v)), u.dot(v));
}

struct Normal {
  Eigen::Vector3d foot_a, foot_b, x;
};

// What decides the DH rules' free choices for one frame: a frame nearby (origin, x and y axes). The nominal
// table takes the model's own frames; the calibrated one takes the nominal table's, so that both make the same
// choices.
struct Ref {
  Eigen::Vector3d o, x, y;
};

Ref RefOf(const Transform& t) { return {t.translation(), t.linear().col(0), t.linear().col(1)}; }

// The common normal of lines a and b. Its x is signed to agree with the reference's x, or where that is nearly
// perpendicular to the normal, to point from a to b (or along a x b where they meet). Where the rules leave a
// choice (parallel lines: anywhere along them; the same line: any direction), the normal through the reference
// origin's foot on b, and the reference's x.
Normal CommonNormal(const Line& a, const Line& b, const Ref& ref) {
  Normal n;
  const Eigen::Vector3d c = a.dir.cross(b.dir);
  const double s = c.norm();
  if (s > kParallelRad) {
    // Closest points of the two lines: a.point + t a.dir and b.point + u b.dir.
    // In the cross-product form: the dot-product form cancels digits as the lines approach parallel.
    const Eigen::Vector3d w = b.point - a.point;
    const double t = w.cross(b.dir).dot(c) / (s * s), u = w.cross(a.dir).dot(c) / (s * s);
    n.foot_a = a.point + t * a.dir;
    n.foot_b = b.point + u * b.dir;
    n.x = c / s;
  } else {
    n.foot_b = Foot(b, ref.o);
    n.foot_a = Foot(a, n.foot_b);
    const Eigen::Vector3d v = n.foot_b - n.foot_a;
    n.x = v.norm() > kCoincident ? Eigen::Vector3d(v.normalized()) : Perpendicular(ref.x, a.dir, ref.y);
  }
  const double agree = n.x.dot(ref.x);
  if (std::abs(agree) > 0.1) {
    if (agree < 0.0) n.x = -n.x;
  } else if (n.x.dot(n.foot_b - n.foot_a) < -kCoincident) {
    n.x = -n.x;
  }
  return n;
}

// The calibrated chain at q = 0 as lines, and the frames that decide the DH rules' free choices.
struct ChainLines {
  std::vector<Line> axes;   // joint 1..n (0-based)
  Transform flange;         // last joint frame -> flange, in the tracker frame
  Transform base;           // tracker -> base, with the base error
  std::vector<Transform> site;  // the joints' frames before their errors (0-based joint)
  Transform tool;           // the calibrated tool
  // Where the model's own table puts the common normal of two parallel axes: through the joint frame on the
  // first of them (modified DH) or on the second (standard DH, and the transform convention's joint origins).
  // A calibrated twist of two such axes turns them about that normal, so the nominal tables of both conventions
  // put it there too.
  bool anchor_on_first = false;

  // The point the nominal common normal of axes k and k + 1 (k + 1 == n: the flange's z) passes through.
  Eigen::Vector3d Anchor(int k) const {
    if (anchor_on_first) return site[k].translation();
    return k + 1 < static_cast<int>(site.size()) ? site[k + 1].translation() : flange.translation();
  }
};

ChainLines LinesOf(const RobotModel& model, const Eigen::VectorXd& errors) {
  const int n = model.num_joints();
  KinematicsWorkspace ws(model);
  ChainLines lines;
  lines.tool = ForwardKinematics(model, Eigen::VectorXd::Zero(n), errors, &ws);
  for (int i = 0; i < n; ++i) {
    lines.axes.push_back({ws.T_world_joint[i].translation(), ws.T_world_joint[i].linear().col(2).normalized()});
    lines.site.push_back(ws.T_world_site[i + 1]);
  }
  lines.flange = ws.T_world_site[n + 1] * model.T_flange_tool().inverse();
  lines.anchor_on_first = model.spec().convention == GeometryConvention::kModifiedDh;
  lines.base = errors.size() == 0 ? model.T_world_base() : model.T_world_base() * ErrorTransform(errors.data());
  return lines;
}

Line LineOf(const Transform& t) { return {t.translation(), t.linear().col(2).normalized()}; }

Transform ToTransform(const Frame& f) {
  Transform t = Transform::Identity();
  t.linear().col(0) = f.x;
  t.linear().col(1) = f.z.cross(f.x);
  t.linear().col(2) = f.z;
  t.translation() = f.o;
  return t;
}

// Frame 0 of either convention: on the first axis, at the reference's foot, x nearest the reference's.
Frame FirstFrame(const ChainLines& lines, const Ref& ref) {
  Frame f;
  f.z = lines.axes[0].dir;
  f.o = Foot(lines.axes[0], ref.o);
  f.x = Perpendicular(ref.x, f.z, ref.y);
  return f;
}

struct Table {
  std::vector<JointSpec> rows;  // a_mm, alpha_rad, d_mm, theta_rad
  std::vector<Frame> frames;    // frame 0 .. n in the tracker frame at q = 0
  Transform T_world_base = Transform::Identity();
  Transform T_flange_tool = Transform::Identity();

  Ref RefAt(int i) const { return {frames[i].o, frames[i].x, frames[i].z.cross(frames[i].x)}; }
};

// A table of either convention before its rows: frame 0 (on the first axis) and the base pose to it.
Table StartTable(const ChainLines& lines, const Table* nominal) {
  Table table;
  table.rows.resize(lines.axes.size());
  const Frame first = FirstFrame(lines, nominal ? nominal->RefAt(0) : RefOf(lines.base));
  table.frames.push_back(first);
  table.T_world_base = ToTransform(first);
  return table;
}

// The tables of the calibrated chain take the nominal table (`nominal`) as reference; the nominal table the
// model's own frames: the calibrated base for frame 0, and the frame before each joint's error, or the flange.
Table StandardTable(const ChainLines& lines, const Table* nominal) {
  const int n = static_cast<int>(lines.axes.size());
  Table table = StartTable(lines, nominal);
  Frame prev = table.frames.front();
  for (int i = 0; i < n; ++i) {
    // Row i + 1: from frame i (on axis i + 1) to frame i + 1 (on the next axis, or the flange's z).
    const bool last = i + 1 == n;
    const Line next = last ? LineOf(lines.flange) : lines.axes[i + 1];
    Ref ref = nominal ? nominal->RefAt(i + 1) : RefOf(last ? lines.flange : lines.site[i + 1]);
    if (!nominal) ref.o = lines.Anchor(i);
    const Normal normal = CommonNormal({prev.o, prev.z}, next, ref);
    Frame f;
    f.o = normal.foot_b;
    f.x = normal.x;
    f.z = next.dir;
    JointSpec& row = table.rows[i];
    row.d_mm = (normal.foot_a - prev.o).dot(prev.z);
    row.theta_rad = AngleAbout(prev.x, f.x, prev.z);
    row.a_mm = (normal.foot_b - normal.foot_a).dot(f.x);
    row.alpha_rad = AngleAbout(prev.z, f.z, f.x);
    prev = f;
    table.frames.push_back(f);
  }
  table.T_flange_tool = ToTransform(prev).inverse() * lines.tool;
  return table;
}

Table ModifiedTable(const ChainLines& lines, const Table* nominal) {
  const int n = static_cast<int>(lines.axes.size());
  Table table = StartTable(lines, nominal);
  Frame prev = table.frames.front();
  Eigen::Vector3d prev_foot = prev.o;  // the foot on axis i of the normal from axis i - 1 (frame 0: on axis 1)
  for (int i = 0; i < n; ++i) {
    // Frame i + 1 sits on axis i + 1, its x along the normal to the next axis; the last one nearest the flange.
    Frame f;
    f.z = lines.axes[i].dir;
    Eigen::Vector3d foot_next;
    Ref ref = nominal ? nominal->RefAt(i + 1) : RefOf(i + 1 < n ? lines.site[i] : lines.flange);
    if (!nominal && i + 1 < n) ref.o = lines.Anchor(i);
    if (i + 1 < n) {
      const Normal normal = CommonNormal(lines.axes[i], lines.axes[i + 1], ref);
      f.o = normal.foot_a;
      f.x = normal.x;
      foot_next = normal.foot_b;
    } else {
      f.o = Foot(lines.axes[i], ref.o);
      f.x = Perpendicular(ref.x, f.z, ref.y);
    }
    JointSpec& row = table.rows[i];
    row.alpha_rad = AngleAbout(prev.z, f.z, prev.x);
    row.a_mm = (prev_foot - prev.o).dot(prev.x);
    row.theta_rad = AngleAbout(prev.x, f.x, f.z);
    row.d_mm = (f.o - prev_foot).dot(f.z);
    prev = f;
    table.frames.push_back(f);
    prev_foot = foot_next;
  }
  table.T_flange_tool = ToTransform(prev).inverse() * lines.tool;
  return table;
}


std::string Format(double value, int digits = 4) {
  std::ostringstream out;
  out.precision(digits);
  out << value;
  return out.str();
}

// The four fields of a row, in the order they are checked, and their deviation from the nominal row (mm or rad,
// angles wrapped).
constexpr int kFields = 4;
const char* const kFieldNames[kFields] = {"d_mm", "a_mm", "theta_deg", "alpha_deg"};
bool IsLength(int field) { return field < 2; }

double Deviation(const JointSpec& row, const JointSpec& nominal, int field) {
  switch (field) {
    case 0:
      return row.d_mm - nominal.d_mm;
    case 1:
      return row.a_mm - nominal.a_mm;
    case 2:
      return WrapAngle(row.theta_rad - nominal.theta_rad);
    default:
      return WrapAngle(row.alpha_rad - nominal.alpha_rad);
  }
}

bool Plausible(double deviation, int field) {
  return std::abs(deviation) <= (IsLength(field) ? kImplausibleErrorMm : kImplausibleErrorRad);
}

Table TableOf(const RobotModel& model, const Eigen::VectorXd& errors, bool standard, const Table* nominal) {
  const ChainLines lines = LinesOf(model, errors);
  return standard ? StandardTable(lines, nominal) : ModifiedTable(lines, nominal);
}

// The line after axis `k` (0-based) in the convention's sense: the next axis, or for the last the flange's z.
Line LineAfter(const ChainLines& lines, int k) {
  return k + 1 < static_cast<int>(lines.axes.size()) ? lines.axes[k + 1] : LineOf(lines.flange);
}

std::string AxisName(const RobotModel& model, int k) {
  return k < model.num_joints() ? "joint '" + model.joint_name(k) + "'" : "the flange's z axis";
}

std::string Shown(double value, bool length) {
  return length ? Format(value, 8) + " mm" : Format(value * kDegPerRad, 8) + " deg";
}

// The distance (mm) between two parallel lines.
double DistanceOfParallel(const Line& a, const Line& b) {
  const Eigen::Vector3d w = b.point - a.point;
  return (w - w.dot(a.dir) * a.dir).norm();
}

// The pairs of axes a row is read from: standard DH row i from axes i and i + 1 (and, through d, the normal
// before); modified DH row i from axes i - 1 and i (and, through d, the normal after). Pairs by their first axis.
std::vector<int> PairsOfRow(int row, bool standard) {
  return standard ? std::vector<int>{row, row - 1} : std::vector<int>{row - 1, row};
}

// Why the common normal of axes k and k + 1 is unusable, or empty when nothing about the pair explains it.
std::string PairExplanation(const RobotModel& model, const ChainLines& nominal, const ChainLines& lines, int k) {
  if (k < 0 || k >= model.num_joints()) return "";
  const Line na = nominal.axes[k], nb = LineAfter(nominal, k);
  const Line a = lines.axes[k], b = LineAfter(lines, k);
  // Angles from parallel, whichever way the axes point.
  const double nominal_angle = std::min(AngleBetween(na.dir, nb.dir), M_PI - AngleBetween(na.dir, nb.dir));
  const double angle = std::min(AngleBetween(a.dir, b.dir), M_PI - AngleBetween(a.dir, b.dir));
  const std::string pair = AxisName(model, k) + " and " + AxisName(model, k + 1);
  const std::string closest = ", and the common normal of two nearly parallel axes, which a DH table is built on, "
                              "lies where they pass closest";
  if (nominal_angle > kNominallyParallel) {
    if (nominal_angle > 1e-3) return "";
    return pair + " are " + Format(nominal_angle * kDegPerRad) + " deg from parallel in the nominal model" + closest;
  }
  if (DistanceOfParallel(na, nb) <= kNominallyCoincident) {
    if (angle <= kParallelRad && DistanceOfParallel(a, b) <= kNominallyCoincident) return "";
    return pair + " are one line in the nominal model and " + Format(angle * kDegPerRad) + " deg from parallel and " +
           Format(DistanceOfParallel(a, b)) + " mm apart in the calibrated one, and the x axis of a DH frame follows" +
           " the direction of their common normal, which turns with that small difference";
  }
  if (angle <= kParallelRad) return "";
  return pair + " are parallel in the nominal model and " + Format(angle * kDegPerRad) +
         " deg from parallel in the calibrated one" + closest;
}

// Refuses the table whose row `row` has `field` beyond what a calibration can move it. The explanation names a
// pair of axes next to the row that is parallel in the model and not in the calibration (where there is one),
// and the error parameters without which the field would stay within bounds (or, failing that, would move
// least).
[[noreturn]] void Refuse(const RobotModel& model, const Eigen::VectorXd& errors, const Table& nominal,
                         const Table& table, int row, int field, bool standard) {
  const bool length = IsLength(field);
  const std::string name = kFieldNames[field];
  const double nominal_value = length ? (field == 0 ? nominal.rows[row].d_mm : nominal.rows[row].a_mm)
                                      : (field == 2 ? nominal.rows[row].theta_rad : nominal.rows[row].alpha_rad);
  const double deviation = Deviation(table.rows[row], nominal.rows[row], field);
  std::ostringstream reason;
  reason << "the calibrated " << (standard ? "dh" : "mdh") << " table would have " << name << " = "
         << Shown(nominal_value + deviation, length) << " against " << Shown(nominal_value, length)
         << " in the nominal table";
  // Standard DH row i is read from axes i and i + 1 (and, through d, the normal before); modified DH row i from
  // axes i - 1 and i (and, through d, the normal after).
  const ChainLines nominal_lines = LinesOf(model, Eigen::VectorXd());
  const ChainLines lines = LinesOf(model, errors);
  for (int k : PairsOfRow(row, standard)) {
    const std::string why = PairExplanation(model, nominal_lines, lines, k);
    if (!why.empty()) {
      reason << ": " << why;
      break;
    }
  }
  // Leave one out: the parameters whose removal helps this field most.
  std::vector<std::pair<double, int>> without;
  for (int p = 0; p < errors.size(); ++p) {
    if (errors[p] == 0.0) continue;
    Eigen::VectorXd less = errors;
    less[p] = 0.0;
    const Table t = TableOf(model, less, standard, &nominal);
    without.emplace_back(std::abs(Deviation(t.rows[row], nominal.rows[row], field)), p);
  }
  std::sort(without.begin(), without.end());
  std::vector<std::string> parameters;
  const bool one_suffices = !without.empty() && Plausible(without.front().first, field);
  for (const auto& [remaining, p] : without) {
    if (parameters.size() == 3 || remaining >= std::abs(deviation)) break;
    if (one_suffices && !Plausible(remaining, field)) break;
    parameters.push_back(model.parameter_name(p));
    if (!one_suffices) break;  // none brings it within bounds alone: the one that helps most
  }
  if (!parameters.empty()) {
    reason << "; identified ";
    for (std::size_t i = 0; i < parameters.size(); ++i) {
      const int p = model.ParameterIndex(parameters[i]);
      const bool mm = RobotModel::IsTranslationParameter(p);
      reason << (i ? ", " : "") << parameters[i] << " = " << Format(mm ? errors[p] : errors[p] * kDegPerRad)
             << (mm ? " mm" : " deg");
    }
    if (one_suffices) {
      reason << (parameters.size() == 1 ? " puts it there (without it" : " put it there (without any one of them")
             << " the table would exist)";
    } else {
      reason << " moves it most";
    }
  }
  reason << ". The calibration can be written as a URDF or in robocal's own JSON.";
  throw DhTableError("joints[" + std::to_string(row) + "]." + name, reason.str(), std::move(parameters));
}

}  // namespace

DhTableError::DhTableError(std::string field, const std::string& reason, std::vector<std::string> parameters)
    : std::runtime_error(reason), field_(std::move(field)), parameters_(std::move(parameters)) {}

RobotModelSpec CalibratedDhSpec(const RobotModel& model, const Eigen::VectorXd& errors,
                                GeometryConvention convention) {
  if (convention != GeometryConvention::kStandardDh && convention != GeometryConvention::kModifiedDh) {
    throw std::invalid_argument("CalibratedDhSpec: the convention must be dh or mdh");
  }
  if (errors.size() != 0 && errors.size() != model.num_error_parameters()) {
    throw std::invalid_argument("CalibratedDhSpec: errors must have num_error_parameters values");
  }
  const bool standard = convention == GeometryConvention::kStandardDh;
  const Table nominal = TableOf(model, Eigen::VectorXd(), standard, nullptr);
  const Table table = TableOf(model, errors, standard, &nominal);

  RobotModelSpec spec;
  spec.name = model.name();
  spec.convention = convention;
  spec.T_world_base = table.T_world_base;
  spec.T_flange_tool = table.T_flange_tool;
  // A nominal geometry whose axes are nearly, not exactly, parallel has no usable table to calibrate.
  for (int i = 0; i < model.num_joints(); ++i) {
    for (const auto& [name, value] : {std::pair<const char*, double>{"d_mm", nominal.rows[i].d_mm},
                                      {"a_mm", nominal.rows[i].a_mm}}) {
      if (std::abs(value) <= kMaxDhLengthMm) continue;
      std::string reason = std::string("the nominal ") + (standard ? "dh" : "mdh") + " table would have " + name +
                           " = " + Shown(value, true);
      const ChainLines nominal_lines = LinesOf(model, Eigen::VectorXd());
      for (int k : PairsOfRow(i, standard)) {
        const std::string why = PairExplanation(model, nominal_lines, nominal_lines, k);
        if (!why.empty()) {
          reason += ": " + why;
          break;
        }
      }
      throw DhTableError("joints[" + std::to_string(i) + "]." + name,
                         reason + ". The calibration can be written as a URDF or in robocal's own JSON.", {});
    }
  }
  for (int i = 0; i < model.num_joints(); ++i) {
    const JointSpec& nom = nominal.rows[i];
    for (int field = 0; field < kFields; ++field) {
      if (!Plausible(Deviation(table.rows[i], nom, field), field)) {
        Refuse(model, errors, nominal, table, i, field, standard);
      }
    }
    JointSpec row = table.rows[i];
    // Angles next to the nominal ones, so that a table read beside the nominal one differs by the calibration.
    row.theta_rad = nom.theta_rad + WrapAngle(row.theta_rad - nom.theta_rad);
    row.alpha_rad = nom.alpha_rad + WrapAngle(row.alpha_rad - nom.alpha_rad);
    const JointSpec& source = model.spec().joints[i];
    row.name = source.name;
    row.type = source.type;
    row.min = source.min;
    row.max = source.max;
    spec.joints.push_back(row);
  }
  return spec;
}

RobotModelSpec CalibratedTransformSpec(const RobotModel& model, const Eigen::VectorXd& errors) {
  if (errors.size() != model.num_error_parameters()) {
    throw std::invalid_argument("CalibratedTransformSpec: errors has " + std::to_string(errors.size()) +
                                " values, the model has " + std::to_string(model.num_error_parameters()));
  }
  RobotModelSpec spec = model.spec();
  spec.convention = GeometryConvention::kTransform;
  const int n = model.num_joints();
  for (int i = 0; i < n; ++i) {
    // ForwardKinematics: ... * fixed(i) * E(site i + 1) * motion(q_i); the base site's E(0) stands before the
    // first fixed transform.
    Transform fixed = model.fixed_transform(i) * ErrorTransform(errors.data() + 6 * (i + 1));
    if (i == 0) fixed = ErrorTransform(errors.data()) * fixed;
    spec.joints[i].xyz_mm = fixed.translation();
    spec.joints[i].rpy_rad = RpyFromRotation(fixed.linear());
    spec.joints[i].a_mm = spec.joints[i].alpha_rad = spec.joints[i].d_mm = spec.joints[i].theta_rad = 0.0;
    // The centre of mass from the link frame (standard DH: DH frame i) into the joint frame after its motion,
    // the transform convention's link frame.
    spec.joints[i].com_mm = model.link_frame(i) * model.spec().joints[i].com_mm;
  }
  spec.T_lastjoint_flange = model.T_lastjoint_flange();
  spec.T_flange_tool = model.T_flange_tool() * ErrorTransform(errors.data() + 6 * (model.num_error_sites() - 1));
  // The joint terms' parameters join the joint terms the joints hold (JointDeflection adds both alike); the
  // result is a robot, its fit's error terms are the next calibration's choice.
  const int first = model.num_geometric_parameters();
  for (size_t t = 0; t < model.joint_terms().size(); ++t) {
    HeldJointTerm(&spec, model.joint_terms()[t]) += errors[first + static_cast<Eigen::Index>(t)];
  }
  spec.error_terms = JointErrorTerms();
  return spec;
}

}  // namespace robocal
