// Robot programs as text to keep: what every dialect's reader finds in a program (its targets, with the byte spans
// of their numbers, their configuration flags and frames, and the motions that move to them), and the table of the
// dialects. Compensation itself is in the core, which knows nothing of dialects (compensate_program.h joins them).
#pragma once

#include <cstddef>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "robocal/core/arm_kinematics.h"

namespace robocal::programs {

/// The controller languages robocal reads and writes.
enum class Dialect {
  kKrl,       // KUKA KRL: .src + .dat
  kRapid,     // ABB RAPID: .mod / .prg
  kUrscript,  // Universal Robots URScript: .script
  kFanucLs,   // FANUC TP source: .ls
  kVal3,      // Staubli VAL3: a program's data file .dtx
};

/// One file of a program, as sent: its name (the extension says the dialect) and its text, byte for byte.
struct ProgramFile {
  std::string name;
  std::string text;
};

/// A program that cannot be read: the file, the line and column (1-based; column in bytes) and why. Readers throw
/// it for text they do not understand where a target must be (a malformed number, a missing component), never for
/// the statements they do not need to read.
class ProgramError : public std::runtime_error {
 public:
  ProgramError(std::string file, int line, int column, const std::string& reason);
  const std::string& file() const { return file_; }
  int line() const { return line_; }
  int column() const { return column_; }
  /// The reason alone (what() is "FILE:LINE:COLUMN: reason").
  const std::string& reason() const { return reason_; }

 private:
  std::string file_;
  int line_ = 0;
  int column_ = 0;
  std::string reason_;
};

/// Where a number is written: the file (index into the program's files) and its bytes [offset, offset + length).
/// The span covers the number alone (sign, digits, point, exponent), no spaces, commas or braces.
struct NumberSpan {
  int file = 0;
  std::size_t offset = 0;
  std::size_t length = 0;
};

enum class TargetKind { kJoint, kCartesian };

/// How the program moves to a target.
enum class Motion {
  /// Declared, and no motion of the program that the reader found moves to it.
  kNone,
  /// Joint interpolation: KRL PTP, RAPID MoveJ / MoveAbsJ, URScript movej, FANUC J, VAL3 movej.
  kJoint,
  /// Straight line: KRL LIN, RAPID MoveL, URScript movel / movep, FANUC L, VAL3 movel.
  kLinear,
  /// Circle: KRL CIRC, RAPID MoveC, URScript movec, FANUC C (both its points: the via point and the end).
  kCircular,
};

/// A range a target's turn information demands of one joint, in core units (rad; mm for a prismatic joint):
/// min <= q[joint] < max. KRL's T bits give a sign (one bound infinite), RAPID's cf1 / cf4 / cf6 a quadrant,
/// FANUC's turn numbers a turn of 360 deg.
struct JointRange {
  int joint = 0;  // 0-based
  double min = 0.0;
  double max = 0.0;
};

/// One target: a joint or Cartesian value that the compensation rewrites.
struct ProgramTarget {
  /// Where the target's first rewritten number is: file index, line and column (1-based, column in bytes).
  int file = 0;
  int line = 0;
  int column = 0;
  /// The variable or point as the program names it (KRL "XP1", RAPID "p10", URScript "home", FANUC "P[3]",
  /// VAL3 "pPick[2]"); nullopt for an inline target.
  std::optional<std::string> name;
  TargetKind kind = TargetKind::kJoint;
  /// The first motion, in program order, that moves to the target (kNone: none found).
  Motion motion = Motion::kNone;
  /// The numbers the compensation rewrites, as written (the dialect's units), and their spans, in this order:
  /// - joint: the robot's joints 1..n (deg; URScript rad). External axes are not listed: they stay as written.
  /// - Cartesian: x, y, z (mm; URScript m), then the rotation in the dialect's convention (DialectSyntax).
  std::vector<double> values;
  std::vector<NumberSpan> spans;
  /// The configuration the target names, as robocal's flags (docs/programs.md gives each dialect's mapping);
  /// 0 for a flag the target leaves free.
  ArmConfiguration configuration;
  /// Whether the controller uses the target's configuration for the motion that moves to it. False for a
  /// dialect without flags (URScript), for KRL LIN and CIRC (the controller keeps the configuration it has)
  /// and for joint targets. A Cartesian target whose configuration does not apply is solved on the branch of
  /// the previous target's joints.
  bool configuration_applies = false;
  /// The joint ranges the target's turn information demands (empty: none).
  std::vector<JointRange> turns;
  /// The tool and base the target is programmed in, as the program names them ("1", "tool1", "UT 2" is "2");
  /// empty: the robot's own tool, and the identity base (BASE_NO 0, wobj0, UF 0, VAL3 world).
  std::string tool;
  std::string base;
};

/// One motion statement of the program, in program order.
struct MotionStatement {
  /// Index of the target it moves to (ParsedProgram::targets). A CIRC / MoveC statement is two entries, the via
  /// point first, both with the same statement span.
  int target = 0;
  Motion motion = Motion::kJoint;
  int file = 0;
  int line = 0;
  /// The statement's bytes in its file: from the first byte of its first line (indentation included) to the
  /// end of its last line, the line end excluded. An intermediate target is inserted before it as a copy of
  /// these bytes with `reference` replaced.
  std::size_t begin = 0;
  std::size_t end = 0;
  /// The bytes of the statement that name the target (a variable's name, or an inline target's literal).
  std::size_t reference_begin = 0;
  std::size_t reference_end = 0;
  /// The statement's own bytes where its lines may hold more (RAPID "MoveL p1, ...; MoveL p2, ...;", "IF b THEN
  /// MoveL ...; ENDIF"): from its instruction's first byte to the end of its terminator. An inserted target is then
  /// a copy of these bytes alone, on a line of its own before the statement. Both 0: the lines are the statement.
  std::size_t own_begin = 0;
  std::size_t own_end = 0;
};

/// What a dialect's reader finds in a program.
struct ParsedProgram {
  /// Every target, in the order of the files and then of their text.
  std::vector<ProgramTarget> targets;
  /// The motions, in program order (the order the controller runs them in, as far as the text tells).
  std::vector<MotionStatement> motions;
};

/// The rotation conventions of the dialects' Cartesian values (the last 3 or 4 values of a Cartesian target).
enum class RotationConvention {
  /// KUKA A, B, C: R = Rz(A) Ry(B) Rx(C) (Z, Y', X'' intrinsic), degrees.
  kZyxIntrinsicDeg,
  /// FANUC W, P, R: R = Rz(R) Ry(P) Rx(W) (fixed X, Y, Z), degrees.
  kXyzFixedDeg,
  /// ABB: a unit quaternion q1..q4 = w, x, y, z.
  kQuaternionWxyz,
  /// Universal Robots: a rotation vector (axis times angle), radians.
  kRotationVectorRad,
  /// Staubli Rx, Ry, Rz: R = Rx(Rx) Ry(Ry) Rz(Rz) (X, Y', Z'' intrinsic), degrees.
  kXyzIntrinsicDeg,
};

/// One dialect: its name on the wire, the file extensions that name it, its units and conventions, its reader
/// and how it writes an inserted target. Adding a controller is one file with these and one row in the table
/// (dialects.cc).
struct DialectSyntax {
  Dialect dialect = Dialect::kKrl;
  /// "krl", "rapid", "urscript", "fanuc-ls", "val3".
  const char* name = "";
  /// Lower-case extensions with the dot (".src", ".dat").
  std::vector<std::string> extensions;
  RotationConvention rotation = RotationConvention::kZyxIntrinsicDeg;
  /// Millimetres per unit of the Cartesian positions (1, or 1000 for URScript's metres).
  double mm_per_length_unit = 1.0;
  /// Revolute joint values in radians (URScript) instead of degrees.
  bool joints_in_rad = false;
  /// Every target and motion of the files (all files of one program, in the request's order). Throws
  /// ProgramError for a target it cannot read.
  ParsedProgram (*read)(const std::vector<ProgramFile>& files) = nullptr;
  /// The text of an inline Cartesian target with `values` (the dialect's units, as ProgramTarget::values), for
  /// an intermediate target inserted before a motion to `like` (whose flags, turns and any other components,
  /// e.g. RAPID's external axes, it copies from the files). Numbers as FormatInserted (text_scan.h) writes
  /// them. nullptr: the dialect cannot insert targets.
  std::string (*inline_target)(const ProgramTarget& like, const std::vector<ProgramFile>& files,
                               const std::vector<double>& values) = nullptr;
};

const char* ToString(Dialect dialect);
/// The dialect named `name` ("krl", ...); false if none is.
bool ParseDialect(const std::string& name, Dialect* dialect);
/// The table row of a dialect.
const DialectSyntax& SyntaxOf(Dialect dialect);
/// Every dialect's row, in the enum's order.
const std::vector<DialectSyntax>& Dialects();
/// The dialect the files' extensions name (case-insensitive), or nullopt when one names none or two name
/// different dialects; `error` (if given) then says which file.
std::optional<Dialect> DialectOfFiles(const std::vector<ProgramFile>& files, std::string* error = nullptr);

const char* ToString(TargetKind kind);
const char* ToString(Motion motion);
const char* ToString(RotationConvention convention);

}  // namespace robocal::programs
