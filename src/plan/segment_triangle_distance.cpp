// Exact distance between a 3D segment and a 3D triangle, after Ericson, Real-Time Collision
// Detection (2005): ClosestPtPointTriangle (5.1.5), the segment-segment distance (5.1.9, here as
// the interior critical point plus the four boundary cases, which stays exact for parallel
// segments), IntersectSegmentTriangle (5.3.6); the decomposition is Eberly's, "Distance Between
// Segment and Triangle" (Geometric Tools): a segment that misses the triangle has its closest
// pair at one of its endpoints or on one of the triangle's edges.
#include <algorithm>
#include <cmath>

#include "dsmplan/plan.hpp"

namespace dsmplan {

namespace {

struct V {
  double x, y, z;
};
inline V operator-(V a, V b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline V operator+(V a, V b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline V operator*(V a, double s) { return {a.x * s, a.y * s, a.z * s}; }
inline double dot(V a, V b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline V cross(V a, V b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline V v(const Point3& p) { return {p[0], p[1], p[2]}; }

double point_segment2(V p, V a, V b) {
  const V ab = b - a, ap = p - a;
  const double e = dot(ap, ab);
  if (e <= 0) return dot(ap, ap);
  const double f = dot(ab, ab);
  if (e >= f) {
    const V bp = p - b;
    return dot(bp, bp);
  }
  const V r = ap - ab * (e / f);
  return dot(r, r);
}

// The minimum of a convex quadratic over the unit square lies at its free critical point or on
// the square's boundary; Ericson's clamping sequence can miss the latter for near-parallel
// segments, the four point-segment distances cannot.
double segment_segment2(V p1, V q1, V p2, V q2) {
  double best = std::min(std::min(point_segment2(p1, p2, q2), point_segment2(q1, p2, q2)),
                         std::min(point_segment2(p2, p1, q1), point_segment2(q2, p1, q1)));
  const V d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = dot(d1, d1), e = dot(d2, d2), b = dot(d1, d2), c = dot(d1, r), f = dot(d2, r);
  const double denom = a * e - b * b;
  if (denom > 0) {
    const double s = (b * f - c * e) / denom, t = (a * f - b * c) / denom;
    if (s > 0 && s < 1 && t > 0 && t < 1) {
      const V w = (p1 + d1 * s) - (p2 + d2 * t);
      best = std::min(best, dot(w, w));
    }
  }
  return best;
}

// Ericson 5.1.5 with the Voronoi regions of the corners, edges and face; needs positive area.
double point_triangle2(V p, V a, V b, V c) {
  const V ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return dot(ap, ap);
  const V bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return dot(bp, bp);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const V w = ap - ab * (d1 / (d1 - d3));
    return dot(w, w);
  }
  const V cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return dot(cp, cp);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const V w = ap - ac * (d2 / (d2 - d6));
    return dot(w, w);
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const V w = bp - (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    return dot(w, w);
  }
  const double denom = 1 / (va + vb + vc);
  const V w = ap - ab * (vb * denom) - ac * (vc * denom);
  return dot(w, w);
}

}  // namespace

double segment_triangle_squared_distance(const Point3& p_, const Point3& q_, const Point3& a_, const Point3& b_,
                                         const Point3& c_) {
  const V p = v(p_), q = v(q_), a = v(a_), b = v(b_), c = v(c_);
  const V ab = b - a, ac = c - a;
  const V n = cross(ab, ac);
  const double n2 = dot(n, n);
  auto edges = [&] {
    return std::min(segment_segment2(p, q, a, b), std::min(segment_segment2(p, q, b, c), segment_segment2(p, q, c, a)));
  };
  // A sliver thinner than 1e-12 of its edges is its edges, to well within rounding; the face
  // formulas would divide by its vanishing area.
  if (!(n2 > 1e-24 * dot(ab, ab) * dot(ac, ac))) return edges();
  const double dp = dot(p - a, n), dq = dot(q - a, n);
  if (((dp <= 0 && dq >= 0) || (dp >= 0 && dq <= 0)) && dp != dq) {
    // The segment meets the plane at r; inside the triangle (barycentric signs against the
    // normal) it meets the triangle. In the plane (dp = dq = 0) the edges and ends decide.
    const V r = p + (q - p) * (dp / (dp - dq));
    const V ra = a - r, rb = b - r, rc = c - r;
    if (dot(cross(rb, rc), n) >= 0 && dot(cross(rc, ra), n) >= 0 && dot(cross(ra, rb), n) >= 0) return 0;
  }
  return std::min(edges(), std::min(point_triangle2(p, a, b, c), point_triangle2(q, a, b, c)));
}

double segment_triangle_distance(const Point3& p, const Point3& q, const Point3& a, const Point3& b, const Point3& c) {
  return std::sqrt(segment_triangle_squared_distance(p, q, a, b, c));
}

}  // namespace dsmplan
