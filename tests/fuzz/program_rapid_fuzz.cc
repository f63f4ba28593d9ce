// Fuzz target: the ABB RAPID reader (programs/src/rapid.cc) as POST :compensate-program runs it. The input is one
// module, or two when it holds a NUL byte (a program of several modules: a motion in one may name a target the
// other declares). The reader must return a consistent reading (spans that read back as their values, targets in
// file and offset order, motions naming targets inside their statements) or throw ProgramError naming a file, line
// and column of the input; and every Cartesian target's inline text must read back as that target.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "fuzz_util.h"
#include "robocal/programs/program.h"
#include "robocal/programs/text_scan.h"

namespace {

using robocal::fuzz::Check;
namespace programs = robocal::programs;

void CheckReading(const std::vector<programs::ProgramFile>& files, const programs::ParsedProgram& program) {
  std::vector<programs::SourceText> sources;
  for (std::size_t i = 0; i < files.size(); ++i) sources.emplace_back(files[i], static_cast<int>(i));
  int previous_file = -1;
  std::size_t previous_offset = 0;
  for (const programs::ProgramTarget& target : program.targets) {
    const std::size_t count = target.kind == programs::TargetKind::kJoint ? 6 : 7;
    Check(target.values.size() == count && target.spans.size() == count, "a target has its 6 or 7 numbers");
    for (std::size_t i = 0; i < count; ++i) {
      const programs::NumberSpan& span = target.spans[i];
      Check(span.file >= 0 && span.file < static_cast<int>(files.size()), "a span names a file");
      const std::string& text = files[span.file].text;
      Check(span.offset <= text.size() && span.length <= text.size() - span.offset, "a span lies in its file");
      const auto number = programs::ScanNumber(text, span.offset);
      Check(number && number->length == span.length && number->value == target.values[i],
            "a span reads back as its value");
    }
    const programs::NumberSpan& first = target.spans[0];
    Check(first.file > previous_file || (first.file == previous_file && first.offset > previous_offset),
          "targets in file and offset order");
    previous_file = first.file;
    previous_offset = first.offset;
    Check(target.line == sources[first.file].LineOf(first.offset) &&
              target.column == sources[first.file].ColumnOf(first.offset),
          "a target's line and column are its first number's");
    for (int flag : {target.configuration.shoulder, target.configuration.elbow, target.configuration.wrist}) {
      Check(flag >= -1 && flag <= 1, "a flag is -1, 0 or 1");
    }
    for (const programs::JointRange& range : target.turns) {
      Check(range.joint >= 0 && range.joint < 6 && range.min < range.max, "a turn is a joint's quadrant");
    }
  }
  for (const programs::MotionStatement& m : program.motions) {
    Check(m.target >= 0 && m.target < static_cast<int>(program.targets.size()), "a motion names a target");
    Check(m.file >= 0 && m.file < static_cast<int>(files.size()), "a motion names a file");
    const std::string& text = files[m.file].text;
    Check(m.begin <= m.reference_begin && m.reference_begin < m.reference_end && m.reference_end <= m.end &&
              m.end <= text.size(),
          "a motion's reference lies in its statement");
    Check(m.end == text.size() || text[m.end] == '\n' || text[m.end] == '\r', "a statement ends at a line end");
    Check(program.targets[m.target].motion != programs::Motion::kNone, "a target moved to has a motion");
  }
}

// The inline text of a Cartesian target, in a MoveL of a module of its own, reads back as the target.
void CheckInline(const programs::DialectSyntax& rapid, const std::vector<programs::ProgramFile>& files,
                 const programs::ProgramTarget& target) {
  const std::string literal = rapid.inline_target(target, files, target.values);
  Check(!literal.empty(), "a robtarget has an inline text");
  const std::vector<programs::ProgramFile> module = {{"I.mod", "MoveL " + literal + ", v100, z1, tool0;\n"}};
  const programs::ParsedProgram again = rapid.read(module);
  Check(again.targets.size() == 1 && again.motions.size() == 1, "an inline text is one target of its motion");
  const programs::ProgramTarget& copy = again.targets[0];
  for (std::size_t i = 0; i < 7; ++i) {
    const double tolerance = (i < 3 ? 1e-3 : 1e-6) * std::max(1.0, std::abs(target.values[i]));
    Check(std::abs(copy.values[i] - target.values[i]) <= tolerance, "an inline text keeps the values");
  }
  Check(copy.configuration == target.configuration, "an inline text keeps the flags");
  Check(copy.turns.size() == target.turns.size(), "an inline text keeps the turns");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text = robocal::fuzz::Text(data, size);
  std::vector<programs::ProgramFile> files;
  const std::size_t nul = text.find('\0');
  if (nul == std::string::npos) {
    files = {{"MAIN.mod", text}};
  } else {
    files = {{"MAIN.mod", text.substr(0, nul)}, {"DATA.prg", text.substr(nul + 1)}};
  }
  const programs::DialectSyntax& rapid = programs::SyntaxOf(programs::Dialect::kRapid);
  programs::ParsedProgram program;
  try {
    program = rapid.read(files);
  } catch (const programs::ProgramError& e) {
    const auto named = std::find_if(files.begin(), files.end(), [&](const auto& f) { return f.name == e.file(); });
    Check(named != files.end(), "an error names a file of the program");
    const programs::SourceText source(*named, 0);
    Check(e.line() >= 1 && e.line() <= source.line_count() && e.column() >= 1, "an error names a line and column");
    return 0;
  }
  CheckReading(files, program);
  // The engine inserts targets only between compensated ones, inside the robot's reach: values of a metre-sized
  // cell, not the 1e300 a fuzzer writes.
  int checked = 0;
  for (const programs::ProgramTarget& target : program.targets) {
    const bool in_reach =
        std::all_of(target.values.begin(), target.values.end(), [](double v) { return std::abs(v) < 1e9; });
    if (target.kind == programs::TargetKind::kCartesian && in_reach && checked++ < 8) {
      CheckInline(rapid, files, target);
    }
  }
  return 0;
}
