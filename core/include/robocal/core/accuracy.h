// Accuracy statistics as the paper reports them: E_xyz, E_cos, E_tot with mean, standard deviation, max and
// RP = mean + 3 std, over validation poses.
#pragma once

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

/// The paper's table rows for one report, in micrometres: "E_xyz  mean std max RP" etc.
std::string FormatAccuracyTable(const AccuracyReport& report, const std::string& title);

}  // namespace robocal
