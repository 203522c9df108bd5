// A bounding volume hierarchy over triangles in double precision, for the exact queries of the
// distance grid (the nearest triangle to a point, within a bound: library/implicit.cpp) and of the
// CPU references (the triangles along a ray: verify/reference.cpp). The generalised winding
// number keeps its own tree (library/winding.cpp), which carries far-field moments per node.
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include "library/mesh.h"

namespace raywarp {

using Triangle3d = std::array<Eigen::Vector3d, 3>;

// A ray's hit on a triangle (a, b, c): at o + t d = (1 - u - v) a + u b + v c.
struct TriangleHit {
  double t = 0.0, u = 0.0, v = 0.0;
};

// Moller & Trumbore 1997, both faces; none when the ray is parallel to the triangle's plane.
// Any t (also negative): the caller bounds it.
inline std::optional<TriangleHit> intersect_triangle(const Eigen::Vector3d& o,
                                                     const Eigen::Vector3d& d,
                                                     const Eigen::Vector3d& a,
                                                     const Eigen::Vector3d& b,
                                                     const Eigen::Vector3d& c) {
  const Eigen::Vector3d e1 = b - a, e2 = c - a;
  const Eigen::Vector3d pv = d.cross(e2);
  const double det = e1.dot(pv);
  if (det == 0.0) return std::nullopt;
  const double inv = 1.0 / det;
  const Eigen::Vector3d tv = o - a;
  const double u = tv.dot(pv) * inv;
  if (u < 0.0 || u > 1.0) return std::nullopt;
  const Eigen::Vector3d qv = tv.cross(e1);
  const double v = d.dot(qv) * inv;
  if (v < 0.0 || u + v > 1.0) return std::nullopt;
  return TriangleHit{e2.dot(qv) * inv, u, v};
}

// The point of triangle (a, b, c) nearest to p (Ericson 2004, section 5.1.5), with the same
// arithmetic as OpenVDB's closestPointOnTriangleToPoint, degenerate cases included: a triangle
// whose vertices coincide (per coordinate within 1e-7, absolutely or relatively) is a point or a
// segment.
Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                          const Eigen::Vector3d& b, const Eigen::Vector3d& c);

// Narrows [t0, t1] to the parameters where o + t d lies in the box [lo, hi] (slab method).
// Returns false when the interval becomes empty.
inline bool clip_ray_to_box(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                            const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double& t0,
                            double& t1) {
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0.0) {
      if (o[a] < lo[a] || o[a] > hi[a]) return false;
      continue;
    }
    double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

// The tree: median split of the centroids on the longest axis of their bounds, at most 4
// triangles a leaf. Triangles keep the index they were given (a mesh's face index).
class TriangleBvh {
 public:
  // Triangle f is face f of the mesh (the vertices are copied: the mesh need not outlive it).
  explicit TriangleBvh(const Mesh& mesh);
  explicit TriangleBvh(std::vector<Triangle3d> triangles);

  int size() const { return static_cast<int>(triangles_.size()); }
  bool empty() const { return triangles_.empty(); }

  // The triangle nearest to a point, when one is nearer than the bound.
  struct Nearest {
    int triangle = -1;      // -1: none nearer than the bound
    double distance = 0.0;  // min(bound, distance to `triangle`), see nearest_distance
    Eigen::Vector3d point = Eigen::Vector3d::Zero();  // on `triangle`, nearest to p
  };
  Nearest nearest(const Eigen::Vector3d& p,
                  double bound = std::numeric_limits<double>::infinity()) const;
  // min(bound, the distance from p to the nearest triangle), as sqrt of the least squared
  // distance (so a bound no triangle beats comes back as sqrt(bound * bound)). Searches only
  // within the bound: a narrow band needs no farther answer.
  double nearest_distance(const Eigen::Vector3d& p,
                          double bound = std::numeric_limits<double>::infinity()) const {
    return nearest(p, bound).distance;
  }

  // A ray's hit on a triangle of the tree.
  struct Hit {
    int triangle = -1;
    TriangleHit hit{};
  };

  // Calls visit(triangle, hit) for every triangle the ray o + t d meets (at any t) in the nodes
  // whose box the ray meets with t in [t_min, limit()], where limit() is asked at each node and
  // visit may lower it as it goes. Depth first, the first child first, a leaf's triangles in
  // order.
  template <class Limit, class Visit>
  void for_each_hit(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min,
                    const Limit& limit, const Visit& visit) const {
    if (nodes_.empty()) return;
    int stack[kStackDepth];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& node = nodes_[stack[--top]];
      double t0 = t_min, t1 = limit();
      if (!clip_ray_to_box(o, d, node.lower, node.upper, t0, t1)) continue;
      if (node.left < 0) {
        for (int k = node.first; k < node.first + node.count; ++k) {
          const Triangle3d& tri = triangles_[k];
          if (auto h = intersect_triangle(o, d, tri[0], tri[1], tri[2])) visit(index_[k], *h);
        }
      } else {
        stack[top++] = node.right;
        stack[top++] = node.left;
      }
    }
  }

  // The nearest hit with t in [t_min, t_max] that accept(t) keeps; of hits at the same t, the
  // last one visited (for_each_hit's order).
  template <class Accept>
  std::optional<Hit> nearest_hit(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min,
                                 double t_max, const Accept& accept) const {
    Hit best;
    double best_t = t_max;
    for_each_hit(
        o, d, t_min, [&] { return best_t; },
        [&](int f, const TriangleHit& h) {
          if (h.t >= t_min && h.t <= best_t && accept(h.t)) {
            best_t = h.t;
            best = Hit{f, h};
          }
        });
    if (best.triangle < 0) return std::nullopt;
    return best;
  }
  std::optional<Hit> nearest_hit(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min,
                                 double t_max) const {
    return nearest_hit(o, d, t_min, t_max, [](double) { return true; });
  }

  // The number of triangles the ray meets at parameters t > t_from.
  int count_after(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_from) const;

 private:
  static constexpr int kLeafSize = 4;
  // A median split halves the count, so the depth is at most log2(2^31 / 4) + 1 = 30, and a
  // depth-first search holds at most one node per level and the root's.
  static constexpr int kStackDepth = 64;

  struct Node {
    Eigen::Vector3d lower, upper;
    int first = 0, count = 0;   // triangles_[first, first + count)
    int left = -1, right = -1;  // children of an inner node; -1 for a leaf
    // Squared distance from p to the node's box (0 inside).
    double box_distance2(const Eigen::Vector3d& p) const;
  };

  void build_tree();
  int build(std::vector<int>& order, const std::vector<Eigen::Vector3d>& centroids, int first,
            int count);

  std::vector<Triangle3d> triangles_;  // in leaf order
  std::vector<int> index_;             // the given index of each of triangles_
  std::vector<Node> nodes_;            // nodes_[0] is the root
};

}  // namespace raywarp
