// Point, segment, capsule and box distances and intersections (see geometry.h for why by hand).
#include "robocal/core/geometry.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "robocal/core/transforms.h"

namespace robocal {
namespace {

double Clamp01(double x) { return std::clamp(x, 0.0, 1.0); }

double PointBoxDistanceSquared(const Eigen::Vector3d& p, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  double sum = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double excess = p[k] < lo[k] ? lo[k] - p[k] : (p[k] > hi[k] ? p[k] - hi[k] : 0.0);
    sum += excess * excess;
  }
  return sum;
}

}  // namespace

double PointSegmentDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d d = b - a;
  const double length_squared = d.squaredNorm();
  const double t = length_squared > 0.0 ? Clamp01((p - a).dot(d) / length_squared) : 0.0;
  return (a + t * d - p).norm();
}

double SegmentSegmentDistance(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& q0,
                              const Eigen::Vector3d& q1) {
  const Eigen::Vector3d d1 = p1 - p0;
  const Eigen::Vector3d d2 = q1 - q0;
  const Eigen::Vector3d r = p0 - q0;
  const double a = d1.squaredNorm();
  const double e = d2.squaredNorm();
  const double f = d2.dot(r);
  double s = 0.0, t = 0.0;
  if (a == 0.0 && e == 0.0) {
    // Two points.
  } else if (a == 0.0) {
    t = Clamp01(f / e);
  } else {
    const double c = d1.dot(r);
    if (e == 0.0) {
      s = Clamp01(-c / a);
    } else {
      const double b = d1.dot(d2);
      const double denom = a * e - b * b;  // >= 0; ~0 for parallel segments
      // Parallel (to rounding): any s is a closest point of the infinite lines; start from s = 0 and let the
      // clamping below find the closest pair of the segments.
      s = denom > 1e-12 * a * e ? Clamp01((b * f - c * e) / denom) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = Clamp01(-c / a);
      } else if (t > 1.0) {
        t = 1.0;
        s = Clamp01((b - c) / a);
      }
    }
  }
  return (p0 + s * d1 - (q0 + t * d2)).norm();
}

double PointBoxDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& box_min, const Eigen::Vector3d& box_max) {
  return std::sqrt(PointBoxDistanceSquared(p, box_min, box_max));
}

double SegmentBoxDistance(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& box_min,
                          const Eigen::Vector3d& box_max) {
  const Eigen::Vector3d d = b - a;
  // Breakpoints: where the segment crosses one of the six face planes. Between two of them every coordinate
  // is either below, inside or above its slab, so the squared distance is one quadratic in t.
  double breaks[8];
  int count = 0;
  breaks[count++] = 0.0;
  breaks[count++] = 1.0;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0.0) continue;
    for (const double plane : {box_min[k], box_max[k]}) {
      const double t = (plane - a[k]) / d[k];
      if (t > 0.0 && t < 1.0) breaks[count++] = t;
    }
  }
  for (int i = 1; i < count; ++i) {  // insertion sort: at most 8 values
    for (int j = i; j > 0 && breaks[j - 1] > breaks[j]; --j) std::swap(breaks[j - 1], breaks[j]);
  }
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i + 1 < count; ++i) {
    const double t0 = breaks[i], t1 = breaks[i + 1];
    const Eigen::Vector3d mid = a + 0.5 * (t0 + t1) * d;
    // sum over the coordinates outside their slab of (a_k + t d_k - plane_k)^2 = A t^2 + 2 B t + C.
    double quad = 0.0, lin = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double plane = mid[k] < box_min[k] ? box_min[k] : (mid[k] > box_max[k] ? box_max[k] : mid[k]);
      if (plane == mid[k]) continue;
      quad += d[k] * d[k];
      lin += d[k] * (a[k] - plane);
    }
    const double t = quad > 0.0 ? std::clamp(-lin / quad, t0, t1) : t0;
    best = std::min(best, PointBoxDistanceSquared(a + t * d, box_min, box_max));
    if (best == 0.0) break;
  }
  return std::sqrt(best);
}

bool SegmentIntersectsBox(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& box_min,
                          const Eigen::Vector3d& box_max) {
  const Eigen::Vector3d d = b - a;
  double t_enter = 0.0, t_exit = 1.0;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0.0) {
      if (a[k] < box_min[k] || a[k] > box_max[k]) return false;
      continue;
    }
    double t0 = (box_min[k] - a[k]) / d[k];
    double t1 = (box_max[k] - a[k]) / d[k];
    if (t0 > t1) std::swap(t0, t1);
    t_enter = std::max(t_enter, t0);
    t_exit = std::min(t_exit, t1);
    if (t_enter > t_exit) return false;
  }
  return true;
}

bool SegmentHitsCapsule(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c0,
                        const Eigen::Vector3d& c1, double radius_mm) {
  return SegmentSegmentDistance(a, b, c0, c1) < radius_mm;
}

double IncidenceAngle(const Eigen::Vector3d& normal, const Eigen::Vector3d& reflector, const Eigen::Vector3d& tracker) {
  return AngleBetween(normal, tracker - reflector);
}

}  // namespace robocal
