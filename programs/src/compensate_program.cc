// A program compensated on a calibration (compensate_program.h): read, the joints the controller would use for
// each target as written (a nominal pass in program order), every target solved on the calibrated robot from
// those joints (in parallel: given its start, a target does not depend on the others), straight moves checked
// and split, and the numbers written back into their own bytes.
#include "robocal/programs/compensate_program.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>

#include "robocal/core/arm_kinematics.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/prediction.h"
#include "robocal/core/units.h"
#include "robocal/programs/text_scan.h"

namespace robocal::programs {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// What the targets of one program share.
struct Context {
  const Calibration& calibration;
  const RobotModel& nominal;
  const DialectSyntax& syntax;
  const std::vector<ProgramFile>& files;
  const ProgramCompensationOptions& options;
  std::optional<ArmSolver> arm;
  // The nominal robot as a calibration (no errors, its own base): the controller's inverse kinematics.
  Calibration controller;
  Transform T_base_world_nominal;
  Transform T_base_world_calibrated;
};

// Number units of a target's values, in order.
NumberUnit UnitOf(const Context& ctx, const ProgramTarget& t, std::size_t k) {
  if (t.kind == TargetKind::kJoint) {
    if (static_cast<int>(k) < ctx.nominal.num_joints() &&
        ctx.nominal.joint_type(static_cast<int>(k)) == JointType::kPrismatic) {
      return ctx.syntax.mm_per_length_unit == 1.0 ? NumberUnit::kMm : NumberUnit::kM;
    }
    return ctx.syntax.joints_in_rad ? NumberUnit::kRad : NumberUnit::kDeg;
  }
  if (k < 3) return ctx.syntax.mm_per_length_unit == 1.0 ? NumberUnit::kMm : NumberUnit::kM;
  switch (ctx.syntax.rotation) {
    case RotationConvention::kQuaternionWxyz:
      return NumberUnit::kQuaternion;
    case RotationConvention::kRotationVectorRad:
      return NumberUnit::kRad;
    default:
      return NumberUnit::kDeg;
  }
}

// Written joint values -> core units (rad / mm), and back.
Eigen::VectorXd JointsToCore(const Context& ctx, const std::vector<double>& values) {
  Eigen::VectorXd q(static_cast<Eigen::Index>(values.size()));
  for (std::size_t k = 0; k < values.size(); ++k) {
    const bool prismatic = ctx.nominal.joint_type(static_cast<int>(k)) == JointType::kPrismatic;
    q[static_cast<Eigen::Index>(k)] = prismatic                  ? values[k] * ctx.syntax.mm_per_length_unit
                                      : ctx.syntax.joints_in_rad ? values[k]
                                                                 : values[k] * kRadPerDeg;
  }
  return q;
}

std::vector<double> JointsFromCore(const Context& ctx, const Eigen::VectorXd& q) {
  std::vector<double> values(static_cast<std::size_t>(q.size()));
  for (Eigen::Index k = 0; k < q.size(); ++k) {
    const bool prismatic = ctx.nominal.joint_type(static_cast<int>(k)) == JointType::kPrismatic;
    values[static_cast<std::size_t>(k)] = prismatic                  ? q[k] / ctx.syntax.mm_per_length_unit
                                          : ctx.syntax.joints_in_rad ? q[k]
                                                                     : q[k] * kDegPerRad;
  }
  return values;
}

// A tool or base entry of the request as a transform; std::invalid_argument naming it.
Transform EntryPose(const DialectSyntax& syntax, const std::string& field, const std::vector<double>& values) {
  try {
    return PoseFromValues(syntax, values);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(field + ": " + e.what());
  }
}

// Where a target's frames put it: T_base_frame (the program's base / work object in the robot base) and the
// transform from the robot's own tool to the program's tool.
struct Frames {
  Transform T_base_frame = Transform::Identity();
  // T_tool0_toolK = T_flange_tool0^-1 * T_flange_toolK (identity for the robot's own tool).
  Transform T_tool0_tool = Transform::Identity();
};

Frames FramesOf(const Context& ctx, const ProgramTarget& t, const std::vector<SourceText>& sources) {
  Frames frames;
  if (!t.base.empty()) {
    const auto it = ctx.options.bases.find(t.base);
    if (it == ctx.options.bases.end()) {
      const SourceText& source = sources[static_cast<std::size_t>(t.file)];
      const std::size_t at = t.spans.empty() ? source.LineStart(std::max(1, t.line)) : t.spans.front().offset;
      source.Fail(at, "the target" + (t.name ? " " + *t.name : std::string()) + " is in base '" + t.base +
                          "', which `bases` does not give");
    }
    frames.T_base_frame = EntryPose(ctx.syntax, "bases." + t.base, it->second);
  }
  if (!t.tool.empty()) {
    const auto it = ctx.options.tools.find(t.tool);
    if (it != ctx.options.tools.end()) {
      frames.T_tool0_tool =
          ctx.nominal.T_flange_tool().inverse() * EntryPose(ctx.syntax, "tools." + t.tool, it->second);
    }
  }
  return frames;
}

// The target as written: the pose of the robot's own tool in the robot base (mm, rad).
Transform WrittenToolPose(const Context& ctx, const ProgramTarget& t, const Frames& frames,
                          const std::vector<SourceText>& sources) {
  try {
    return frames.T_base_frame * PoseFromValues(ctx.syntax, t.values) * frames.T_tool0_tool.inverse();
  } catch (const std::invalid_argument& e) {
    sources[static_cast<std::size_t>(t.file)].Fail(t.spans.empty() ? 0 : t.spans.front().offset, e.what());
  }
}

// The nominal tool pose in the robot base at q.
Transform NominalToolPose(const Context& ctx, const Eigen::VectorXd& q) {
  return ctx.T_base_world_nominal * ForwardKinematics(ctx.nominal, q);
}

// Of q + 2 pi k per revolute joint, the one within the target's turn ranges and the limits nearest `near`.
// False if a turn range cannot be met within the limits.
bool PlaceTurns(const Context& ctx, const std::vector<JointRange>& turns, const Eigen::VectorXd& near,
                Eigen::VectorXd* q) {
  constexpr double kTurn = 2.0 * std::numbers::pi;
  bool met = true;
  for (int i = 0; i < q->size(); ++i) {
    if (ctx.nominal.joint_type(i) != JointType::kRevolute) continue;
    double lower = ctx.nominal.lower_limits()[i], upper = ctx.nominal.upper_limits()[i];
    for (const JointRange& r : turns) {
      if (r.joint == i) lower = std::max(lower, r.min), upper = std::min(upper, r.max);
    }
    const double base = (*q)[i];
    double best = base, best_distance = HUGE_VAL;
    bool inside = false;
    if (lower <= upper) {
      const double k_low = std::floor((lower - base) / kTurn), k_high = std::ceil((upper - base) / kTurn);
      for (double k = k_low; k <= k_high && k - k_low < 64; ++k) {
        const double v = base + k * kTurn;
        if (v < lower - 1e-12 || v >= upper + 1e-12) continue;
        const double distance = std::abs(v - near[i]);
        if (distance < best_distance) best = v, best_distance = distance, inside = true;
      }
    }
    if (!inside) met = false;
    (*q)[i] = best;
  }
  return met;
}

bool TurnsMet(const std::vector<JointRange>& turns, const Eigen::VectorXd& q) {
  for (const JointRange& r : turns) {
    if (r.joint < 0 || r.joint >= q.size()) continue;
    if (!(q[r.joint] >= r.min - 1e-9 && q[r.joint] < r.max + 1e-9)) return false;
  }
  return true;
}

// The nominal robot's joints for a pose as the controller takes them: of the exact closed-form solutions whose flags
// `wanted` admits, the one meeting `turns` (placed in them and the limits) nearest `near`; with `prefer_default`,
// front, up and noflip first (the shoulder weighing most), as the core's rule for a target without a hint. A robot
// without named branches: the controller's solution from `near`. Empty when there is none; `why` then (or when
// only other turns reach it) says so.
Eigen::VectorXd NominalSolution(const Context& ctx, const Transform& T_base_tool, const ArmConfiguration& wanted,
                                const std::vector<JointRange>& turns, const Eigen::VectorXd& near, bool prefer_default,
                                std::string* why) {
  if (ctx.arm) {
    auto preference = [&](const ArmConfiguration& c) {
      return prefer_default ? 4 * (c.shoulder != 1) + 2 * (c.elbow != 1) + (c.wrist != 1) : 0;
    };
    Eigen::VectorXd best;
    std::tuple<bool, int, double> best_rank{false, 0, HUGE_VAL};
    for (const ArmSolution& s : ctx.arm->Solve(T_base_tool, near)) {
      if (!wanted.Admits(s.configuration)) continue;
      if (s.position_error_mm > 1e-6 || s.orientation_error_rad > 1e-9) continue;  // not an exact solution
      Eigen::VectorXd q = s.joints;
      const bool met = PlaceTurns(ctx, turns, near, &q);
      const std::tuple<bool, int, double> rank{!met, preference(s.configuration), (q - near).squaredNorm()};
      if (best.size() == 0 || rank < best_rank) best = q, best_rank = rank;
    }
    if (best.size() == 0) {
      *why = "the nominal robot does not reach the target as written on " +
             (wanted.empty() ? std::string("any branch") : wanted.ToString());
    } else if (std::get<0>(best_rank)) {
      *why = "the nominal robot reaches the target as written only with other turns than the target names";
    }
    return best;
  }
  CompensationTarget target;
  target.pose = T_base_tool;
  target.frame = TargetFrame::kBase;
  target.start = near;
  const CompensationResult r = Compensate(ctx.controller, ctx.nominal, target, ctx.options.solver);
  if (!r.converged) {
    *why = "the nominal robot does not reach the target as written: " + r.message;
    return {};
  }
  return r.joints;
}

// The joints the controller uses for a Cartesian target as written: on the branch the target names (flags and
// turns) or, where none applies, on the previous target's branch nearest its joints.
Eigen::VectorXd ControllerJoints(const Context& ctx, const ProgramTarget& t, const Transform& T_base_tool,
                                 const Eigen::VectorXd& previous, std::string* why) {
  const Eigen::VectorXd& near = previous.size() != 0 ? previous : DefaultJoints(ctx.nominal);
  ArmConfiguration wanted = t.configuration_applies ? t.configuration : ArmConfiguration{};
  if (ctx.arm && !t.configuration_applies && previous.size() != 0) wanted = ctx.arm->ConfigurationOf(previous);
  const bool first_without_flags = !t.configuration_applies && previous.size() == 0;
  return NominalSolution(ctx, T_base_tool, wanted, t.configuration_applies ? t.turns : std::vector<JointRange>{}, near,
                         first_without_flags, why);
}

double LargestRevoluteChange(const RobotModel& model, const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  if (a.size() != b.size() || a.size() == 0) return kNaN;
  double change = kNaN;
  for (int i = 0; i < a.size(); ++i) {
    if (model.joint_type(i) != JointType::kRevolute) continue;
    const double d = std::abs(a[i] - b[i]);
    change = std::isnan(change) ? d : std::max(change, d);
  }
  return change;
}

// One edit of a file: bytes [offset, offset + length) replaced by `text` (length 0: an insertion).
struct Edit {
  std::size_t offset = 0;
  std::size_t length = 0;
  std::string text;
};

// The line end that follows `end` in `text` ("\r\n", "\n" or "\r"), or the file's first one, or "\n".
std::string LineEndAt(std::string_view text, std::size_t end) {
  if (end < text.size()) {
    if (text[end] == '\r') return end + 1 < text.size() && text[end + 1] == '\n' ? "\r\n" : "\r";
    if (text[end] == '\n') return "\n";
  }
  const std::size_t first = text.find_first_of("\r\n");
  if (first != std::string_view::npos && text[first] == '\r') {
    return first + 1 < text.size() && text[first + 1] == '\n' ? "\r\n" : "\r";
  }
  return "\n";
}

// The text inserted before a motion statement: a copy of the statement with its references replaced, on a line of its
// own. `replacements` are (reference begin, reference end, text), within the statement. The copy is the
// statement's own bytes when the reader gives them (another statement may share its lines), else its lines.
Edit InsertedStatement(std::string_view text, const MotionStatement& m,
                       std::vector<std::tuple<std::size_t, std::size_t, std::string>> replacements) {
  const bool own = m.own_end > m.own_begin && m.own_begin >= m.begin && m.own_end <= m.end;
  const std::size_t from = own ? m.own_begin : m.begin, to = own ? m.own_end : m.end;
  std::sort(replacements.begin(), replacements.end(),
            [](const auto& a, const auto& b) { return std::get<0>(a) > std::get<0>(b); });
  std::string copy(text.substr(from, to - from));
  for (const auto& [begin, end, with] : replacements) copy.replace(begin - from, end - begin, with);
  const std::string line_end = LineEndAt(text, m.end);
  if (!own) return {m.begin, 0, copy + line_end};
  // Before the statement itself: the copy, the line end, and the indentation of the statement's first line; when
  // another statement precedes it on that line, a line end and the indentation first, so the copy stands alone.
  std::size_t indent = m.begin;
  while (indent < m.own_begin && (text[indent] == ' ' || text[indent] == '\t')) ++indent;
  const std::string indentation(text.substr(m.begin, indent - m.begin));
  const std::string before = indent < m.own_begin ? line_end + indentation : "";
  return {m.own_begin, 0, before + copy + line_end + indentation};
}

// Per target, what the solve needs and gives.
struct Work {
  Frames frames;
  // The robot's own tool in the robot base as written (Cartesian), or the nominal pose of the written joints.
  Transform written = Transform::Identity();
  // The controller's joints for the target as written; empty if it has none.
  Eigen::VectorXd controller;
  std::string controller_problem;
  bool solved = false;
  CompensationResult result;
  // The new values (dialect units) when rewritten.
  std::vector<double> values;
  double predicted_error_mm = std::numeric_limits<double>::quiet_NaN();
};

// Linear interpolation of positions and spherical of rotations, at s in [0, 1].
Transform Interpolate(const Transform& a, const Transform& b, double s) {
  Transform t = Transform::Identity();
  t.translation() = (1.0 - s) * a.translation() + s * b.translation();
  const Eigen::Quaterniond qa(a.linear()), qb(b.linear());
  t.linear() = qa.slerp(s, qb).toRotationMatrix();
  return t;
}

// The circle through three tool positions, as a circular move runs it from `a` through `via` to `b`: the pose at
// fraction s of the arc from a to b (positions on the circle, rotations slerped from a to b as for a straight
// move). nullopt when the three points are (nearly) on a line.
struct Arc {
  Eigen::Vector3d centre, u, v;
  double radius = 0.0, angle = 0.0;
  Transform a, b;
};
std::optional<Arc> ArcThrough(const Transform& a, const Transform& via, const Transform& b) {
  const Eigen::Vector3d p0 = a.translation(), p1 = via.translation(), p2 = b.translation();
  const Eigen::Vector3d d1 = p1 - p0, d2 = p2 - p0;
  const Eigen::Vector3d n = d1.cross(d2);
  const double n2 = n.squaredNorm();
  if (n2 < 1e-9 * d1.squaredNorm() * d2.squaredNorm() || n2 == 0.0) return std::nullopt;
  Arc arc;
  // The circumcentre of the triangle (p0, p1, p2).
  arc.centre = p0 + (d2.squaredNorm() * n.cross(d1) + d1.squaredNorm() * d2.cross(n)) / (2.0 * n2);
  arc.radius = (p0 - arc.centre).norm();
  arc.u = (p0 - arc.centre) / arc.radius;
  arc.v = n.normalized().cross(arc.u);
  // p0 -> p1 -> p2 turns positively about n, so p2's angle in [0, 2 pi) is the whole arc's.
  const Eigen::Vector3d r2 = p2 - arc.centre;
  arc.angle = std::atan2(arc.v.dot(r2), arc.u.dot(r2));
  if (arc.angle < 0.0) arc.angle += 2.0 * std::numbers::pi;
  arc.a = a;
  arc.b = b;
  return arc;
}

Transform ArcAt(const Arc& arc, double s) {
  Transform t = Interpolate(arc.a, arc.b, s);
  const double phi = s * arc.angle;
  t.translation() = arc.centre + arc.radius * (std::cos(phi) * arc.u + std::sin(phi) * arc.v);
  return t;
}

// The calibrated robot's tool in the robot base (its calibrated base) at q.
Transform CalibratedToolPose(const Context& ctx, const Eigen::VectorXd& q) {
  KinematicsWorkspace ws(ctx.calibration.model);
  return ctx.T_base_world_calibrated *
         ForwardKinematics(ctx.calibration.model, q, ctx.calibration.errors, &ws, ctx.options.payload);
}

// A straight segment between two compensated ends, checked at its midpoint and split while it deviates.
struct Segment {
  Transform intended_a, intended_b;  // the programmed ends (robot's tool, base frame)
  Transform written_a, written_b;    // the ends as written after compensation (nominal poses)
  Eigen::VectorXd q_a, q_b;          // the controller's joints at the written ends
};

struct Inserted {
  Eigen::VectorXd joints;
  Transform written;
  CompensationResult result;
};

class PathChecker {
 public:
  explicit PathChecker(const Context& ctx) : ctx_(ctx) {}

  // A circular move from the written a through via to b, checked at its midpoint as Split checks a straight one:
  // its deviation from the programmed arc (mm), or NaN when either arc is a line or the controller has no joints.
  double CircleDeviation(const Arc& intended, const Arc& written, const Eigen::VectorXd& q_a,
                         const Eigen::VectorXd& q_b) const {
    const Eigen::VectorXd q_mid = ControllerAt(ArcAt(written, 0.5), q_b, 0.5 * (q_a + q_b));
    if (q_mid.size() == 0) return std::numeric_limits<double>::quiet_NaN();
    return (CalibratedToolPose(ctx_, q_mid).translation() - ArcAt(intended, 0.5).translation()).norm();
  }

  // The targets to insert between the ends (in path order); *over: the segment still deviates after the deepest
  // split. Each piece's midpoint is checked: the controller's joints there (nominal IK of the written ends'
  // interpolation, on the branch of the end) moved on the calibrated robot, against the programmed path.
  void Split(const Segment& s, int depth, std::vector<Inserted>* out, bool* over) const {
    const Transform written_mid = Interpolate(s.written_a, s.written_b, 0.5);
    const Eigen::VectorXd near = 0.5 * (s.q_a + s.q_b);
    Eigen::VectorXd q_mid = ControllerAt(written_mid, s.q_b, near);
    if (q_mid.size() == 0) return;  // the controller has no solution there either: nothing to compare
    const Transform intended_mid = Interpolate(s.intended_a, s.intended_b, 0.5);
    const double deviation = (CalibratedToolPose(ctx_, q_mid).translation() - intended_mid.translation()).norm();
    if (deviation <= *ctx_.options.max_path_deviation_mm) return;
    if (depth >= ctx_.options.max_split_depth) {
      *over = true;
      return;
    }
    CompensationTarget target;
    target.pose = intended_mid;
    target.frame = TargetFrame::kBase;
    target.start = q_mid;
    target.payload = ctx_.options.payload;
    Inserted mid;
    mid.result = Compensate(ctx_.calibration, ctx_.nominal, target, ctx_.options.solver);
    if (!mid.result.converged) {
      *over = true;
      return;
    }
    mid.joints = mid.result.joints;
    mid.written = NominalToolPose(ctx_, mid.joints);
    Segment first{s.intended_a, intended_mid, s.written_a, mid.written, s.q_a, mid.joints};
    Segment second{intended_mid, s.intended_b, mid.written, s.written_b, mid.joints, s.q_b};
    Split(first, depth + 1, out, over);
    out->push_back(mid);
    Split(second, depth + 1, out, over);
  }

  // The controller's joints for a pose on the branch of `branch`, nearest `near`; empty when it has none.
  Eigen::VectorXd ControllerAt(const Transform& T_base_tool, const Eigen::VectorXd& branch,
                               const Eigen::VectorXd& near) const {
    const ArmConfiguration wanted = ctx_.arm ? ctx_.arm->ConfigurationOf(branch) : ArmConfiguration{};
    std::string why;
    return NominalSolution(ctx_, T_base_tool, wanted, {}, near, false, &why);
  }

 private:
  const Context& ctx_;
};

std::string TargetLabel(const ProgramFile& file, const CompensatedTarget& t) {
  return file.name + ":" + std::to_string(t.line) + (t.name ? " " + *t.name : std::string(" (inline)"));
}

// The request's checks before anything is read: std::invalid_argument saying what is wrong.
void CheckProgramRequest(const Calibration& calibration, const RobotModel& nominal, const DialectSyntax& syntax,
                         const ProgramCompensationOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("ProgramCompensationOptions: " + error);
  if (nominal.num_joints() != calibration.model.num_joints()) {
    throw std::invalid_argument("CompensateProgram: the nominal model has another number of joints");
  }
  if (syntax.read == nullptr)
    throw std::invalid_argument(std::string("CompensateProgram: ") + syntax.name + " has no reader");
  if (options.max_path_deviation_mm && syntax.inline_target == nullptr) {
    throw std::invalid_argument(std::string("max_path_deviation_mm: a ") + syntax.name +
                                " program cannot take inserted targets");
  }
}

// Every target's frames and written pose first: a frame the request does not give refuses the program before
// anything is solved.
std::vector<Work> PrepareTargets(const Context& ctx, const ParsedProgram& program,
                                 const std::vector<SourceText>& sources) {
  const std::size_t n = program.targets.size();
  const int joints = ctx.nominal.num_joints();
  std::vector<Work> work(n);
  for (std::size_t i = 0; i < n; ++i) {
    const ProgramTarget& t = program.targets[i];
    if (t.values.size() != t.spans.size()) throw std::logic_error("reader: values and spans differ in number");
    if (t.kind == TargetKind::kJoint) {
      if (static_cast<int>(t.values.size()) != joints) {
        sources[static_cast<std::size_t>(t.file)].Fail(t.spans.empty() ? 0 : t.spans.front().offset,
                                                       "the joint target has " + std::to_string(t.values.size()) +
                                                           " robot axes, the robot " + std::to_string(joints));
      }
      work[i].controller = JointsToCore(ctx, t.values);
      work[i].written = NominalToolPose(ctx, work[i].controller);
    } else {
      work[i].frames = FramesOf(ctx, t, sources);
      work[i].written = WrittenToolPose(ctx, t, work[i].frames, sources);
    }
  }
  return work;
}

// The controller's joints in program order: motions first (each target at its first motion, from the previous
// motion's target), then the targets no motion uses, each from the target before it in the files.
void PlaceControllerJoints(const Context& ctx, const ParsedProgram& program, std::vector<Work>* work) {
  const std::size_t n = program.targets.size();
  std::vector<int> order;
  std::vector<char> placed(n, 0);
  for (const MotionStatement& m : program.motions) {
    if (m.target >= 0 && static_cast<std::size_t>(m.target) < n && !placed[static_cast<std::size_t>(m.target)]) {
      placed[static_cast<std::size_t>(m.target)] = 1;
      order.push_back(m.target);
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!placed[i]) order.push_back(static_cast<int>(i));
  }
  Eigen::VectorXd previous;
  for (int i : order) {
    const ProgramTarget& t = program.targets[static_cast<std::size_t>(i)];
    Work& w = (*work)[static_cast<std::size_t>(i)];
    if (t.kind == TargetKind::kCartesian) {
      w.controller = ControllerJoints(ctx, t, w.written, previous, &w.controller_problem);
    }
    if (w.controller.size() != 0) previous = w.controller;
  }
}

// Solve every target from the controller's joints (independent of each other now: in parallel), with the
// predicted error bound at its solution.
void SolveTargets(const Context& ctx, const ParsedProgram& program, std::vector<Work>* work) {
  const ProgramCompensationOptions& options = ctx.options;
  std::vector<CompensationTarget> targets;
  std::vector<std::size_t> index;
  for (std::size_t i = 0; i < program.targets.size(); ++i) {
    const ProgramTarget& t = program.targets[i];
    const Work& w = (*work)[i];
    if (w.controller.size() == 0) continue;
    CompensationTarget target;
    if (t.kind == TargetKind::kJoint) {
      target.joints = w.controller;
    } else {
      target.pose = w.written;
      target.frame = TargetFrame::kBase;
      target.start = w.controller;
      if (t.configuration_applies && ctx.arm) target.configuration = t.configuration;
    }
    target.payload = options.payload;
    targets.push_back(std::move(target));
    index.push_back(i);
  }
  const std::vector<CompensationResult> solved =
      CompensateAll(ctx.calibration, ctx.nominal, targets, options.solver, options.threads);
  std::vector<Eigen::VectorXd> solved_joints;
  solved_joints.reserve(solved.size());
  for (const CompensationResult& r : solved) solved_joints.push_back(r.joints);
  const std::vector<double> bounds = PredictPositionErrorBounds(ctx.calibration, solved_joints, {options.payload},
                                                                options.prediction, options.threads);
  for (std::size_t k = 0; k < index.size(); ++k) {
    Work& w = (*work)[index[k]];
    w.result = solved[k];
    w.solved = true;
    w.predicted_error_mm = bounds[k];
  }
}

// A solved target's correction: the nominal pose at its compensated joints against the pose as written, in the
// target's own tool and frame; w->values its new numbers (dialect units).
void MeasureCorrection(const Context& ctx, const ProgramTarget& t, Work* w, CompensatedTarget* c) {
  const Transform reached = NominalToolPose(ctx, w->result.joints);
  if (t.kind == TargetKind::kJoint) {
    c->correction_mm = (reached.translation() - w->written.translation()).norm();
    c->correction_rad = Eigen::AngleAxisd(w->written.linear().transpose() * reached.linear()).angle();
    w->values = JointsFromCore(ctx, w->result.joints);
  } else {
    // The nominal pose at the compensated joints, in the target's own tool and frame.
    const Transform in_frame = w->frames.T_base_frame.inverse() * reached * w->frames.T_tool0_tool;
    const Transform as_written = w->frames.T_base_frame.inverse() * w->written * w->frames.T_tool0_tool;
    c->correction_mm = (in_frame.translation() - as_written.translation()).norm();
    c->correction_rad = Eigen::AngleAxisd(as_written.linear().transpose() * in_frame.linear()).angle();
    w->values = ValuesFromPose(ctx.syntax, in_frame, t.values);
  }
}

// A target's outcome: its termination, whether the controller's branch and turns are kept, its correction.
CompensatedTarget JudgeTarget(const Context& ctx, const ProgramTarget& t, Work* w) {
  const int joints = ctx.nominal.num_joints();
  CompensatedTarget c;
  c.file = t.file, c.line = t.line, c.column = t.column, c.name = t.name, c.kind = t.kind;
  if (!w->solved) {
    c.termination = Termination::kFailure;
    c.message = w->controller_problem;
    c.configuration_kept = false;
    return c;
  }
  const CompensationResult& r = w->result;
  c.termination = r.termination;
  c.message = r.message;
  c.joints = r.joints;
  c.joint_change_rad = LargestRevoluteChange(ctx.nominal, r.joints, w->controller);
  c.predicted_error_mm = w->predicted_error_mm;
  // The branch the controller uses for the target as written, kept? And its turns.
  if (r.joints.size() == joints && ctx.arm) {
    const ArmConfiguration wanted = t.kind == TargetKind::kCartesian && t.configuration_applies
                                        ? t.configuration
                                        : ctx.arm->ConfigurationOf(w->controller);
    c.configuration_kept = r.configuration && wanted.Admits(*r.configuration);
  }
  if (r.joints.size() == joints && t.kind == TargetKind::kCartesian && t.configuration_applies &&
      !TurnsMet(t.turns, r.joints)) {
    c.configuration_kept = false;
  }
  if (!c.configuration_kept && c.message.empty()) {
    c.message = "the calibrated solution nearest the target's joints has other configuration flags or turns (" +
                (r.configuration ? r.configuration->ToString() : std::string("unknown")) + ") than the target";
  }
  if (r.joints.size() == joints) MeasureCorrection(ctx, t, w, &c);
  return c;
}

// What the passes after the solve build: the reply (its summary as they go), each file's edits, and the targets
// as read (index i) and inserted, each with where it sorts (file, offset).
struct ProgramOutcome {
  ProgramCompensationResult result;
  std::vector<std::vector<Edit>> edits;
  std::vector<CompensatedTarget> compensated;
  std::vector<std::pair<int, std::size_t>> sort_keys;
  std::vector<std::pair<std::pair<int, std::size_t>, CompensatedTarget>> inserted_targets;
};

// A kept target's numbers written over their own bytes where they change, and the summary's maxima.
void RewriteTargetNumbers(const Context& ctx, const ProgramTarget& t, const Work& w, CompensatedTarget* c,
                          ProgramOutcome* out) {
  ProgramCompensationSummary& summary = out->result.summary;
  for (std::size_t k = 0; k < t.spans.size(); ++k) {
    const NumberSpan& span = t.spans[k];
    const std::string_view original =
        std::string_view(ctx.files[static_cast<std::size_t>(span.file)].text).substr(span.offset, span.length);
    std::string text = FormatLike(original, w.values[k], UnitOf(ctx, t, k));
    if (text != original) {
      out->edits[static_cast<std::size_t>(span.file)].push_back({span.offset, span.length, std::move(text)});
      c->rewritten = true;
    }
  }
  if (c->rewritten) ++summary.rewritten;
  summary.max_correction_mm = std::max(summary.max_correction_mm, c->correction_mm);
  if (std::isfinite(c->predicted_error_mm) && !(c->predicted_error_mm <= summary.max_predicted_error_mm)) {
    summary.max_predicted_error_mm = c->predicted_error_mm;
  }
}

// Judge each target and prepare its numbers.
void JudgeTargets(const Context& ctx, const ParsedProgram& program, std::vector<Work>* work, ProgramOutcome* out) {
  const std::size_t n = program.targets.size();
  ProgramCompensationSummary& summary = out->result.summary;
  out->edits.resize(ctx.files.size());
  out->compensated.resize(n);
  out->sort_keys.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const ProgramTarget& t = program.targets[i];
    ++summary.targets;
    ++(t.kind == TargetKind::kJoint ? summary.joint_targets : summary.cartesian_targets);
    CompensatedTarget c = JudgeTarget(ctx, t, &(*work)[i]);
    const bool ok = c.termination == Termination::kConvergence && c.configuration_kept;
    if (ok) {
      RewriteTargetNumbers(ctx, t, (*work)[i], &c, out);
    } else {
      ++summary.failed;
      if (!c.configuration_kept) ++summary.configuration_changes;
    }
    out->sort_keys[i] = {t.file, t.spans.empty() ? 0 : t.spans.front().offset};
    out->compensated[i] = std::move(c);
  }
}

// A circular move: the targets it runs from (the previous motion's), through (via) and to, the controller's joints
// at its ends, and its arcs as programmed (intended) and as the controller runs the written targets.
struct CircleMove {
  std::size_t a = 0, v = 0, b = 0;
  Eigen::VectorXd q_a, q_b;
  Arc intended, written;
};

// Straight and circular moves: the path between the compensated ends, checked and split where it deviates.
class PathPass {
 public:
  PathPass(const Context& ctx, const ParsedProgram& program, const std::vector<Work>& work, ProgramOutcome* out)
      : ctx_(ctx), program_(program), work_(work), out_(*out), summary_(out->result.summary), checker_(ctx) {}

  void Run() {
    const std::vector<MotionStatement>& motions = program_.motions;
    for (std::size_t m = 1; m < motions.size(); ++m) {
      const MotionStatement& here = motions[m];
      const MotionStatement& before = motions[m - 1];
      if (here.motion == Motion::kCircular && m + 1 < motions.size() && motions[m + 1].motion == Motion::kCircular &&
          motions[m + 1].begin == here.begin && motions[m + 1].file == here.file && here.file >= 0 &&
          static_cast<std::size_t>(here.file) < ctx_.files.size()) {
        // A circular move: its via point (here) and its end (the next entry), from the previous motion's target.
        const MotionStatement& end = motions[m + 1];
        ++m;
        CheckCircle(before, here, end);
        continue;
      }
      if (here.motion != Motion::kLinear || here.file < 0 || static_cast<std::size_t>(here.file) >= ctx_.files.size())
        continue;
      CheckLine(before, here);
    }
  }

 private:
  // The joints a target's motion ends at (compensated, or as written when kept).
  Eigen::VectorXd EndsAt(std::size_t i) const {
    const CompensatedTarget& c = out_.compensated[i];
    const bool moved = c.termination == Termination::kConvergence && c.configuration_kept;
    return moved ? c.joints : work_[i].controller;
  }

  // An inserted target's entry in the reply, sorted just before the statement it precedes.
  void RecordInserted(const MotionStatement& statement, const Inserted& point) {
    CompensatedTarget c;
    c.file = statement.file, c.line = statement.line, c.kind = TargetKind::kCartesian, c.inserted = true;
    c.joints = point.joints;
    c.predicted_error_mm =
        PredictPositionError(ctx_.calibration, point.joints, ctx_.options.payload, ctx_.options.prediction).bound_mm;
    c.termination = point.result.termination;
    c.rewritten = true;
    c.joint_change_rad = kNaN;
    out_.inserted_targets.push_back({{statement.file, statement.begin == 0 ? 0 : statement.begin - 1}, std::move(c)});
    ++summary_.inserted;
  }

  // The numbers of a target like `like` (its tool and frame from work_[target]) at a compensated point, as the
  // dialect writes an inline target; empty when it cannot.
  std::string InlineLiteral(std::size_t target, const Inserted& point) const {
    const ProgramTarget& like = program_.targets[target];
    const Frames& frames = work_[target].frames;
    const Transform in_frame = frames.T_base_frame.inverse() * point.written * frames.T_tool0_tool;
    return ctx_.syntax.inline_target(like, ctx_.files, ValuesFromPose(ctx_.syntax, in_frame, like.values));
  }

  void CheckCircle(const MotionStatement& before, const MotionStatement& here, const MotionStatement& end) {
    const std::size_t n = program_.targets.size();
    const std::size_t a = static_cast<std::size_t>(before.target), v = static_cast<std::size_t>(here.target),
                      b = static_cast<std::size_t>(end.target);
    if (a >= n || v >= n || b >= n || work_[a].controller.size() == 0 || work_[v].controller.size() == 0 ||
        work_[b].controller.size() == 0 || program_.targets[v].kind != TargetKind::kCartesian ||
        program_.targets[b].kind != TargetKind::kCartesian) {
      return;
    }
    const Eigen::VectorXd q_a = EndsAt(a), q_v = EndsAt(v), q_b = EndsAt(b);
    const std::optional<Arc> intended = ArcThrough(work_[a].written, work_[v].written, work_[b].written);
    const std::optional<Arc> written =
        ArcThrough(NominalToolPose(ctx_, q_a), NominalToolPose(ctx_, q_v), NominalToolPose(ctx_, q_b));
    if (!intended || !written) return;
    ++summary_.segments_checked;
    const double deviation = checker_.CircleDeviation(*intended, *written, q_a, q_b);
    if (!(deviation > *ctx_.options.max_path_deviation_mm)) return;
    const CircleMove move{.a = a, .v = v, .b = b, .q_a = q_a, .q_b = q_b, .intended = *intended, .written = *written};
    const std::vector<Inserted> points = CompensateArcPoints(move);
    if (points.size() != 3) {
      ++summary_.segments_over_deviation;
      return;
    }
    CheckArcHalves(move, points);
    const std::string via_first = InlineLiteral(v, points[0]), end_first = InlineLiteral(b, points[1]);
    const std::string via_second = InlineLiteral(v, points[2]);
    if (via_first.empty() || end_first.empty() || via_second.empty()) return;
    const std::string_view text(ctx_.files[static_cast<std::size_t>(here.file)].text);
    // The new statement: a copy of this one with both references replaced.
    std::vector<Edit>& file_edits = out_.edits[static_cast<std::size_t>(here.file)];
    file_edits.push_back(InsertedStatement(
        text, here,
        {{here.reference_begin, here.reference_end, via_first}, {end.reference_begin, end.reference_end, end_first}}));
    // This move's via point: the three-quarter point, in place of the reference (and of an inline via's own
    // numbers, which lie inside it).
    std::erase_if(file_edits, [&](const Edit& e) {
      return e.length > 0 && e.offset >= here.reference_begin && e.offset < here.reference_end;
    });
    file_edits.push_back({here.reference_begin, here.reference_end - here.reference_begin, via_second});
    for (const Inserted& point : points) RecordInserted(here, point);
  }

  // Split once, in two circles on the programmed arc: a new move through its quarter point to its midpoint, then
  // this move with its via point replaced by the three-quarter point. Each new point compensated; fewer than three
  // when one does not converge.
  std::vector<Inserted> CompensateArcPoints(const CircleMove& move) const {
    const Eigen::VectorXd& q_a = move.q_a;
    const Eigen::VectorXd& q_b = move.q_b;
    std::vector<Inserted> points;
    for (double fraction : {0.25, 0.5, 0.75}) {
      CompensationTarget target;
      target.pose = ArcAt(move.intended, fraction);
      target.frame = TargetFrame::kBase;
      target.start = checker_.ControllerAt(ArcAt(move.written, fraction), q_b, q_a + fraction * (q_b - q_a));
      if (target.start.size() == 0) target.start = q_a + fraction * (q_b - q_a);
      target.payload = ctx_.options.payload;
      Inserted point;
      point.result = Compensate(ctx_.calibration, ctx_.nominal, target, ctx_.options.solver);
      if (!point.result.converged) break;
      point.joints = point.result.joints;
      point.written = NominalToolPose(ctx_, point.joints);
      points.push_back(std::move(point));
    }
    return points;
  }

  // Each half checked as the whole was; beyond the limit still, it is said (one split only).
  void CheckArcHalves(const CircleMove& move, const std::vector<Inserted>& points) {
    const Arc& intended = move.intended;
    const std::optional<Arc> halves[2][2] = {
        {ArcThrough(work_[move.a].written, ArcAt(intended, 0.25), ArcAt(intended, 0.5)),
         ArcThrough(NominalToolPose(ctx_, move.q_a), points[0].written, points[1].written)},
        {ArcThrough(ArcAt(intended, 0.5), ArcAt(intended, 0.75), work_[move.b].written),
         ArcThrough(points[1].written, points[2].written, NominalToolPose(ctx_, move.q_b))}};
    const Eigen::VectorXd* ends[2][2] = {{&move.q_a, &points[1].joints}, {&points[1].joints, &move.q_b}};
    for (int h = 0; h < 2; ++h) {
      if (!halves[h][0] || !halves[h][1]) continue;
      const double d = checker_.CircleDeviation(*halves[h][0], *halves[h][1], *ends[h][0], *ends[h][1]);
      if (d > *ctx_.options.max_path_deviation_mm) ++summary_.segments_over_deviation;
    }
  }

  void CheckLine(const MotionStatement& before, const MotionStatement& here) {
    const std::size_t n = program_.targets.size();
    const std::size_t a = static_cast<std::size_t>(before.target), b = static_cast<std::size_t>(here.target);
    if (a >= n || b >= n || work_[a].controller.size() == 0 || work_[b].controller.size() == 0) return;
    const CompensatedTarget& ca = out_.compensated[a];
    const CompensatedTarget& cb = out_.compensated[b];
    Segment s;
    s.intended_a = work_[a].written, s.intended_b = work_[b].written;
    const bool a_moved = ca.termination == Termination::kConvergence && ca.configuration_kept;
    const bool b_moved = cb.termination == Termination::kConvergence && cb.configuration_kept;
    s.q_a = a_moved ? ca.joints : work_[a].controller;
    s.q_b = b_moved ? cb.joints : work_[b].controller;
    s.written_a = NominalToolPose(ctx_, s.q_a);
    s.written_b = NominalToolPose(ctx_, s.q_b);
    ++summary_.segments_checked;
    std::vector<Inserted> inserted;
    bool over = false;
    checker_.Split(s, 0, &inserted, &over);
    if (over) ++summary_.segments_over_deviation;
    if (inserted.empty() || program_.targets[b].kind != TargetKind::kCartesian) return;
    const std::string_view text(ctx_.files[static_cast<std::size_t>(here.file)].text);
    std::vector<Edit> block;
    for (const Inserted& piece : inserted) {
      const std::string literal = InlineLiteral(b, piece);
      if (literal.empty()) continue;
      block.push_back(InsertedStatement(text, here, {{here.reference_begin, here.reference_end, literal}}));
      RecordInserted(here, piece);
    }
    // In path order: edits at one offset keep their order (the writer's sort is stable).
    for (Edit& e : block) out_.edits[static_cast<std::size_t>(here.file)].push_back(std::move(e));
  }

  const Context& ctx_;
  const ParsedProgram& program_;
  const std::vector<Work>& work_;
  ProgramOutcome& out_;
  ProgramCompensationSummary& summary_;
  const PathChecker checker_;
};

// The reply's targets: those read and those inserted, in the order of where they sort (file, offset).
void ListTargets(ProgramOutcome* out) {
  std::vector<std::pair<std::pair<int, std::size_t>, CompensatedTarget>> listed;
  for (std::size_t i = 0; i < out->compensated.size(); ++i) {
    listed.push_back({out->sort_keys[i], std::move(out->compensated[i])});
  }
  for (auto& entry : out->inserted_targets) listed.push_back(std::move(entry));
  std::stable_sort(listed.begin(), listed.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  for (auto& entry : listed) out->result.targets.push_back(std::move(entry.second));
}

// on_failure refuse with targets that failed: FAILURE naming the first five, nothing written.
void Refuse(const std::vector<ProgramFile>& files, ProgramCompensationResult* result) {
  ProgramCompensationSummary& summary = result->summary;
  summary.termination = Termination::kFailure;
  std::string which;
  int shown = 0;
  for (const CompensatedTarget& c : result->targets) {
    if (c.inserted || (c.termination == Termination::kConvergence && c.configuration_kept)) continue;
    if (shown++ < 5) which += (which.empty() ? "" : "; ") + TargetLabel(files[static_cast<std::size_t>(c.file)], c);
  }
  summary.message = std::to_string(summary.failed) + " target(s) cannot be compensated as written (" + which +
                    (summary.failed > 5 ? "; ..." : "") + "); on_failure refuse: nothing written";
}

// A file with its edits applied in order of their offsets (an insertion before a replacement at the same offset),
// in one pass, so that a large program is copied once.
std::string ApplyEdits(const std::string& in, std::vector<Edit>* list) {
  std::stable_sort(list->begin(), list->end(), [](const Edit& a, const Edit& b) {
    return a.offset != b.offset ? a.offset < b.offset : a.length < b.length;
  });
  std::string out;
  out.reserve(in.size() + in.size() / 8);
  std::size_t at = 0;
  for (const Edit& e : *list) {
    out.append(in, at, e.offset - at);
    out += e.text;
    at = e.offset + e.length;
  }
  out.append(in, at, std::string::npos);
  return out;
}

// DEGRADED when anything was left as it was: a target, a segment beyond the deviation, or a program in which the
// reader found no target at all (a client must not take that for a program compensated).
void Conclude(const DialectSyntax& syntax, ProgramCompensationSummary* summary) {
  std::vector<std::string> said;
  if (summary->targets == 0) said.push_back("the files hold no target " + std::string(syntax.name) + " reads");
  if (summary->failed > 0) said.push_back(std::to_string(summary->failed) + " target(s) kept as written");
  if (summary->segments_over_deviation > 0) {
    said.push_back(std::to_string(summary->segments_over_deviation) + " segment(s) still beyond max_path_deviation_mm");
  }
  summary->termination = said.empty() ? Termination::kConvergence : Termination::kDegraded;
  summary->message.clear();
  for (const std::string& s : said) summary->message += (summary->message.empty() ? "" : "; ") + s;
}

}  // namespace

const char* ToString(OnFailure on_failure) { return on_failure == OnFailure::kKeep ? "keep" : "refuse"; }

bool ParseOnFailure(const std::string& text, OnFailure* on_failure) {
  if (text == "keep")
    *on_failure = OnFailure::kKeep;
  else if (text == "refuse")
    *on_failure = OnFailure::kRefuse;
  else
    return false;
  return true;
}

bool ProgramCompensationOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  if (max_path_deviation_mm && !(*max_path_deviation_mm > 0.0 && std::isfinite(*max_path_deviation_mm))) {
    return fail("max_path_deviation_mm must be positive and finite");
  }
  if (max_split_depth < 0 || max_split_depth > 10) return fail("max_split_depth must be in [0, 10]");
  std::string why;
  if (!solver.IsValid(&why)) return fail("solver: " + why);
  if (!payload.IsValid("payload", &why)) return fail(why);
  if (!prediction.IsValid(&why)) return fail("prediction: " + why);
  if (threads < 0) return fail("threads must be >= 0");
  return true;
}

ProgramCompensationResult CompensateProgram(const Calibration& calibration, const RobotModel& nominal, Dialect dialect,
                                            const std::vector<ProgramFile>& files,
                                            const ProgramCompensationOptions& options) {
  return CompensateProgram(calibration, nominal, SyntaxOf(dialect), files, options);
}

ProgramCompensationResult CompensateProgram(const Calibration& calibration, const RobotModel& nominal,
                                            const DialectSyntax& syntax, const std::vector<ProgramFile>& files,
                                            const ProgramCompensationOptions& options) {
  CheckProgramRequest(calibration, nominal, syntax, options);
  Context ctx{calibration,
              nominal,
              syntax,
              files,
              options,
              ArmSolver::For(nominal),
              NominalCalibration(nominal),
              nominal.T_world_base().inverse(),
              calibration.T_world_base.inverse()};

  std::vector<SourceText> sources;
  sources.reserve(files.size());
  for (std::size_t f = 0; f < files.size(); ++f) sources.emplace_back(files[f], static_cast<int>(f));
  const ParsedProgram program = syntax.read(files);

  std::vector<Work> work = PrepareTargets(ctx, program, sources);
  PlaceControllerJoints(ctx, program, &work);
  SolveTargets(ctx, program, &work);
  ProgramOutcome out;
  out.result.dialect = syntax.dialect;
  JudgeTargets(ctx, program, &work, &out);
  if (options.max_path_deviation_mm) PathPass(ctx, program, work, &out).Run();
  ListTargets(&out);
  ProgramCompensationResult& result = out.result;

  if (options.on_failure == OnFailure::kRefuse && result.summary.failed > 0) {
    Refuse(files, &result);
    return std::move(out.result);
  }
  result.files.reserve(files.size());
  for (std::size_t f = 0; f < files.size(); ++f) {
    result.files.push_back({files[f].name, ApplyEdits(files[f].text, &out.edits[f])});
  }
  Conclude(syntax, &result.summary);
  return std::move(out.result);
}

}  // namespace robocal::programs
