// Fuzz target: the URScript reader (programs/src/urscript.cc) on any bytes, as one file or two (the first byte's
// low bit splits the rest at its first NUL byte). A program is read or refused with a ProgramError naming one of
// its files and a place in it; what is read has spans inside their files that read back as the values, targets
// in the order of their text, motions on whole lines that point at targets, and an inserted pose that reads back.
#include <cmath>
#include <cstring>

#include "fuzz_util.h"
#include "robocal/programs/program.h"
#include "robocal/programs/text_scan.h"

namespace {

using robocal::fuzz::Check;
using namespace robocal::programs;

void CheckProgram(const std::vector<ProgramFile>& files, const ParsedProgram& program) {
  const DialectSyntax& syntax = SyntaxOf(Dialect::kUrscript);
  for (std::size_t t = 0; t < program.targets.size(); ++t) {
    const ProgramTarget& target = program.targets[t];
    Check(target.file >= 0 && target.file < static_cast<int>(files.size()), "a target's file is a file");
    Check(target.values.size() == 6 && target.spans.size() == 6, "a target has 6 numbers");
    const std::string& text = files[target.file].text;
    for (std::size_t k = 0; k < 6; ++k) {
      const NumberSpan& span = target.spans[k];
      Check(span.file == target.file && span.length > 0 && span.offset + span.length <= text.size(),
            "a span lies inside its target's file");
      const std::optional<ScannedNumber> number =
          ScanNumber(std::string_view(text).substr(span.offset, span.length), 0);
      Check(number && number->length == span.length && number->value == target.values[k],
            "a span is exactly its number");
      Check(std::isfinite(target.values[k]), "a value is finite");
      Check(k == 0 || span.offset > target.spans[k - 1].offset, "a target's numbers in order");
    }
    const SourceText source(files[target.file], target.file);
    Check(target.line == source.LineOf(target.spans[0].offset) &&
              target.column == source.ColumnOf(target.spans[0].offset),
          "a target's line and column are its first number's");
    Check(!target.configuration_applies && target.turns.empty() && target.base.empty(),
          "URScript has no flags, turns or bases");
    if (t > 0) {
      const ProgramTarget& before = program.targets[t - 1];
      Check(
          before.file < target.file || (before.file == target.file && before.spans[0].offset < target.spans[0].offset),
          "targets in the order of their text");
    }
    // An inserted pose with the target's values reads back as one target with those values: to half a unit in
    // the sixth decimal it is written with, plus the reading's own rounding (0.4713255 is written 0.471326 and
    // reads back 5.0000000001e-7 away). Only for values a robot could reach (within 1000 km): an inserted number
    // is written in fixed notation.
    bool reachable = true;
    for (double v : target.values) reachable = reachable && std::abs(v) < 1e6;
    if (target.kind == TargetKind::kCartesian && reachable) {
      const std::string inserted = syntax.inline_target(target, files, target.values);
      const ParsedProgram again = syntax.read({ProgramFile{"inserted.script", "movel(" + inserted + ")\n"}});
      Check(again.targets.size() == 1 && again.motions.size() == 1, "an inserted pose is one target");
      for (std::size_t k = 0; k < 6; ++k) {
        Check(
            std::abs(again.targets[0].values[k] - target.values[k]) <= 5e-7 + 1e-12 * std::max(1.0, std::abs(target.values[k])),
            "an inserted pose reads back");
      }
    } else if (target.kind == TargetKind::kJoint) {
      Check(syntax.inline_target(target, files, target.values).empty(), "no inserted joint target");
    }
  }
  std::vector<bool> moved(program.targets.size(), false);
  for (const MotionStatement& m : program.motions) {
    Check(m.target >= 0 && m.target < static_cast<int>(program.targets.size()), "a motion's target is a target");
    Check(m.file >= 0 && m.file < static_cast<int>(files.size()), "a motion's file is a file");
    const std::string& text = files[m.file].text;
    Check(m.begin <= m.reference_begin && m.reference_begin < m.reference_end && m.reference_end <= m.end &&
              m.end <= text.size(),
          "a motion's reference lies inside its statement");
    Check(m.begin == 0 || text[m.begin - 1] == '\n' || text[m.begin - 1] == '\r', "a statement starts a line");
    Check(m.end == text.size() || text[m.end] == '\n' || text[m.end] == '\r', "a statement ends a line");
    const ProgramTarget& target = program.targets[m.target];
    if (!moved[m.target]) Check(target.motion == m.motion, "a target's motion is its first motion's");
    moved[m.target] = true;
    if (target.name) {
      Check(text.compare(m.reference_begin, m.reference_end - m.reference_begin, *target.name) == 0,
            "a declared target is referred to by its name");
    }
  }
  for (std::size_t t = 0; t < program.targets.size(); ++t) {
    Check(moved[t] || program.targets[t].motion == Motion::kNone, "a target no motion moves to has none");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string rest = robocal::fuzz::Text(data + 1, size - 1);
  std::vector<ProgramFile> files;
  const std::size_t nul = rest.find('\0');
  if ((data[0] & 1) && nul != std::string::npos) {
    files = {{"poses.script", rest.substr(0, nul)}, {"main.script", rest.substr(nul + 1)}};
  } else {
    files = {{"program.script", rest}};
  }
  try {
    CheckProgram(files, SyntaxOf(Dialect::kUrscript).read(files));
  } catch (const ProgramError& e) {
    bool named = false;
    for (const ProgramFile& file : files) {
      if (file.name != e.file()) continue;
      named = true;
      const SourceText source(file, 0);
      Check(e.line() >= 1 && e.line() <= source.line_count() && e.column() >= 1, "an error names a place");
      Check(static_cast<std::size_t>(e.column()) <= source.Line(e.line()).size() + 1,
            "an error's column is on its line");
    }
    Check(named, "an error names one of the program's files");
  }
  return 0;
}
