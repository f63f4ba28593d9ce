// Fuzz target: the FANUC .ls reader (the "fanuc-ls" row's read). The input is one program, or two split at the
// first NUL byte (a request may send several .ls files, each with its own P numbers). The reader must end in a
// result or a ProgramError naming one of the files and a place in it; a result's spans lie in their file and read
// back as exactly the values, and its motions point at targets and at bytes of their file.
#include <cstring>
#include <typeinfo>

#include "fuzz_util.h"
#include "robocal/programs/program.h"
#include "robocal/programs/text_scan.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace robocal::programs;
  using robocal::fuzz::Check;
  const std::string input = robocal::fuzz::Text(data, size);
  std::vector<ProgramFile> files;
  const std::size_t split = input.find('\0');
  if (split == std::string::npos) {
    files.push_back({"fuzz.ls", input});
  } else {
    files.push_back({"first.ls", input.substr(0, split)});
    files.push_back({"second.ls", input.substr(split + 1)});
  }

  ParsedProgram program;
  try {
    program = SyntaxOf(Dialect::kFanucLs).read(files);
  } catch (const ProgramError& e) {
    Check(typeid(e) == typeid(ProgramError), "the reader refuses with ProgramError itself");
    bool named = false;
    for (const ProgramFile& file : files) {
      if (e.file() == file.name) {
        named = true;
        // Line and column of a byte of the file or of its end.
        std::size_t lines = 1;
        for (std::size_t k = 0; k < file.text.size(); ++k) {
          const char c = file.text[k];
          lines += c == '\n' || (c == '\r' && (k + 1 == file.text.size() || file.text[k + 1] != '\n'));
        }
        Check(e.line() >= 1 && static_cast<std::size_t>(e.line()) <= lines, "an error's line is in its file");
        Check(e.column() >= 1 && static_cast<std::size_t>(e.column()) <= file.text.size() + 1,
              "an error's column is in its line");
      }
    }
    Check(named, "an error names one of the files");
    return 0;
  }

  for (std::size_t t = 0; t < program.targets.size(); ++t) {
    const ProgramTarget& target = program.targets[t];
    Check(target.file >= 0 && static_cast<std::size_t>(target.file) < files.size(), "a target's file exists");
    Check(!target.values.empty() && target.values.size() == target.spans.size(), "one span per value");
    Check(target.kind == TargetKind::kJoint || target.values.size() == 6, "a Cartesian target has 6 values");
    Check(target.name.has_value(), "every FANUC target has its P[n] / PR[n] name");
    const std::string& text = files[target.file].text;
    for (std::size_t k = 0; k < target.spans.size(); ++k) {
      const NumberSpan& span = target.spans[k];
      Check(span.file == target.file && span.length > 0 && span.offset + span.length <= text.size(),
            "a span lies in its target's file");
      const std::string written = text.substr(span.offset, span.length);
      const std::optional<ScannedNumber> number = ScanNumber(written, 0);
      Check(number && number->length == written.size() && number->value == target.values[k],
            "a span reads back as exactly its value");
    }
    for (const JointRange& range : target.turns) {
      Check(range.joint >= 0 && range.min < range.max, "a turn is a range of a joint");
    }
    if (t > 0) {
      const ProgramTarget& before = program.targets[t - 1];
      Check(
          before.file < target.file || (before.file == target.file && before.spans[0].offset < target.spans[0].offset),
          "targets in the order of the files and their text");
    }
  }
  for (const MotionStatement& motion : program.motions) {
    Check(motion.target >= 0 && static_cast<std::size_t>(motion.target) < program.targets.size(),
          "a motion points at a target");
    Check(motion.file == program.targets[motion.target].file, "a motion moves to a target of its own file");
    const std::string& text = files[motion.file].text;
    Check(motion.begin <= motion.reference_begin && motion.reference_begin < motion.reference_end &&
              motion.reference_end <= motion.end && motion.end <= text.size(),
          "a motion's reference lies in its statement, in its file");
    Check(motion.motion != Motion::kNone, "a motion has a kind");
  }
  return 0;
}
