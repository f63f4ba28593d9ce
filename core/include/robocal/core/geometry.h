// Closed-form distance and intersection tests between points, segments, capsules and axis-aligned boxes, for
// the cell's collision and line-of-sight checks (cell.h). Lengths in mm, any one frame.
//
// Written by hand with Eigen: the cell needs five small closed-form functions, and no Debian library offers
// them without a whole collision stack (FCL, Bullet) and its meshes, broad phases and allocations.
#pragma once

#include <Eigen/Core>

namespace robocal {

/// Distance from point p to the segment [a, b] (a == b: a point).
double PointSegmentDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b);

/// Distance between the segments [p0, p1] and [q0, q1]: parallel, crossing and degenerate (point) segments
/// included. Ericson, Real-Time Collision Detection (2005), 5.1.9.
double SegmentSegmentDistance(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& q0,
                              const Eigen::Vector3d& q1);

/// Distance from point p to the box [box_min, box_max] (0 inside or on it).
double PointBoxDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& box_min, const Eigen::Vector3d& box_max);

/// Distance between the segment [a, b] and the box (0 when the segment touches, crosses or lies inside it).
/// Exact: the squared distance is a convex piecewise quadratic in the segment parameter, with pieces split
/// where the segment crosses a face plane; each piece is minimised in closed form.
double SegmentBoxDistance(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& box_min,
                          const Eigen::Vector3d& box_max);

/// True when the segment [a, b] has a point inside or on the box (slab test).
bool SegmentIntersectsBox(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& box_min,
                          const Eigen::Vector3d& box_max);

/// True when the segment [a, b] (a beam) passes strictly inside the capsule of axis [c0, c1] and `radius_mm`:
/// a beam that only grazes the surface (distance == radius) is not blocked.
bool SegmentHitsCapsule(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c0,
                        const Eigen::Vector3d& c1, double radius_mm);

/// Angle (rad, [0, pi]) between a reflector's normal and the direction from the reflector to the tracker.
double IncidenceAngle(const Eigen::Vector3d& normal, const Eigen::Vector3d& reflector, const Eigen::Vector3d& tracker);

}  // namespace robocal
