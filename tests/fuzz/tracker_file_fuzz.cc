// Fuzz target: a tracker's export as POST .../measurements:import reads it (api::ReadTrackerPoints, then
// api::MatchToConfigurations against a seven-configuration plan, or api::PointsWithJoints for an export that
// carries joints). The first byte picks the format, the unit, the matching, the CSV columns, joint columns with
// Euler angles or a quaternion, and the decimal comma; the rest is the file.
#include <cmath>

#include "fuzz_util.h"
#include "robocal/api/tracker_files.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace robocal;
  if (size == 0) return 0;
  const std::uint8_t options = data[0];
  api::ImportMeasurementsRequest request;
  request.request_id = "fuzz";
  request.format = (options & 1) ? api::TrackerFileFormat::kCsv : api::TrackerFileFormat::kSa;
  static const std::optional<api::TrackerFileUnit> kUnits[4] = {std::nullopt, api::TrackerFileUnit::kMm,
                                                                api::TrackerFileUnit::kM, api::TrackerFileUnit::kIn};
  request.unit = kUnits[(options >> 1) & 3];
  request.match = (options & 8) ? api::TrackerFileMatch::kOrder : api::TrackerFileMatch::kName;
  if (options & 16) request.columns = {"Name", "X [mm]", "Y [mm]", "Z [mm]", "nest"};
  const bool with_joints = (options & 1) && (options & 32);
  if (with_joints) {
    request.joints = {{"j1", "j2"}, (options & 8) ? api::AngleUnit::kRad : api::AngleUnit::kDeg};
    request.orientation =
        (options & 64)
            ? api::OrientationColumns{.representation = api::OrientationRepresentation::kQuaternion,
                                      .columns = {"qw", "qx", "qy", "qz"},
                                      .order = api::QuaternionOrder::kWxyz}
            : api::OrientationColumns{.representation = api::OrientationRepresentation::kEuler,
                                      .columns = {"a", "b", "c"},
                                      .sequence = "ZYX",
                                      .convention = api::EulerConvention::kExtrinsic,
                                      .unit = api::AngleUnit::kDeg};
  }
  if ((options & 1) && (options & 128)) request.decimal = api::TrackerFileDecimal::kComma;
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
    if (with_joints) {
      fuzz::Check(p.joints_deg.size() == 2 && std::isfinite(p.joints_deg[0]) && std::isfinite(p.joints_deg[1]),
                  "a point of an export with joints has its finite joints");
      const double norm = std::sqrt(p.quaternion[0] * p.quaternion[0] + p.quaternion[1] * p.quaternion[1] +
                                    p.quaternion[2] * p.quaternion[2] + p.quaternion[3] * p.quaternion[3]);
      fuzz::Check(p.has_orientation && std::abs(norm - 1.0) < 1e-9 && p.quaternion[0] >= 0.0,
                  "a point of an export with orientation has a unit quaternion, w >= 0");
    }
  }
  // A problem names the file (a line, or the whole), the unit or a column: the fields a client can fix.
  for (const api::FieldViolation& v : problems.list()) {
    fuzz::Check(v.field == "text" || v.field == "unit" || v.field.rfind("columns.", 0) == 0 ||
                    v.field.rfind("joints.columns[", 0) == 0 || v.field.rfind("orientation.columns[", 0) == 0,
                "a problem names text, unit or a column");
    if (v.field == "text") {
      fuzz::Check(v.reason.rfind("line ", 0) == 0 || v.reason == "no points", "a file problem names its line");
    }
  }
  if (!problems.empty()) return 0;
  fuzz::Check(!points.empty(), "a file without problems has points");
  if (with_joints) {
    const api::MeasurementBatchRequest batch = api::PointsWithJoints(request, points, &problems);
    fuzz::Check(problems.empty() && batch.measurements.size() == points.size(), "every point with joints is stored");
    return 0;
  }
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
