// Accuracy statistics of the paper (E_xyz, E_cos, E_tot; mean, sample std, max, RP), their table and the
// improvement of one report over another.
#include "robocal/core/accuracy.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

namespace robocal {
namespace {

constexpr double kArcsecPerRad = 180.0 * 3600.0 / M_PI;

std::string Row(const char* label, const ErrorStatistics& s, double scale) {
  char line[128];
  std::snprintf(line, sizeof(line), "  %-12s %10.1f %10.1f %10.1f %10.1f\n", label, s.mean * scale, s.std * scale,
                s.max * scale, s.rp * scale);
  return line;
}

}  // namespace

double Median(std::vector<double> values) {
  if (values.empty() || std::any_of(values.begin(), values.end(), [](double v) { return std::isnan(v); })) {
    return std::nan("");
  }
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  return 0.5 * (values[n / 2] + values[(n - 1) / 2]);
}

ErrorStatistics ComputeErrorStatistics(const std::vector<double>& values) {
  if (values.empty()) throw std::invalid_argument("ComputeErrorStatistics: empty sample");
  for (size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) {
      throw std::invalid_argument("ComputeErrorStatistics: values[" + std::to_string(i) + "] is not finite");
    }
  }
  ErrorStatistics s;
  s.count = static_cast<int>(values.size());
  double sum = 0.0;
  for (double v : values) sum += v;
  s.mean = sum / s.count;
  // Two passes (mean first) rather than sum of squares: errors of a few um on top of each other would
  // otherwise cancel catastrophically.
  double squares = 0.0;
  for (double v : values) squares += (v - s.mean) * (v - s.mean);
  s.std = s.count > 1 ? std::sqrt(squares / (s.count - 1)) : 0.0;
  s.max = *std::max_element(values.begin(), values.end());
  s.rp = s.mean + 3.0 * s.std;
  return s;
}

AccuracyReport ComputeAccuracy(const std::vector<Transform>& reached, const std::vector<Transform>& target,
                               double h_mm) {
  if (reached.empty() || reached.size() != target.size()) {
    throw std::invalid_argument("ComputeAccuracy: need as many reached as target poses, at least one (got " +
                                std::to_string(reached.size()) + " and " + std::to_string(target.size()) + ")");
  }
  if (!(h_mm > 0.0) || !std::isfinite(h_mm)) {
    throw std::invalid_argument("ComputeAccuracy: h_mm must be positive and finite");
  }
  // Named here: a NaN pose would otherwise be reported by ComputeErrorStatistics as an anonymous bad value.
  for (size_t i = 0; i < reached.size(); ++i) {
    if (!reached[i].matrix().allFinite()) {
      throw std::invalid_argument("ComputeAccuracy: reached[" + std::to_string(i) + "] is not finite");
    }
    if (!target[i].matrix().allFinite()) {
      throw std::invalid_argument("ComputeAccuracy: target[" + std::to_string(i) + "] is not finite");
    }
  }
  AccuracyReport report;
  report.h_mm = h_mm;
  const size_t n = reached.size();
  report.e_xyz_values_mm.reserve(n);
  report.e_cos_values_rad.reserve(n);
  report.e_tot_values_mm.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const double e_xyz = (reached[i].translation() - target[i].translation()).norm();
    const Eigen::Vector3d u = reached[i].linear().col(2);
    const Eigen::Vector3d u_target = target[i].linear().col(2);
    // The paper's arccos(u . u'), in the form that stays accurate near 0.
    const double e_cos = AngleBetween(u, u_target);
    report.e_xyz_values_mm.push_back(e_xyz);
    report.e_cos_values_rad.push_back(e_cos);
    report.e_tot_values_mm.push_back(e_xyz + h_mm * e_cos);
  }
  report.e_xyz_mm = ComputeErrorStatistics(report.e_xyz_values_mm);
  report.e_cos_rad = ComputeErrorStatistics(report.e_cos_values_rad);
  report.e_tot_mm = ComputeErrorStatistics(report.e_tot_values_mm);
  return report;
}

double ImprovementPercent(double before, double after) {
  if (!(before > 0.0) || !std::isfinite(before) || !std::isfinite(after)) return std::nan("");
  return 100.0 * (before - after) / before;
}

AccuracyImprovement ComputeImprovement(const AccuracyReport& before, const AccuracyReport& after) {
  AccuracyImprovement out;
  out.e_xyz_mean = ImprovementPercent(before.e_xyz_mm.mean, after.e_xyz_mm.mean);
  out.e_xyz_rp = ImprovementPercent(before.e_xyz_mm.rp, after.e_xyz_mm.rp);
  out.e_cos_mean = ImprovementPercent(before.e_cos_rad.mean, after.e_cos_rad.mean);
  out.e_cos_rp = ImprovementPercent(before.e_cos_rad.rp, after.e_cos_rad.rp);
  out.e_tot_mean = ImprovementPercent(before.e_tot_mm.mean, after.e_tot_mm.mean);
  out.e_tot_rp = ImprovementPercent(before.e_tot_mm.rp, after.e_tot_mm.rp);
  return out;
}

std::string FormatAccuracyTable(const AccuracyReport& report, const std::string& title) {
  std::ostringstream out;
  char h[32];
  std::snprintf(h, sizeof(h), "%g", report.h_mm);
  out << title << " (N = " << report.e_xyz_mm.count << ", E_tot = E_xyz + " << h << " mm * E_cos)\n";
  char header[128];
  std::snprintf(header, sizeof(header), "  %-12s %10s %10s %10s %10s\n", "", "mean", "std", "max", "RP");
  out << header;
  out << Row("E_xyz um", report.e_xyz_mm, 1000.0);
  // E_cos is an angle: printed in arc-seconds, not turned into a length.
  out << Row("E_cos arcsec", report.e_cos_rad, kArcsecPerRad);
  out << Row("E_tot um", report.e_tot_mm, 1000.0);
  return out.str();
}

}  // namespace robocal
