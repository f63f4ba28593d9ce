// Fuzz target: the Staubli VAL3 reader (the .dtx data files of POST /v1/campaigns/{c}:compensate-program). The
// input is one file, or two split at the first NUL byte (a program may bring several .dtx files). The reader
// must return or throw ProgramError naming one of the files at a line and column inside it; whatever it returns
// must be what the compensation can rewrite: spans inside their file that hold exactly the listed numbers.
#include <cstring>

#include "fuzz_util.h"
#include "robocal/programs/program.h"
#include "robocal/programs/text_scan.h"

namespace robocal::programs {
const DialectSyntax& Val3Syntax();
}

namespace {

using robocal::fuzz::Check;
namespace programs = robocal::programs;

void CheckTargets(const std::vector<programs::ProgramFile>& files, const programs::ParsedProgram& program) {
  Check(program.motions.empty(), "a .dtx lists no motions");
  int last_file = 0;
  for (const programs::ProgramTarget& target : program.targets) {
    Check(target.file >= 0 && target.file < static_cast<int>(files.size()), "a target's file is one of the files");
    Check(target.file >= last_file, "targets are in the order of the files");
    last_file = target.file;
    Check(target.values.size() == 6 && target.spans.size() == 6, "a target has six numbers and six spans");
    Check(target.name.has_value() && !target.name->empty(), "a .dtx target has a name");
    Check(target.motion == programs::Motion::kNone, "a .dtx target has no motion");
    Check(target.tool.empty() && target.turns.empty(), "a .dtx target names no tool and no turns");
    Check(target.configuration_applies == !target.configuration.empty(), "flags apply exactly when given");
    const std::string_view text = files[target.file].text;
    for (std::size_t k = 0; k < 6; ++k) {
      const programs::NumberSpan& span = target.spans[k];
      Check(span.file == target.file, "a span is in its target's file");
      Check(span.length > 0 && span.offset <= text.size() && span.length <= text.size() - span.offset,
            "a span lies inside its file");
      const auto number = programs::ScanNumber(text.substr(span.offset, span.length), 0);
      Check(number && number->length == span.length && number->value == target.values[k],
            "a span holds exactly its number");
    }
    const programs::SourceText source(files[target.file], target.file);
    Check(target.line == source.LineOf(target.spans[0].offset) &&
              target.column == source.ColumnOf(target.spans[0].offset),
          "a target's line and column are its first number's");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string input = robocal::fuzz::Text(data, size);
  std::vector<programs::ProgramFile> files;
  const std::size_t split = input.find('\0');
  if (split == std::string::npos) {
    files = {{"cell.dtx", input}};
  } else {
    files = {{"cell.dtx", input.substr(0, split)}, {"library.dtx", input.substr(split + 1)}};
  }
  try {
    CheckTargets(files, programs::Val3Syntax().read(files));
  } catch (const programs::ProgramError& e) {
    const programs::ProgramFile* file = nullptr;
    for (const programs::ProgramFile& f : files) {
      if (f.name == e.file()) file = &f;
    }
    Check(file != nullptr, "an error names one of the files");
    const programs::SourceText source(*file, 0);
    Check(e.line() >= 1 && e.line() <= source.line_count(), "an error's line is in its file");
    Check(e.column() >= 1 && static_cast<std::size_t>(e.column()) <= source.Line(e.line()).size() + 1,
          "an error's column is in its line");
    Check(!e.reason().empty(), "an error says why");
  }
  return 0;
}
