// Point-set registration of the tracker -> base frame (Umeyama's least-squares rotation and translation).
#include <Eigen/SVD>
#include <stdexcept>
#include <string>

#include "robocal/core/identification.h"

namespace robocal {

Transform RegisterPoints(const std::vector<Eigen::Vector3d>& from, const std::vector<Eigen::Vector3d>& to) {
  if (from.size() != to.size()) {
    throw std::invalid_argument("RegisterPoints: " + std::to_string(from.size()) + " source and " +
                                std::to_string(to.size()) + " target points");
  }
  if (from.size() < 3) {
    throw std::invalid_argument("RegisterPoints: needs at least 3 points, got " + std::to_string(from.size()));
  }
  const Eigen::Index n = static_cast<Eigen::Index>(from.size());
  Eigen::Matrix3Xd a(3, n), b(3, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    a.col(i) = from[i];
    b.col(i) = to[i];
  }
  if (!a.allFinite() || !b.allFinite()) throw std::invalid_argument("RegisterPoints: non-finite point");
  const Eigen::Vector3d ca = a.rowwise().mean();
  const Eigen::Vector3d cb = b.rowwise().mean();
  a.colwise() -= ca;
  b.colwise() -= cb;
  // The rotation is determined only if each point set spans a plane: collinear (or coincident) points leave a
  // free rotation about their line.
  const auto spread = [](const Eigen::Matrix3Xd& m) {
    const Eigen::Vector3d s = Eigen::JacobiSVD<Eigen::Matrix3d>(m * m.transpose()).singularValues();
    return s[0] > 0.0 && s[1] > 1e-18 * s[0];  // squared singular values of m: 1e-9 relative in length
  };
  if (!spread(a) || !spread(b)) {
    throw std::invalid_argument("RegisterPoints: points are collinear or coincident; the rotation is undetermined");
  }
  const Eigen::Matrix3d h = a * b.transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  // Umeyama's correction: flip the weakest direction if the best orthogonal matrix is a reflection.
  Eigen::Vector3d d(1.0, 1.0, 1.0);
  if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0) d[2] = -1.0;
  Transform t = Transform::Identity();
  t.linear() = svd.matrixV() * d.asDiagonal() * svd.matrixU().transpose();
  t.translation() = cb - t.linear() * ca;
  return t;
}

}  // namespace robocal
