#include "library/triangle_bvh.h"

#include <cmath>
#include <numeric>

namespace raywarp {

namespace {

// Products and sums in the order OpenVDB's Vec3d takes them, so that distances come out the same
// to the last bit.
double dot3(const Eigen::Vector3d& x, const Eigen::Vector3d& y) {
  return x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
}

// OpenVDB's isRelOrApproxEqual(x, y, 1e-7, 1e-7).
bool approx_equal(double x, double y) {
  constexpr double kTolerance = 1e-7;
  if (!(std::abs(x - y) > kTolerance)) return true;
  const double relative = std::abs(y) > std::abs(x) ? std::abs((x - y) / y) : std::abs((x - y) / x);
  return relative <= kTolerance;
}

// OpenVDB's isApproxEqual of two Vec3d: every coordinate.
bool approx_equal(const Eigen::Vector3d& x, const Eigen::Vector3d& y) {
  return approx_equal(x[0], y[0]) && approx_equal(x[1], y[1]) && approx_equal(x[2], y[2]);
}

// The point of segment [a, b] nearest to p.
Eigen::Vector3d closest_point_on_segment(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                         const Eigen::Vector3d& p) {
  const Eigen::Vector3d ab = b - a;
  double t = dot3(p - a, ab);
  if (t <= 0.0) return a;
  const double denominator = dot3(ab, ab);
  if (t >= denominator) return b;
  t = t / denominator;
  return a + ab * t;
}

}  // namespace

Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                          const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  // Degenerate triangles: a point, or a segment.
  if (approx_equal(a, b) && approx_equal(a, c)) return a;
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot3(ab, ap), d2 = dot3(ac, ap);
  if (approx_equal(a, b)) return closest_point_on_segment(a, c, p);
  if (approx_equal(a, c) || approx_equal(b, c)) return closest_point_on_segment(a, b, p);

  if (d1 <= 0.0 && d2 <= 0.0) return a;  // vertex region of a
  const Eigen::Vector3d bp = p - b;
  const double d3 = dot3(ab, bp), d4 = dot3(ac, bp);
  if (d3 >= 0.0 && d4 <= d3) return b;  // vertex region of b
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return a + (d1 / (d1 - d3)) * ab;  // edge ab
  const Eigen::Vector3d cp = p - c;
  const double d5 = dot3(ab, cp), d6 = dot3(ac, cp);
  if (d6 >= 0.0 && d5 <= d6) return c;  // vertex region of c
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return a + (d2 / (d2 - d6)) * ac;  // edge ac
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {  // edge bc
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return b + w * (c - b);
  }
  // The face: through the barycentric coordinates (1 - v - w, v, w).
  const double denominator = 1.0 / (va + vb + vc);
  const double w = vc * denominator, v = vb * denominator;
  return a + ab * v + ac * w;
}

TriangleBvh::TriangleBvh(const Mesh& mesh) {
  const int n = static_cast<int>(mesh.F.rows());
  triangles_.resize(n);
  for (int f = 0; f < n; ++f)
    triangles_[f] = {mesh.vertex(f, 0), mesh.vertex(f, 1), mesh.vertex(f, 2)};
  build_tree();
}

TriangleBvh::TriangleBvh(std::vector<Triangle3d> triangles) : triangles_(std::move(triangles)) {
  build_tree();
}

void TriangleBvh::build_tree() {
  const int n = static_cast<int>(triangles_.size());
  std::vector<Eigen::Vector3d> centroids(n);
  for (int t = 0; t < n; ++t)
    centroids[t] = (triangles_[t][0] + triangles_[t][1] + triangles_[t][2]) / 3.0;
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  if (n > 0) {
    nodes_.reserve(2 * static_cast<size_t>(n / kLeafSize + 1));
    build(order, centroids, 0, n);
  }
  std::vector<Triangle3d> sorted(n);
  for (int k = 0; k < n; ++k) sorted[k] = triangles_[order[k]];
  triangles_ = std::move(sorted);
  index_ = std::move(order);
}

int TriangleBvh::build(std::vector<int>& order, const std::vector<Eigen::Vector3d>& centroids,
                       int first, int count) {
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  const int index = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  Eigen::Vector3d lower = Eigen::Vector3d::Constant(kInfinity),
                  upper = Eigen::Vector3d::Constant(-kInfinity);
  Eigen::Vector3d clower = lower, cupper = upper;
  for (int k = first; k < first + count; ++k) {
    for (const Eigen::Vector3d& v : triangles_[order[k]]) {
      lower = lower.cwiseMin(v);
      upper = upper.cwiseMax(v);
    }
    clower = clower.cwiseMin(centroids[order[k]]);
    cupper = cupper.cwiseMax(centroids[order[k]]);
  }
  Node node;
  node.lower = lower;
  node.upper = upper;
  node.first = first;
  node.count = count;
  if (count > kLeafSize) {
    int axis;
    (cupper - clower).maxCoeff(&axis);
    const int half = count / 2;
    std::nth_element(order.begin() + first, order.begin() + first + half,
                     order.begin() + first + count,
                     [&](int s, int t) { return centroids[s][axis] < centroids[t][axis]; });
    node.left = build(order, centroids, first, half);
    node.right = build(order, centroids, first + half, count - half);
  }
  nodes_[index] = node;
  return index;
}

double TriangleBvh::Node::box_distance2(const Eigen::Vector3d& p) const {
  double d2 = 0;
  for (int a = 0; a < 3; ++a) {
    const double d = std::max({lower[a] - p[a], 0.0, p[a] - upper[a]});
    d2 += d * d;
  }
  return d2;
}

TriangleBvh::Nearest TriangleBvh::nearest(const Eigen::Vector3d& p, double bound) const {
  Nearest best;
  double best2 = bound * bound;
  if (!nodes_.empty()) {
    int stack[kStackDepth];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& node = nodes_[stack[--top]];
      if (node.box_distance2(p) >= best2) continue;
      if (node.left < 0) {
        for (int k = node.first; k < node.first + node.count; ++k) {
          const Triangle3d& t = triangles_[k];
          const Eigen::Vector3d q = closest_point_on_triangle(p, t[0], t[1], t[2]);
          const Eigen::Vector3d e = p - q;
          const double d2 = dot3(e, e);
          if (d2 < best2) {
            best2 = d2;
            best.triangle = index_[k];
            best.point = q;
          }
        }
      } else {
        // The nearer child last, so that it is searched first and tightens the bound for the
        // other.
        const bool left_first =
            nodes_[node.left].box_distance2(p) <= nodes_[node.right].box_distance2(p);
        stack[top++] = left_first ? node.right : node.left;
        stack[top++] = left_first ? node.left : node.right;
      }
    }
  }
  best.distance = std::sqrt(best2);
  return best;
}

int TriangleBvh::count_after(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                             double t_from) const {
  int count = 0;
  for_each_hit(
      o, d, t_from, [] { return std::numeric_limits<double>::infinity(); },
      [&](int, const TriangleHit& h) { count += h.t > t_from; });
  return count;
}

}  // namespace raywarp
