// The campaign report (GET /v1/campaigns/{c}/report): what it shows, as a plain data struct every number of
// which is already in the unit its field name gives, and its rendering into one self-contained HTML page
// (inline CSS and SVG, no script, no external asset; a print stylesheet). service_report.cc gathers the data;
// this part knows nothing of storage or HTTP. docs/report.md describes the page.
//
// Why by hand: no Debian library renders such a page (the packaged template engines need their own language
// and data model, and none draws SVG charts); the page is a few tables and three kinds of chart, and the only
// subtle part, escaping, is a dozen lines tested here.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "robocal/api/calibration.h"
#include "robocal/api/iso9283.h"
#include "robocal/api/plans.h"
#include "robocal/api/robots.h"

namespace robocal::server::report {

/// The configurations of a plan made in a cell, drawn as stick figures: each configuration's chain of points
/// (base origin, each joint frame's origin, flange, tool point), tracker frame, mm.
struct CellFigure {
  std::string cell;
  /// Where the tracker is in the robot's base frame (mm); the drawing's origin.
  std::array<double, 3> tracker_in_base_mm{0.0, 0.0, 0.0};
  /// Per configuration, its chain's points in the tracker frame (axes parallel to the base's: the cell gives
  /// the tracker's position, not its orientation).
  std::vector<std::vector<std::array<double, 3>>> chains;
  /// The cell's obstacles (axis-aligned boxes), tracker frame, mm.
  struct Box {
    std::string id;
    std::array<double, 3> min_mm{}, max_mm{};
  };
  std::vector<Box> obstacles;
};

/// The plan the campaign was made from.
struct PlanSection {
  api::PlanResult plan;
  /// The drawing when the plan has a cell that still exists; otherwise why there is none.
  std::optional<CellFigure> figure;
  std::string no_figure_reason;
};

/// One pair of the most correlated parameters.
struct Correlation {
  std::string a, b;
  double rho = 0.0;
};

/// The residual of one joint configuration of the calibration measurements: the RMS over its shots, before
/// (nominal model, registered base) and after calibration.
struct PoseResidual {
  /// The stored sequence numbers of its shots (first and last; equal for one shot).
  std::int64_t first_sequence = 0, last_sequence = 0;
  int shots = 0;
  double before_position_mm = 0.0, after_position_mm = 0.0;
  /// Orientation (pose) or tool-axis (position_axis) error; 0 for position measurements.
  double before_orientation_deg = 0.0, after_orientation_deg = 0.0;
  /// Shots of this configuration the robust fit excluded.
  int outliers = 0;
};

/// The fit, as stored, and its residuals recomputed over the measurements it saw.
/// One joint's fitted error map, sampled over its knots: the angle (deg), the map's value (deg) and its 2-sigma
/// band (deg, from the fit's covariance of the map's coefficients).
struct MapCurve {
  std::string joint;
  std::vector<double> angle_deg, value_deg, band_deg;
};

struct FitSection {
  api::CalibrationResult calibration;
  /// Per mapped joint (a fit with joint maps): its map as a curve with its band.
  std::vector<MapCurve> maps;
  /// As the fit computed them at its solution and stored them: singular values of the weighted, column-scaled
  /// Jacobian (descending), its condition number, and the covariance's most correlated pairs (largest |rho|
  /// first, at most kTopCorrelations).
  std::vector<double> singular_values;
  double condition_number = 0.0;
  std::vector<Correlation> correlations;
  /// Why the stored fit has none of the three above (then they are empty); "" when it has them.
  std::string linearization_problem;
  /// Per joint configuration of the measurements the fit saw, in sequence order (at most kMaxResidualBars drawn).
  std::vector<PoseResidual> poses;
};

/// The validation measurements against the nominal and the calibrated model (the :evaluate figures).
struct ValidationSection {
  api::Evaluation evaluation;
  /// E_xyz per validation measurement, in sequence order (mm).
  std::vector<double> e_xyz_before_mm, e_xyz_after_mm;
};

struct ReportData {
  std::string campaign;
  std::string description;
  MeasurementType measurement_type = MeasurementType::kPose;
  std::int64_t created_unix_ms = 0;
  /// Every stored measurement of each role.
  api::MeasurementCounts counts;
  /// Of counts.calibration, those uploaded after the fit: not in it, nor in the fit's sections.
  std::int64_t calibration_after_fit = 0;
  api::Robot robot;
  /// Absent: the campaign was not made from a plan (or the plan is gone: plan_missing says which).
  std::optional<PlanSection> plan;
  std::string plan_missing;
  FitSection fit;
  /// Absent: no validation measurements.
  std::optional<ValidationSection> validation;
  /// The ISO 9283 characteristics of the test shots (absent: none, or iso9283_problem says why they have none).
  std::optional<api::Iso9283ReportWire> iso9283;
  std::string iso9283_problem;
  /// When the page was made (ms since the Unix epoch).
  std::int64_t generated_unix_ms = 0;
};

inline constexpr std::size_t kTopCorrelations = 10;
/// Bars beyond this many configurations are not drawn (the page says so); the statistics cover them all.
inline constexpr std::size_t kMaxResidualBars = 400;
/// The outliers table lists at most this many, the largest normalised residuals first (the page says how many
/// more there are): a fit of 100,000 measurements with 30 % gross errors must not make a page of megabytes.
inline constexpr std::size_t kMaxOutlierRows = 200;

/// The page. Deterministic for equal data.
std::string RenderReport(const ReportData& data);

/// `text` safe inside HTML text and double- or single-quoted attributes: & < > " ' as entities, invalid UTF-8
/// and control characters other than tab and newline as U+FFFD.
std::string EscapeHtml(std::string_view text);

/// std in percent of |value|; NaN when value is 0 (no relative figure exists).
double StdPercent(double value, double std);

/// The most correlated pairs of a correlation matrix over `names` (i < j), largest |rho| first (ties: lower
/// indices first), at most `count`.
std::vector<Correlation> TopCorrelations(const std::vector<std::string>& names, const Eigen::MatrixXd& rho,
                                         std::size_t count);

}  // namespace robocal::server::report
