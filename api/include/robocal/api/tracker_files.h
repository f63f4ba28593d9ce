// Measurements from a laser tracker's own export files (POST /v1/campaigns/{c}/measurements:import): a point
// export in the Spatial Analyzer style and a generic CSV, read into points in mm and matched to a plan's
// configurations by target name or by order (docs/formats.md).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "robocal/api/campaigns.h"
#include "robocal/api/error.h"
#include "robocal/api/wire.h"

namespace robocal::api {

/// The largest tracker file accepted in one import (bytes of `text`).
inline constexpr std::size_t kMaxTrackerFileBytes = 4u << 20;
/// A point farther than this from the tracker (mm, after the unit) is a unit or column mistake: trackers reach
/// tens of metres.
inline constexpr double kMaxTrackerDistanceMm = 1e6;

/// An import's file format: "sa", a point export in the Spatial Analyzer style, or "csv".
enum class TrackerFileFormat { kSa, kCsv };
/// A tracker file's length unit: "mm", "m" or "in".
enum class TrackerFileUnit { kMm, kM, kIn };
/// How points find their configurations: "name" (a target name's trailing number) or "order".
enum class TrackerFileMatch { kName, kOrder };
/// A csv import's field delimiter: ",", ";" or "\t".
enum class TrackerFileDelimiter { kComma, kSemicolon, kTab };
/// A csv import's decimal separator: "." or ",".
enum class TrackerFileDecimal { kPoint, kComma };
/// A joint or Euler angle unit: "deg" or "rad".
enum class AngleUnit { kDeg, kRad };
/// What a quaternion's four columns hold, in order: "wxyz" or "xyzw".
enum class QuaternionOrder { kWxyz, kXyzw };
/// Euler angles about the turning frame's axes ("intrinsic") or about the fixed tracker axes ("extrinsic").
enum class EulerConvention { kIntrinsic, kExtrinsic };
/// How a 6-DoF export writes the measured orientation: four quaternion columns or three Euler angles.
enum class OrientationRepresentation { kQuaternion, kEuler };
template <>
struct EnumTable<TrackerFileFormat> {
  static constexpr std::array<TrackerFileFormat, 2> values = {TrackerFileFormat::kSa, TrackerFileFormat::kCsv};
  static const char* Name(TrackerFileFormat value);
};
template <>
struct EnumTable<TrackerFileUnit> {
  static constexpr std::array<TrackerFileUnit, 3> values = {TrackerFileUnit::kMm, TrackerFileUnit::kM,
                                                            TrackerFileUnit::kIn};
  static const char* Name(TrackerFileUnit value);
};
template <>
struct EnumTable<TrackerFileMatch> {
  static constexpr std::array<TrackerFileMatch, 2> values = {TrackerFileMatch::kName, TrackerFileMatch::kOrder};
  static const char* Name(TrackerFileMatch value);
};
template <>
struct EnumTable<TrackerFileDelimiter> {
  static constexpr std::array<TrackerFileDelimiter, 3> values = {
      TrackerFileDelimiter::kComma, TrackerFileDelimiter::kSemicolon, TrackerFileDelimiter::kTab};
  static const char* Name(TrackerFileDelimiter value);
};
template <>
struct EnumTable<TrackerFileDecimal> {
  static constexpr std::array<TrackerFileDecimal, 2> values = {TrackerFileDecimal::kPoint, TrackerFileDecimal::kComma};
  static const char* Name(TrackerFileDecimal value);
};
template <>
struct EnumTable<AngleUnit> {
  static constexpr std::array<AngleUnit, 2> values = {AngleUnit::kDeg, AngleUnit::kRad};
  static const char* Name(AngleUnit value);
};
template <>
struct EnumTable<QuaternionOrder> {
  static constexpr std::array<QuaternionOrder, 2> values = {QuaternionOrder::kWxyz, QuaternionOrder::kXyzw};
  static const char* Name(QuaternionOrder value);
};
template <>
struct EnumTable<EulerConvention> {
  static constexpr std::array<EulerConvention, 2> values = {EulerConvention::kIntrinsic, EulerConvention::kExtrinsic};
  static const char* Name(EulerConvention value);
};
template <>
struct EnumTable<OrientationRepresentation> {
  static constexpr std::array<OrientationRepresentation, 2> values = {OrientationRepresentation::kQuaternion,
                                                                      OrientationRepresentation::kEuler};
  static const char* Name(OrientationRepresentation value);
};

/// The header names of a CSV export's columns (matched without regard to case or surrounding white space).
struct CsvColumns {
  std::string target = "target";
  std::string x = "x";
  std::string y = "y";
  std::string z = "z";
  /// The reflector (nest) id of each point, for a campaign with reflectors; empty: no such column.
  std::string reflector;
};
template <>
struct WireFields<CsvColumns> {
  using S = CsvColumns;
  static constexpr auto fields = std::make_tuple(
      Field{"target", &S::target, Presence::kOptionalOnRead},
      Field{"x", &S::x, Presence::kOptionalOnRead},
      Field{"y", &S::y, Presence::kOptionalOnRead},
      Field{"z", &S::z, Presence::kOptionalOnRead},
      Field{"reflector", &S::reflector, Presence::kOmitEmpty});
};
ROBOCAL_WIRE_DECLARE(CsvColumns);

/// A CSV export that carries the robot's joints beside the tracker's measurement: one column per joint, in the
/// robot's joint order, and their unit ("deg" or "rad").
struct JointColumns {
  std::vector<std::string> columns;
  AngleUnit unit = AngleUnit::kDeg;
  /// No joint columns: the export carries none.
  bool empty() const { return columns.empty(); }
};
template <>
struct WireFields<JointColumns> {
  static constexpr auto fields =
      std::make_tuple(Field{"columns", &JointColumns::columns}.Size(1, kMaxJoints), Field{"unit", &JointColumns::unit});
};
ROBOCAL_WIRE_DECLARE(JointColumns);

/// The measured orientation of a 6-DoF export (docs/formats.md, "Files with joints"): a quaternion (four
/// columns, `order` "wxyz" or "xyzw" naming what they hold), or Euler angles (three columns, the angles of the
/// first, second and third rotation of `sequence`, e.g. "XYZ" or "ZYX"; `convention` "intrinsic" (about the
/// turning frame's axes) or "extrinsic" (about the fixed tracker axes); `unit` "deg" or "rad").
struct OrientationColumns {
  /// Unset: the file's orientation is not read.
  std::optional<OrientationRepresentation> representation;
  std::vector<std::string> columns;
  QuaternionOrder order = QuaternionOrder::kWxyz;
  std::string sequence;
  EulerConvention convention = EulerConvention::kIntrinsic;
  AngleUnit unit = AngleUnit::kDeg;
  /// No orientation read.
  bool empty() const { return !representation.has_value(); }
};
template <>
struct WireFields<OrientationColumns> {
  using S = OrientationColumns;
  static constexpr bool (*kQuaternion)(const S&) = +[](const S& o) {
    return o.representation == OrientationRepresentation::kQuaternion;
  };
  static constexpr bool (*kEuler)(const S&) = +[](const S& o) {
    return o.representation == OrientationRepresentation::kEuler;
  };
  static constexpr auto fields =
      std::make_tuple(Field{"representation", &S::representation}, Field{"columns", &S::columns}.Size(3, 4),
                      Field{"order", &S::order}.When(kQuaternion), Field{"sequence", &S::sequence}.When(kEuler),
                      Field{"convention", &S::convention}.When(kEuler), Field{"unit", &S::unit}.When(kEuler));
};
ROBOCAL_WIRE_DECLARE(OrientationColumns);

/// POST /v1/campaigns/{c}/measurements:import.
struct ImportMeasurementsRequest {
  /// As in a measurement batch: the idempotency key, and the role of every point.
  std::string request_id;
  MeasurementRole role = MeasurementRole::kCalibration;
  /// "sa": `//` header lines and `collection group target x y z` rows (comma or white space); "csv": a header
  /// row and `columns`.
  TrackerFileFormat format = TrackerFileFormat::kSa;
  /// The file's text.
  std::string text;
  /// "mm", "m" or "in". csv: required. sa: the file's own declaration (a `// Units: ...` line) when absent; a
  /// request unit that contradicts the file is refused.
  std::optional<TrackerFileUnit> unit;
  /// The plan whose configurations the points were shot at; empty: the campaign's plan.
  std::string plan;
  /// "name" (default): a point's configuration is the trailing number of its target name, 1-based ("P007" is
  /// configuration 7). "order": the points in file order, `shots_per_configuration` per configuration.
  TrackerFileMatch match = TrackerFileMatch::kName;
  /// match "order": shots per configuration; 0: the number of points over the plan's configurations.
  int shots_per_configuration = 0;
  CsvColumns columns;
  /// csv: the joint columns of an export that carries them; then every row is a measurement at its own joints,
  /// and no plan is used (`plan`, `match` and `shots_per_configuration` are refused). Rows with equal joints are
  /// shots of one pose.
  JointColumns joints;
  /// csv with joints: the measured orientation (pose and position_axis campaigns need it).
  OrientationColumns orientation;
  /// csv: the field delimiter ",", ";" or "\t"; unset: the most frequent of them in the header.
  std::optional<TrackerFileDelimiter> delimiter;
  /// csv: the decimal separator, "." (default) or "," (European exports; the delimiter then cannot be ",").
  TrackerFileDecimal decimal = TrackerFileDecimal::kPoint;
  /// The payload the robot carried for every point of the file; unset: the campaign's.
  std::optional<PayloadWire> payload;
  /// The data rows to store, by 1-based line of `text`, ascending; empty: every row. The other rows are read and
  /// checked as well, and give the order the tracker took its shots in (a stale reading repeats the row before
  /// it), but are not stored: a file split into calibration and validation rows is sent whole, once per role.
  std::vector<int> rows;
};
/// Checks the request's own fields (the file is read by ReadTrackerPoints); every problem with its field.
ImportMeasurementsRequest ParseImportMeasurementsRequest(const nlohmann::json& body);
/// A file's text holds more than white space.
bool HasText(const std::string& text);
/// An import's role: test shots carry an ISO 9283 pose and cycle, which a tracker export does not.
inline bool IsImportRole(const MeasurementRole& role) { return role != MeasurementRole::kTest; }
template <>
struct WireFields<ImportMeasurementsRequest> {
  using S = ImportMeasurementsRequest;
  static constexpr bool (*kCsv)(const S&) = +[](const S& r) { return r.format == TrackerFileFormat::kCsv; };
  static constexpr auto fields = std::make_tuple(
      // ReadRequest reads the rows; the parser reads the Apart ones, whose reading depends on the format or on
      // other members (ParseImportMeasurementsRequest).
      Field{"request_id", &S::request_id}.Mandatory().Size(0, 128).Rule(&IsValidRequestId, kRequestIdRule),
      Field{"role", &S::role}.Rule(&IsImportRole,
                                   "test shots carry their ISO 9283 pose and cycle, which a tracker export does "
                                   "not: upload them as measurements (POST /v1/campaigns/{c}/measurements)"),
      Field{"format", &S::format}.Mandatory(),
      Field{"text", &S::text}.Mandatory().Size(0, kMaxTrackerFileBytes).Rule(&HasText, "the file is empty"),
      Field{"unit", &S::unit, Presence::kOmitEmpty}, Field{"plan", &S::plan, Presence::kOmitEmpty}.Size(0, 64),
      Field{"joints", &S::joints, Presence::kOmitEmpty}.Apart(),
      // A file with joints is not matched to a plan.
      Field{"match", &S::match, Presence::kOptionalOnRead}.When(+[](const S& r) { return r.joints.empty(); }),
      Field{"shots_per_configuration", &S::shots_per_configuration, Presence::kOmitEmpty}.Range(1, 1000),
      Field{"columns", &S::columns, Presence::kOptionalOnRead}.When(kCsv).Apart(),
      Field{"delimiter", &S::delimiter, Presence::kOmitEmpty}.When(kCsv),
      Field{"decimal", &S::decimal, Presence::kOptionalOnRead}.When(kCsv),
      Field{"orientation", &S::orientation, Presence::kOmitEmpty}.Apart(),
      Field{"payload", &S::payload, Presence::kOmitEmpty},
      Field{"rows", &S::rows, Presence::kOmitEmpty}.Apart().Size(1, 0).Range(1, RequestRule::kNoBound));
};
ROBOCAL_WIRE_DECLARE(ImportMeasurementsRequest);

/// One point of a tracker export.
struct TrackerPoint {
  /// 1-based line of the file.
  int line = 0;
  std::string target{};
  std::string reflector{};
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
  /// With joint columns: the row's joints (deg, the wire's unit).
  std::vector<double> joints_deg{};
  /// With orientation columns: the measured orientation (w, x, y, z; unit norm).
  bool has_orientation = false;
  std::array<double, 4> quaternion{1.0, 0.0, 0.0, 0.0};
};

/// Reads the points of `request.text` in its format, positions converted to mm. Every bad line is recorded in
/// `problems` as {"text", "line N: why"}; problems of the whole file ({"unit", ...}, {"columns.x", ...},
/// {"text", "no points"}) likewise.
std::vector<TrackerPoint> ReadTrackerPoints(const ImportMeasurementsRequest& request, Problems* problems);

/// The 1-based lines of a file's data rows, as an import's `rows` counts them: its lines (each ended as the import
/// ends them: LF, CRLF or a lone CR) after the first one that is not blank (the header), those not blank.
std::vector<int> DataRowLines(const std::string& text);

/// Data rows (DataRowLines) split at random, as `robocal upload --calibration-rows N --seed S` splits a file:
/// `calibration_rows` of them (at most all) drawn from Rng(seed) (DrawDistinct), the others for validation; each
/// list ascending.
struct DataRowSplit {
  std::vector<int> calibration, validation;
};
DataRowSplit SplitDataRows(const std::vector<int>& data_lines, std::size_t calibration_rows, std::uint64_t seed);

/// The 0-based configuration a target name points at: its trailing number, 1-based ("P007" -> 6); -1 without
/// trailing digits (or a number beyond any plan); -2 for a name with more than one number ("P001_2", "P7.8":
/// the last one may be a shot or a decimal).
int ConfigurationOfTarget(const std::string& target);

/// The measurement batch of the points of an export with joint columns: each at its own joints (and nest, as
/// MatchToConfigurations checks them), with its orientation when read.
MeasurementBatchRequest PointsWithJoints(const ImportMeasurementsRequest& request,
                                         const std::vector<TrackerPoint>& points, Problems* problems,
                                         const std::vector<CampaignReflectorWire>& reflectors = {});

/// The rotation of Euler angles (rad) about `sequence`'s axes (three of X, Y, Z, no two neighbours equal), as
/// `intrinsic` (R = R1(a) R2(b) R3(c), about the turning axes) or extrinsic (R = R3(c) R2(b) R1(a), about the
/// fixed ones). Throws std::invalid_argument for a sequence that is not one.
Eigen::Matrix3d EulerToRotation(const std::string& sequence, bool intrinsic, double a, double b, double c);

/// The measurement batch of the points: each with the joints of its configuration among `configurations` (wire
/// units, the plan's), matched by `request.match`, and its nest, one of the campaign's `reflectors` (a point
/// without one, or naming another, is a bad line; a reflector column for a campaign without nests is refused).
/// Problems are recorded as ReadTrackerPoints does.
MeasurementBatchRequest MatchToConfigurations(const ImportMeasurementsRequest& request,
                                              const std::vector<TrackerPoint>& points,
                                              const std::vector<std::vector<double>>& configurations,
                                              Problems* problems,
                                              const std::vector<CampaignReflectorWire>& reflectors = {});

}  // namespace robocal::api
