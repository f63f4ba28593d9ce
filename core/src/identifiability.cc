// Identifiable parameter subset by column-pivoted QR of the scaled identification Jacobian.
#include "robocal/core/identifiability.h"

#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <numeric>
#include <sstream>

#include "robocal/core/column_scaling.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/random.h"

namespace robocal {
namespace {

// `d` are the unit-column factors of `weighted` (UnitColumnFactors): 0 for a column without effect.
std::string ExplainDropped(const Eigen::MatrixXd& weighted, const Eigen::VectorXd& d, const std::vector<int>& kept,
                           const Eigen::MatrixXd& kept_scaled,
                           const Eigen::ColPivHouseholderQR<Eigen::MatrixXd>& kept_qr, int j, const RobotModel& model,
                           const std::vector<Reflector>& reflectors, MeasurementType type, int* alias) {
  if (d[j] == 0.0) {
    return std::string("no effect on ") + ToString(type) + " measurements";
  }
  // Column j (unit norm) as a combination of the kept unit columns; back to physical units the coefficient
  // of kept parameter k is c_k * |a_j| / |a_k|, i.e. "a change of parameter j looks like c * parameter k".
  const Eigen::VectorXd target = weighted.col(j) * d[j];
  const Eigen::VectorXd c = kept_qr.solve(target);
  const double misfit = (kept_scaled * c - target).norm();
  std::vector<int> order(kept.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return std::abs(c[a]) > std::abs(c[b]); });
  std::ostringstream out;
  out << std::showpos << std::setprecision(4);
  // Coefficients at round-off level are not part of the relation.
  size_t significant = 0;
  while (significant < order.size() && std::abs(c[order[significant]]) > 1e-6 * std::abs(c[order[0]])) {
    ++significant;
  }
  const int shown = static_cast<int>(std::min<size_t>(3, significant));
  const bool single = significant <= 1;
  out << (single ? "indistinguishable from " : "a combination of ");
  if (single && significant == 1) *alias = kept[order[0]];
  for (int i = 0; i < (single ? 1 : shown); ++i) {
    const int k = kept[order[i]];
    const double coeff = c[order[i]] * d[k] / d[j];
    if (i > 0) out << ", ";
    out << coeff << " " << ParameterName(model, reflectors, k);
  }
  if (!single && static_cast<int>(significant) > shown) out << ", ...";
  out << std::noshowpos << " (residual " << std::setprecision(2) << misfit << ")";
  return out.str();
}

}  // namespace

bool IdentifiabilityOptions::IsValid(std::string* error) const {
  if (num_configurations < 1 || num_configurations > 100000) {
    *error = "num_configurations must be in [1, 100000]";
    return false;
  }
  if (!noise.IsValid(error)) return false;
  if (!ValidateReflectors(reflectors, error)) return false;
  if (!(rank_tolerance > 0.0 && rank_tolerance < 1.0)) {
    *error = "rank_tolerance must be in (0, 1)";
    return false;
  }
  if (!(min_rank_gap >= 1.0) || !std::isfinite(min_rank_gap)) {
    *error = "min_rank_gap must be >= 1 and finite";
    return false;
  }
  return true;
}

namespace {

// The Jacobian over random configurations (seeded, uniform within limits), `rows` per configuration, each row
// weighted by the tracker noise; with reflectors 3 rows per reflector and their offsets' columns after the model's.
Eigen::MatrixXd WeightedProbeJacobian(const RobotModel& model, MeasurementType type,
                                      const IdentifiabilityOptions& options, int rows) {
  const std::vector<Reflector>& reflectors = options.reflectors;
  const int num_reflectors = static_cast<int>(reflectors.size());
  const int n_model = model.num_error_parameters();
  const int n = n_model + 3 * num_reflectors;
  Eigen::MatrixXd weighted(rows * options.num_configurations, n);
  const Eigen::VectorXd w = options.noise.RowWeights(type);
  KinematicsWorkspace ws(model);
  Rng rng(options.seed);
  Eigen::MatrixXd block = Eigen::MatrixXd::Zero(rows, n);
  const std::vector<Eigen::Vector3d> in_tool = ReflectorsInTool(model, reflectors, Eigen::VectorXd());
  Eigen::MatrixXd pose(6, n_model);
  for (int m = 0; m < options.num_configurations; ++m) {
    const Eigen::VectorXd q = RandomConfiguration(model, &rng);
    if (num_reflectors == 0) {
      IdentificationJacobian(model, q, Eigen::VectorXd(), type, &ws, block);
    } else {
      IdentificationJacobian(model, q, Eigen::VectorXd(), MeasurementType::kPose, &ws, pose);
      for (int k = 0; k < num_reflectors; ++k) {
        ReflectorRows(ws.T_world_tool, in_tool[k], pose, block.block(3 * k, 0, 3, n_model));
        // A fixed reflector's columns stay zero: it has no offset to estimate.
        if (!reflectors[k].fixed) {
          block.block<3, 3>(3 * k, n_model + 3 * k) = ReflectorOffsetRows(model, ws.T_world_tool);
        }
      }
    }
    for (int r = 0; r < rows; ++r) weighted.row(m * rows + r) = w[num_reflectors > 0 ? 0 : r] * block.row(r);
  }
  return weighted;
}

// The probe Jacobian: weighted rows, its unit-column factors (UnitColumnFactors) and the columns scaled by them.
struct ProbeColumns {
  Eigen::MatrixXd weighted;
  Eigen::VectorXd d;
  Eigen::MatrixXd scaled;
};

// The columns in pivot order, their |R_kk|, and the rank kept.
struct PivotedColumns {
  std::vector<int> perm;
  Eigen::VectorXd diag;
  int rank = 0;
};

// The gauge of free reflector nests. Whatever moves all points rigidly with the flange (the tool site, the
// last joint's turn about its axis, ...) is also explained by the free nests' offsets, so the pivoted QR
// alone would keep an arbitrary mix of the two. The nests' offset columns go first: a free nest's position
// is what its shots measure, while the tool point is not measured at all, so what the offsets can explain
// stays in them and the tool site keeps its nominal place on the flange (no campaign without the
// tool-to-nest geometry can know better). The model's columns follow in pivoted order, projected off the
// nests' span: the same |R_kk| as one QR with the nests' columns pivoted first.
PivotedColumns PivotIdentifiabilityColumns(const Eigen::MatrixXd& scaled, int n_model,
                                           const IdentifiabilityOptions& options) {
  const std::vector<Reflector>& reflectors = options.reflectors;
  const int n = static_cast<int>(scaled.cols());
  std::vector<int> first, rest;
  for (int j = 0; j < n; ++j) {
    const bool free_offset = j >= n_model && !reflectors[(j - n_model) / 3].fixed;
    (free_offset ? first : rest).push_back(j);
  }
  PivotedColumns out;
  std::vector<int>& perm = out.perm;  // columns in pivot order
  Eigen::VectorXd& diag = out.diag;
  diag.resize(n);
  Eigen::MatrixXd rest_cols(scaled.rows(), rest.size());
  for (size_t k = 0; k < rest.size(); ++k) rest_cols.col(k) = scaled.col(rest[k]);
  int first_rank = 0;
  if (!first.empty()) {
    Eigen::MatrixXd first_cols(scaled.rows(), first.size());
    for (size_t k = 0; k < first.size(); ++k) first_cols.col(k) = scaled.col(first[k]);
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr_first(first_cols);
    const Eigen::VectorXd first_diag = qr_first.matrixQR().diagonal().cwiseAbs();
    // Tolerance against a unit column: the largest |R_kk| any column of `scaled` can have.
    while (first_rank < first_diag.size() && first_diag[first_rank] > options.rank_tolerance) ++first_rank;
    for (int k = 0; k < first_rank; ++k) {
      perm.push_back(first[qr_first.colsPermutation().indices()[k]]);
      diag[k] = first_diag[k];
    }
    // Q' applied to the rest; its rows below first_rank are the rest projected off the kept nest columns.
    rest_cols.applyOnTheLeft(qr_first.householderQ().transpose());
    rest_cols.topRows(first_rank).setZero();
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr_rest(rest_cols);
  const Eigen::VectorXd rest_diag = qr_rest.matrixQR().diagonal().cwiseAbs();
  for (Eigen::Index k = 0; k < rest_diag.size(); ++k) {
    perm.push_back(rest[qr_rest.colsPermutation().indices()[k]]);
    diag[first_rank + k] = rest_diag[k];
  }
  // Nest columns beyond the nests' own rank (not expected: each nest has its own rows) are dropped last.
  for (size_t k = first_rank; k < first.size(); ++k) {
    perm.push_back(first[k]);
    diag[first_rank + rest_diag.size() + (k - first_rank)] = 0.0;
  }
  int& rank = out.rank;
  rank = first_rank;
  while (rank - first_rank < rest_diag.size() && rest_diag[rank - first_rank] > options.rank_tolerance) ++rank;
  return out;
}

// Each dropped parameter explained by fitting its column onto the kept ones, and the kept columns' condition
// number.
void ExplainIdentifiability(const RobotModel& model, const std::vector<Reflector>& reflectors,
                            const ProbeColumns& probe, std::vector<int> dropped_indices,
                            IdentifiabilitySummary* summary) {
  const int n_model = model.num_error_parameters();
  const int rank = static_cast<int>(summary->identifiable.size());
  Eigen::MatrixXd kept_scaled(probe.scaled.rows(), rank);
  for (int k = 0; k < rank; ++k) kept_scaled.col(k) = probe.scaled.col(summary->identifiable[k]);
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> kept_qr(kept_scaled);
  std::sort(dropped_indices.begin(), dropped_indices.end());
  for (int j : dropped_indices) {
    const bool held = j >= n_model && reflectors[(j - n_model) / 3].fixed;
    int alias = -1;
    const std::string reason = held ? "held at its given position (fixed reflector)"
                                    : ExplainDropped(probe.weighted, probe.d, summary->identifiable, kept_scaled,
                                                     kept_qr, j, model, reflectors, summary->measurement_type, &alias);
    summary->dropped.push_back({j, ParameterName(model, reflectors, j), reason, alias});
  }

  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(kept_scaled);
  const Eigen::VectorXd& sv = svd.singularValues();
  summary->condition_number = rank > 0 ? sv[0] / sv[rank - 1] : 0.0;
}

}  // namespace

IdentifiabilitySummary FindIdentifiableParameters(const RobotModel& model, MeasurementType type,
                                                  const IdentifiabilityOptions& options) {
  IdentifiabilitySummary summary;
  summary.measurement_type = type;
  const std::vector<Reflector>& reflectors = options.reflectors;
  const int num_reflectors = static_cast<int>(reflectors.size());
  summary.num_parameters = model.num_error_parameters() + 3 * num_reflectors;
  summary.num_configurations = options.num_configurations;
  summary.scaling = DescribeScaling(options.noise);
  std::string error;
  if (!options.IsValid(&error)) {
    summary.message = "invalid options: " + error;
    return summary;
  }
  if (num_reflectors > 0 && type != MeasurementType::kPosition) {
    summary.message = "invalid options: reflectors need position measurements";
    return summary;
  }
  // With reflectors a configuration gives 3 rows per reflector.
  const int rows = num_reflectors > 0 ? 3 * num_reflectors : MeasurementRows(type);
  const int n_model = model.num_error_parameters();
  const int n = summary.num_parameters;
  if (rows * options.num_configurations < n) {
    summary.message = "too few configurations: " + std::to_string(rows * options.num_configurations) + " rows for " +
                      std::to_string(n) + " parameters";
    return summary;
  }

  ProbeColumns probe;
  probe.weighted = WeightedProbeJacobian(model, type, options, rows);
  if (!probe.weighted.allFinite()) {
    summary.message = "non-finite weighted Jacobian: the noise figures are out of range";
    return summary;
  }
  // A column with no effect stays zero; the QR then pivots it last.
  probe.d = UnitColumnFactorsOf(probe.weighted);
  probe.scaled = probe.weighted * probe.d.asDiagonal();
  const PivotedColumns pivots = PivotIdentifiabilityColumns(probe.scaled, n_model, options);
  const int rank = pivots.rank;
  summary.smallest_kept_pivot = rank > 0 ? pivots.diag.head(rank).minCoeff() : 0.0;
  summary.largest_dropped_pivot = rank < n ? pivots.diag.tail(n - rank).maxCoeff() : 0.0;

  for (int k = 0; k < rank; ++k) summary.identifiable.push_back(pivots.perm[k]);
  std::sort(summary.identifiable.begin(), summary.identifiable.end());
  for (int k : summary.identifiable) summary.identifiable_names.push_back(ParameterName(model, reflectors, k));
  ExplainIdentifiability(model, reflectors, probe, std::vector<int>(pivots.perm.begin() + rank, pivots.perm.end()),
                         &summary);

  std::ostringstream msg;
  msg << rank << " of " << n << " parameters identifiable from " << ToString(type) << " measurements";
  if (num_reflectors > 0) msg << " of " << num_reflectors << " reflectors";
  if (rank < n && summary.smallest_kept_pivot < options.min_rank_gap * summary.largest_dropped_pivot) {
    summary.termination = Termination::kDegraded;
    msg << "; rank decision unclear (kept pivot " << summary.smallest_kept_pivot << " vs dropped "
        << summary.largest_dropped_pivot << ")";
  } else {
    summary.termination = Termination::kConvergence;
  }
  summary.message = msg.str();
  return summary;
}

std::string IdentifiabilitySummary::BriefReport() const {
  std::ostringstream out;
  out << "Identifiability: " << ToString(termination) << ", " << message << ", cond " << std::setprecision(4)
      << condition_number;
  return out.str();
}

std::string IdentifiabilitySummary::FullReport() const {
  std::ostringstream out;
  out << BriefReport() << "\n";
  out << "  scaling: " << scaling << "\n";
  out << "  probe configurations: " << num_configurations << "\n";
  out << "  pivots |R_kk|/|R_00|: last kept " << smallest_kept_pivot << ", first dropped " << largest_dropped_pivot
      << "\n";
  out << "  identifiable (" << identifiable_names.size() << "):";
  for (const std::string& name : identifiable_names) out << " " << name;
  out << "\n  dropped (" << dropped.size() << "):\n";
  for (const DroppedParameter& d : dropped) out << "    " << d.name << ": " << d.reason << "\n";
  return out.str();
}

}  // namespace robocal
