// Accuracy statistics as the paper reports them: E_xyz, E_cos, E_tot with mean, standard deviation, max and
// RP = mean + 3 std, over validation poses; and the improvement of one report over another in percent.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "robocal/core/transforms.h"

namespace robocal {

/// Statistics of a sample of non-negative errors.
struct ErrorStatistics {
  int count = 0;
  double mean = 0.0;
  /// Sample standard deviation (divisor N - 1; 0 for N < 2).
  double std = 0.0;
  double max = 0.0;
  /// mean + 3 std (the paper's RP).
  double rp = 0.0;
};

/// Statistics of `values`. Throws std::invalid_argument for an empty sample or a non-finite value.
ErrorStatistics ComputeErrorStatistics(const std::vector<double>& values);

/// Median of `values` (the mean of the two middle values for an even count); NaN for an empty sample or
/// one holding a NaN.
double Median(std::vector<double> values);

/// The paper's three errors at N validation poses.
struct AccuracyReport {
  /// E_xyz = |p - p'| (mm).
  ErrorStatistics e_xyz_mm;
  /// E_cos = arccos(u . u') with u the tool axis (z column) direction cosines (rad).
  ErrorStatistics e_cos_rad;
  /// E_tot = E_xyz + h E_cos (mm).
  ErrorStatistics e_tot_mm;
  double h_mm = 30.0;
  /// The per-pose values, in input order.
  std::vector<double> e_xyz_values_mm, e_cos_values_rad, e_tot_values_mm;
};

/// Compares `reached` tool poses against `target` ones (same frame, same size >= 1). h_mm > 0.
AccuracyReport ComputeAccuracy(const std::vector<Transform>& reached, const std::vector<Transform>& target,
                               double h_mm = 30.0);

/// How much smaller `after` is than `before`, in percent of `before`: 100 (before - after) / before. Positive
/// when `after` is better (smaller), 100 when it is 0, negative when it is worse. NaN when there is no relative
/// improvement to speak of: `before` not finite or not positive (a zero baseline, e.g. a noise-free cell that
/// already reaches round-off), or `after` not finite. Callers show NaN as "n/a" in text and null on the wire.
double ImprovementPercent(double before, double after);

/// ImprovementPercent of the mean and RP of each of the paper's three errors (NaN where it has none).
struct AccuracyImprovement {
  double e_xyz_mean = std::numeric_limits<double>::quiet_NaN();
  double e_xyz_rp = std::numeric_limits<double>::quiet_NaN();
  double e_cos_mean = std::numeric_limits<double>::quiet_NaN();
  double e_cos_rp = std::numeric_limits<double>::quiet_NaN();
  double e_tot_mean = std::numeric_limits<double>::quiet_NaN();
  double e_tot_rp = std::numeric_limits<double>::quiet_NaN();
};

/// The improvement of `after` over the reference `before` (e.g. nominal against calibrated commands, or random
/// selection against a planned set): every field ImprovementPercent(before.x, after.x).
AccuracyImprovement ComputeImprovement(const AccuracyReport& before, const AccuracyReport& after);

/// The paper's table rows for one report, in micrometres: "E_xyz  mean std max RP" etc.
std::string FormatAccuracyTable(const AccuracyReport& report, const std::string& title);

}  // namespace robocal
