// Cell geometry (distances, intersections, incidence) against hand-computed cases and sampling.
#include <algorithm>
#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "robocal/core/geometry.h"
#include "robocal/core/random.h"

namespace robocal {
namespace {

using V = Eigen::Vector3d;

// ---- Geometry ------------------------------------------------------------------------------------------

TEST(GeometryTest, PointSegmentDistance) {
  EXPECT_DOUBLE_EQ(PointSegmentDistance(V(5, 3, 0), V(0, 0, 0), V(10, 0, 0)), 3.0);   // beside the middle
  EXPECT_DOUBLE_EQ(PointSegmentDistance(V(13, 4, 0), V(0, 0, 0), V(10, 0, 0)), 5.0);  // beyond the end
  EXPECT_DOUBLE_EQ(PointSegmentDistance(V(3, 4, 0), V(0, 0, 0), V(0, 0, 0)), 5.0);    // a point
}

TEST(GeometryTest, SegmentSegmentDistanceHandComputed) {
  // Crossing at right angles, 5 apart along z.
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(-1, 0, 0), V(1, 0, 0), V(0, -1, 5), V(0, 1, 5)), 5.0);
  // Intersecting.
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(-1, 0, 0), V(1, 0, 0), V(0, -1, 0), V(0, 1, 0)), 0.0);
  // Skew, closest points at ends of both: (1, 0, 0) and (2, 0, 1).
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(0, 0, 0), V(1, 0, 0), V(2, -1, 1), V(2, 1, 1)), std::sqrt(2.0));
  // Parallel and overlapping: the distance between the lines.
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(0, 0, 0), V(10, 0, 0), V(4, 3, 4), V(20, 3, 4)), 5.0);
  // Parallel, not overlapping: end to end, (10, 0, 0) to (13, 4, 0).
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(0, 0, 0), V(10, 0, 0), V(13, 4, 0), V(20, 4, 0)), 5.0);
  // Parallel, opposite directions, overlapping.
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(0, 0, 0), V(10, 0, 0), V(8, 0, 2), V(-3, 0, 2)), 2.0);
  // Collinear and apart.
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(0, 0, 0), V(1, 0, 0), V(4, 0, 0), V(9, 0, 0)), 3.0);
  // Degenerate: point-point, point-segment, segment-point.
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(0, 0, 0), V(0, 0, 0), V(3, 4, 0), V(3, 4, 0)), 5.0);
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(5, 3, 0), V(5, 3, 0), V(0, 0, 0), V(10, 0, 0)), 3.0);
  EXPECT_DOUBLE_EQ(SegmentSegmentDistance(V(0, 0, 0), V(10, 0, 0), V(5, 3, 0), V(5, 3, 0)), 3.0);
}

TEST(GeometryTest, SegmentSegmentDistanceAgreesWithSampling) {
  Rng rng(7);
  auto random_point = [&] { return V(rng.Uniform(-10, 10), rng.Uniform(-10, 10), rng.Uniform(-10, 10)); };
  for (int trial = 0; trial < 200; ++trial) {
    const V p0 = random_point(), p1 = random_point(), q0 = random_point(), q1 = random_point();
    const double d = SegmentSegmentDistance(p0, p1, q0, q1);
    EXPECT_NEAR(d, SegmentSegmentDistance(q1, q0, p1, p0), 1e-12);  // symmetric, direction-free
    double sampled = INFINITY;
    constexpr int kSteps = 200;
    for (int i = 0; i <= kSteps; ++i) {
      const V p = p0 + (p1 - p0) * i / kSteps;
      sampled = std::min(sampled, PointSegmentDistance(p, q0, q1));
    }
    // The exact minimum is at most the sampled one, and within the sampling step of it.
    EXPECT_LE(d, sampled + 1e-12);
    EXPECT_GE(d, sampled - (p1 - p0).norm() / kSteps);
  }
}

TEST(GeometryTest, SegmentBoxDistanceHandComputed) {
  const V lo(0, 0, 0), hi(1, 1, 1);
  EXPECT_DOUBLE_EQ(SegmentBoxDistance(V(-1, 2, 0.5), V(2, 2, 0.5), lo, hi), 1.0);            // parallel to a face
  EXPECT_DOUBLE_EQ(SegmentBoxDistance(V(-1, 0.5, 0.5), V(2, 0.5, 0.5), lo, hi), 0.0);        // through it
  EXPECT_DOUBLE_EQ(SegmentBoxDistance(V(0.2, 0.3, 0.4), V(0.6, 0.7, 0.8), lo, hi), 0.0);     // inside
  EXPECT_DOUBLE_EQ(SegmentBoxDistance(V(2, 2, 2), V(3, 3, 3), lo, hi), std::sqrt(3.0));      // off a corner
  EXPECT_DOUBLE_EQ(SegmentBoxDistance(V(3, 0, 0.5), V(0, 3, 0.5), lo, hi), std::sqrt(0.5));  // past an edge
  EXPECT_DOUBLE_EQ(SegmentBoxDistance(V(4, 5, 1), V(4, 5, 1), lo, hi), 5.0);                 // a point
  EXPECT_DOUBLE_EQ(SegmentBoxDistance(V(1, 0, 3), V(3, 0, 1), lo, hi), std::sqrt(2.0));      // past the top edge
}

TEST(GeometryTest, SegmentBoxDistanceAgreesWithSampling) {
  Rng rng(11);
  const V lo(-1, -2, -0.5), hi(2, 1, 0.5);
  for (int trial = 0; trial < 200; ++trial) {
    const V a(rng.Uniform(-5, 5), rng.Uniform(-5, 5), rng.Uniform(-5, 5));
    const V b(rng.Uniform(-5, 5), rng.Uniform(-5, 5), rng.Uniform(-5, 5));
    const double d = SegmentBoxDistance(a, b, lo, hi);
    double sampled = INFINITY;
    constexpr int kSteps = 400;
    for (int i = 0; i <= kSteps; ++i) sampled = std::min(sampled, PointBoxDistance(a + (b - a) * i / kSteps, lo, hi));
    EXPECT_LE(d, sampled + 1e-12);
    EXPECT_GE(d, sampled - (b - a).norm() / kSteps);
    EXPECT_EQ(d == 0.0, SegmentIntersectsBox(a, b, lo, hi)) << trial;
  }
}

TEST(GeometryTest, SegmentIntersectsBox) {
  const V lo(0, 0, 0), hi(1, 1, 1);
  EXPECT_TRUE(SegmentIntersectsBox(V(-1, 0.5, 0.5), V(2, 0.5, 0.5), lo, hi));     // through
  EXPECT_TRUE(SegmentIntersectsBox(V(0.5, 0.5, 0.5), V(0.6, 0.5, 0.5), lo, hi));  // inside
  EXPECT_TRUE(SegmentIntersectsBox(V(-1, 0.5, 1), V(2, 0.5, 1), lo, hi));         // along the top face
  EXPECT_FALSE(SegmentIntersectsBox(V(-1, 0.5, 1.01), V(2, 0.5, 1.01), lo, hi));
  EXPECT_FALSE(SegmentIntersectsBox(V(-2, 0.5, 0.5), V(-1, 0.5, 0.5), lo, hi));  // stops short
  EXPECT_FALSE(SegmentIntersectsBox(V(3, 0, 0.5), V(0, 3, 0.5), lo, hi));        // passes the edge
}

TEST(GeometryTest, SegmentHitsCapsuleHitMissTangent) {
  const V c0(0, 0, 0), c1(100, 0, 0);
  // Through the cylinder part.
  EXPECT_TRUE(SegmentHitsCapsule(V(50, -100, 5), V(50, 100, 5), c0, c1, 10));
  // Tangent: the segment passes at exactly the radius, (50, 0, 0) to (50, 0, 10); grazing does not block.
  EXPECT_FALSE(SegmentHitsCapsule(V(50, -100, 10), V(50, 100, 10), c0, c1, 10));
  EXPECT_TRUE(SegmentHitsCapsule(V(50, -100, 9.999), V(50, 100, 9.999), c0, c1, 10));
  // Past the end of the axis: only the spherical cap counts.
  EXPECT_TRUE(SegmentHitsCapsule(V(105, -100, 0), V(105, 100, 0), c0, c1, 10));
  EXPECT_FALSE(SegmentHitsCapsule(V(115, -100, 0), V(115, 100, 0), c0, c1, 10));
  // A beam that stops before the capsule.
  EXPECT_FALSE(SegmentHitsCapsule(V(50, -100, 0), V(50, -20, 0), c0, c1, 10));
}

TEST(GeometryTest, IncidenceAngle) {
  const V normal(0, 0, 1), reflector(10, 20, 30);
  EXPECT_NEAR(IncidenceAngle(normal, reflector, reflector + V(0, 0, 500)), 0.0, 1e-15);
  EXPECT_NEAR(IncidenceAngle(normal, reflector, reflector + V(300, 0, 300)), M_PI / 4, 1e-15);
  EXPECT_NEAR(IncidenceAngle(normal, reflector, reflector + V(0, -7, 0)), M_PI / 2, 1e-15);
  EXPECT_NEAR(IncidenceAngle(normal, reflector, reflector + V(0, 0, -1)), M_PI, 1e-15);
  EXPECT_NEAR(IncidenceAngle(normal, reflector, reflector + V(0, std::sqrt(3.0), 1)), M_PI / 3, 1e-15);
}

}  // namespace
}  // namespace robocal
