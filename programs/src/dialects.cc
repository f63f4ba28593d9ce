// The table of the dialects: one row per controller language, each defined in its own file (krl.cc, rapid.cc,
// urscript.cc, fanuc_ls.cc, val3.cc). Adding a controller is its file, its enum value and its line here.
#include <algorithm>

#include "robocal/programs/program.h"
#include "robocal/programs/text_scan.h"

namespace robocal::programs {

// Each dialect's row, from its own file.
const DialectSyntax& KrlSyntax();
const DialectSyntax& RapidSyntax();
const DialectSyntax& UrscriptSyntax();
const DialectSyntax& FanucLsSyntax();
const DialectSyntax& Val3Syntax();

const std::vector<DialectSyntax>& Dialects() {
  static const std::vector<DialectSyntax> table = {KrlSyntax(), RapidSyntax(), UrscriptSyntax(), FanucLsSyntax(),
                                                   Val3Syntax()};
  return table;
}

const DialectSyntax& SyntaxOf(Dialect dialect) { return Dialects()[static_cast<std::size_t>(dialect)]; }

const char* ToString(Dialect dialect) { return SyntaxOf(dialect).name; }

bool ParseDialect(const std::string& name, Dialect* dialect) {
  for (const DialectSyntax& row : Dialects()) {
    if (name == row.name) {
      *dialect = row.dialect;
      return true;
    }
  }
  return false;
}

std::optional<Dialect> DialectOfFiles(const std::vector<ProgramFile>& files, std::string* error) {
  std::optional<Dialect> found;
  std::string first;
  for (const ProgramFile& file : files) {
    const std::size_t dot = file.name.rfind('.');
    const std::string extension = dot == std::string::npos ? "" : LowerCase(file.name.substr(dot));
    std::optional<Dialect> dialect;
    for (const DialectSyntax& row : Dialects()) {
      if (std::find(row.extensions.begin(), row.extensions.end(), extension) != row.extensions.end()) {
        dialect = row.dialect;
      }
    }
    if (!dialect) {
      if (error) *error = "the extension of " + file.name + " names no dialect";
      return std::nullopt;
    }
    if (found && *found != *dialect) {
      if (error) *error = first + " is " + ToString(*found) + " and " + file.name + " is " + ToString(*dialect);
      return std::nullopt;
    }
    if (!found) first = file.name;
    found = dialect;
  }
  if (!found && error) *error = "no files";
  return found;
}

const char* ToString(TargetKind kind) { return kind == TargetKind::kJoint ? "joint" : "cartesian"; }

const char* ToString(Motion motion) {
  switch (motion) {
    case Motion::kNone:
      return "none";
    case Motion::kJoint:
      return "joint";
    case Motion::kLinear:
      return "linear";
    case Motion::kCircular:
      return "circular";
  }
  return "?";
}

const char* ToString(RotationConvention convention) {
  switch (convention) {
    case RotationConvention::kZyxIntrinsicDeg:
      return "Z, Y', X'' (deg)";
    case RotationConvention::kXyzFixedDeg:
      return "fixed X, Y, Z (deg)";
    case RotationConvention::kQuaternionWxyz:
      return "quaternion w, x, y, z";
    case RotationConvention::kRotationVectorRad:
      return "rotation vector (rad)";
    case RotationConvention::kXyzIntrinsicDeg:
      return "X, Y', Z'' (deg)";
  }
  return "?";
}

}  // namespace robocal::programs
