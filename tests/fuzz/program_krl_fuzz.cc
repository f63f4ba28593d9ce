// Fuzz target: the KUKA KRL reader (programs/src/krl.cc). The input is one file, or a .src and a .dat when it holds
// a NUL byte (before it the .src, after it the .dat). The reader either returns targets whose spans hold exactly
// their numbers, in file and text order, with motions inside their files, or throws ProgramError naming one of
// the files at a line and column inside it. The intermediate target it writes for a Cartesian target reads back
// as one target with the values it was given.
#include <algorithm>
#include <cmath>
#include <cstring>

#include "fuzz_util.h"
#include "robocal/programs/program.h"
#include "robocal/programs/text_scan.h"

namespace {

using robocal::fuzz::Check;
namespace programs = robocal::programs;

void CheckProgram(const std::vector<programs::ProgramFile>& files, const programs::ParsedProgram& program) {
  std::vector<programs::SourceText> sources;
  for (std::size_t f = 0; f < files.size(); ++f) sources.emplace_back(files[f], static_cast<int>(f));
  std::pair<int, std::size_t> previous{-1, 0};
  for (const programs::ProgramTarget& t : program.targets) {
    Check(t.values.size() == 6 && t.spans.size() == 6, "a target has six values and six spans");
    Check(t.file >= 0 && static_cast<std::size_t>(t.file) < files.size(), "a target is in one of the files");
    const std::string& text = files[t.file].text;
    std::size_t first = text.size();
    for (std::size_t i = 0; i < 6; ++i) {
      const programs::NumberSpan& span = t.spans[i];
      Check(span.file == t.file && span.length > 0 && span.offset + span.length <= text.size(),
            "a span lies inside its target's file");
      const auto number = programs::ScanNumber(std::string_view(text).substr(span.offset, span.length), 0);
      Check(number && number->length == span.length && number->value == t.values[i],
            "a span holds exactly the number listed");
      first = std::min(first, span.offset);
    }
    Check(t.line == sources[t.file].LineOf(first) && t.column == sources[t.file].ColumnOf(first),
          "a target is at its first number");
    Check(previous < std::make_pair(t.file, first), "targets in file, then text order");
    previous = {t.file, first};
    if (t.kind == programs::TargetKind::kJoint) {
      Check(t.configuration.empty() && !t.configuration_applies, "a joint target has no flags");
    }
    Check(t.turns.empty() || t.configuration_applies, "turns only where the configuration applies");
  }
  for (const programs::MotionStatement& m : program.motions) {
    Check(m.target >= 0 && static_cast<std::size_t>(m.target) < program.targets.size(), "a motion has a target");
    Check(m.file >= 0 && static_cast<std::size_t>(m.file) < files.size(), "a motion is in one of the files");
    Check(m.begin <= m.reference_begin && m.reference_begin < m.reference_end && m.reference_end <= m.end &&
              m.end <= files[m.file].text.size(),
          "a motion's reference lies inside its statement, inside its file");
    Check(m.line == sources[m.file].LineOf(m.begin), "a motion is at its statement's line");
  }
}

// The inserted target for a Cartesian `like` reads back as one target with the values given.
void CheckInlineTarget(const std::vector<programs::ProgramFile>& files, const programs::ProgramTarget& like) {
  const programs::DialectSyntax& krl = programs::SyntaxOf(programs::Dialect::kKrl);
  std::vector<double> values = like.values;
  values[0] += 0.5;
  values[5] = -values[5];
  const std::string text = krl.inline_target(like, files, values);
  if (like.kind == programs::TargetKind::kJoint) {
    Check(text.empty(), "no inline Cartesian target for a joint target");
    return;
  }
  const std::vector<programs::ProgramFile> inserted = {{"inserted.src", "PTP " + text + "\n"}};
  const programs::ParsedProgram again = krl.read(inserted);
  Check(again.targets.size() == 1 && again.motions.size() == 1, "an inserted target reads as one target");
  for (int i = 0; i < 6; ++i) {
    const double written = again.targets[0].values[i];
    Check(std::abs(written - values[i]) <= 1e-3 + 1e-12 * std::abs(values[i]), "an inserted target keeps its values");
  }
  Check(again.targets[0].configuration == like.configuration, "an inserted target keeps the flags of its model");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string input = robocal::fuzz::Text(data, size);
  std::vector<programs::ProgramFile> files;
  const std::size_t nul = input.find('\0');
  if (nul == std::string::npos) {
    files.push_back({"fuzz.src", input});
  } else {
    files.push_back({"fuzz.src", input.substr(0, nul)});
    files.push_back({"fuzz.dat", input.substr(nul + 1)});
  }
  const programs::DialectSyntax& krl = programs::SyntaxOf(programs::Dialect::kKrl);
  programs::ParsedProgram program;
  try {
    program = krl.read(files);
  } catch (const programs::ProgramError& e) {
    const auto file =
        std::find_if(files.begin(), files.end(), [&](const programs::ProgramFile& f) { return f.name == e.file(); });
    Check(file != files.end(), "an error names one of the files");
    const programs::SourceText source(*file, 0);
    Check(e.line() >= 1 && e.line() <= source.line_count(), "an error's line is in its file");
    Check(e.column() >= 1 && static_cast<std::size_t>(e.column()) <= source.Line(e.line()).size() + 1,
          "an error's column is in its line");
    return 0;
  }
  CheckProgram(files, program);
  for (const programs::ProgramTarget& t : program.targets) CheckInlineTarget(files, t);
  return 0;
}
