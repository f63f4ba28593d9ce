// Fuzz target: a tracker's point export as POST .../measurements:import reads it (api::ReadTrackerPoints, then
// api::MatchToConfigurations against a seven-configuration plan). The first byte picks the format, the unit,
// the matching and the CSV columns; the rest is the file.
#include "fuzz_util.h"
#include "robocal/api/tracker_files.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace robocal;
  if (size == 0) return 0;
  const std::uint8_t options = data[0];
  api::ImportMeasurementsRequest request;
  request.request_id = "fuzz";
  request.format = (options & 1) ? "csv" : "sa";
  static const char* const kUnits[4] = {"", "mm", "m", "in"};
  request.unit = kUnits[(options >> 1) & 3];
  request.match = (options & 8) ? "order" : "name";
  if (options & 16) request.columns = {"Name", "X [mm]", "Y [mm]", "Z [mm]", "nest"};
  request.text = fuzz::Text(data + 1, size - 1);
  const std::vector<std::vector<double>> configurations = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {8, 9}, {10, 11},
                                                           {12, 13}};
  api::Problems problems;
  const std::vector<api::TrackerPoint> points = api::ReadTrackerPoints(request, &problems);
  // Lines as editors count them: LF, CRLF and a lone CR each end one.
  std::size_t lines = 1;
  for (std::size_t k = 0; k < request.text.size(); ++k) {
    const char c = request.text[k];
    lines += c == '\n' || (c == '\r' && (k + 1 == request.text.size() || request.text[k + 1] != '\n'));
  }
  int previous_line = 0;
  for (const api::TrackerPoint& p : points) {
    // A point is a line of the file, in file order, at a finite place within reach of a tracker.
    fuzz::Check(p.line > previous_line && static_cast<std::size_t>(p.line) <= lines, "points in file order");
    previous_line = p.line;
    fuzz::Check(p.position_mm.allFinite() && p.position_mm.norm() <= api::kMaxTrackerDistanceMm,
                "a point is finite and within reach");
  }
  // A problem names the file (a line, or the whole), the unit or a column: the fields a client can fix.
  for (const api::FieldViolation& v : problems.list()) {
    fuzz::Check(v.field == "text" || v.field == "unit" || v.field.rfind("columns.", 0) == 0,
                "a problem names text, unit or a column");
    if (v.field == "text") {
      fuzz::Check(v.reason.rfind("line ", 0) == 0 || v.reason == "no points", "a file problem names its line");
    }
  }
  if (!problems.empty()) return 0;
  fuzz::Check(!points.empty(), "a file without problems has points");
  const api::MeasurementBatchRequest batch = api::MatchToConfigurations(request, points, configurations, &problems);
  if (problems.empty()) {
    // Every point stored, each with the joints of one configuration of the plan.
    fuzz::Check(batch.measurements.size() == points.size(), "every point is matched");
    for (const api::MeasurementWire& m : batch.measurements) {
      fuzz::Check(std::find(configurations.begin(), configurations.end(), m.joints) != configurations.end(),
                  "a point's joints are a configuration of the plan");
    }
  } else {
    fuzz::Check(batch.measurements.empty(), "nothing is matched when a point is not");
  }
  return 0;
}
