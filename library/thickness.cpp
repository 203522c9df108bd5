#include "library/thickness.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "library/triangle_bvh.h"

namespace raywarp {

double ThicknessProbe::quantile(double q) const {
  if (features.empty()) return 0.0;
  const double rank = std::clamp(q, 0.0, 1.0) * double(features.size() - 1);
  return features[static_cast<size_t>(std::lround(rank))];
}

namespace {

// The radical inverse of i in base b (van der Corput), for the Halton points.
double radical_inverse(unsigned i, unsigned b) {
  const double inv = 1.0 / b;
  double f = inv, r = 0.0;
  while (i > 0) {
    r += f * (i % b);
    i /= b;
    f *= inv;
  }
  return r;
}

// A limb is narrower across its chord than this many thicknesses.
constexpr double kLimbWidths = 3.0;

}  // namespace

ThicknessProbe probe_thickness(const Mesh& mesh, const Box& box, int samples,
                               Interrupter* interrupter) {
  ThicknessProbe probe;
  const Eigen::Vector3d h = box.half_extents;
  // The wall across a limb lies near it: the tree holds the triangles within half the box's
  // longest side of it; the samples lie on those that meet the box.
  const Eigen::Vector3d grow = Eigen::Vector3d::Constant(0.5 * h.maxCoeff());
  const Eigen::AlignedBox3d inside(-h, h), near(-h - grow, h + grow);
  std::vector<Triangle3d> triangles;
  std::vector<Eigen::Vector3d> normals;
  std::vector<double> area_sum;  // cumulative areas of the triangles that meet the box
  std::vector<int> meeting;      // their indices in `triangles`
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    Triangle3d t;
    Eigen::AlignedBox3d bounds;
    for (int c = 0; c < 3; ++c) {
      t[c] = box.to_local(mesh.vertex(int(f), c));
      bounds.extend(t[c]);
    }
    if (!bounds.intersects(near)) continue;
    const Eigen::Vector3d n = (t[1] - t[0]).cross(t[2] - t[0]);
    const double area = 0.5 * n.norm();
    if (!(area > 0.0)) continue;
    if (bounds.intersects(inside)) {
      meeting.push_back(static_cast<int>(triangles.size()));
      area_sum.push_back((area_sum.empty() ? 0.0 : area_sum.back()) + area);
    }
    triangles.push_back(t);
    normals.push_back(n / (2.0 * area));
  }
  if (meeting.empty() || samples <= 0) return probe;
  const TriangleBvh bvh(triangles);
  const double total = area_sum.back();
  const double reach = 2.0 * h.norm();
  const double t_min = 1e-9 * reach;
  // The nearest triangle along o + t d with t in (t_min, reach), other than `skip`.
  auto cast = [&](const Eigen::Vector3d& o, const Eigen::Vector3d& d, int skip, double& t) {
    t = reach;
    int best = -1;
    bvh.for_each_hit(
        o, d, t_min, [&] { return t; },
        [&](int g, const TriangleHit& hit) {
          if (g == skip || hit.t <= t_min || hit.t >= t) return;
          t = hit.t;
          best = g;
        });
    return best;
  };

  // A candidate on a triangle that only partly lies in the box may fall outside it: up to four
  // times as many are tried.
  for (unsigned i = 0; probe.samples < samples && i < 4u * unsigned(samples); ++i) {
    if (i % 256 == 0) raywarp::poll(interrupter, "thickness", double(probe.samples) / samples);
    // The golden-ratio sequence picks the triangle by area, Halton (2, 3) the point in it.
    const double pick = std::fmod(0.5 + i * 0.6180339887498949, 1.0) * total;
    const size_t k = std::min<size_t>(
        area_sum.size() - 1,
        static_cast<size_t>(std::upper_bound(area_sum.begin(), area_sum.end(), pick) -
                            area_sum.begin()));
    const int f = meeting[k];
    double a = radical_inverse(i + 1, 2), b = radical_inverse(i + 1, 3);
    if (a + b > 1.0) {
      a = 1.0 - a;
      b = 1.0 - b;
    }
    const Triangle3d& t = triangles[size_t(f)];
    const Eigen::Vector3d p = t[0] + a * (t[1] - t[0]) + b * (t[2] - t[0]);
    if (!inside.contains(p)) continue;
    ++probe.samples;
    const Eigen::Vector3d d = -normals[size_t(f)];
    double chord = 0;
    const int across = cast(p, d, f, chord);
    if (across < 0 || normals[size_t(across)].dot(d) <= 0.0) continue;
    ++probe.hits;
    const Eigen::Vector3d middle = p + 0.5 * chord * d;
    const Eigen::Vector3d u0 = d.unitOrthogonal(), u1 = d.cross(u0);
    double narrowest = std::numeric_limits<double>::infinity();
    for (int diameter = 0; diameter < 4; ++diameter) {
      const double angle = diameter * M_PI / 4;
      const Eigen::Vector3d u = std::cos(angle) * u0 + std::sin(angle) * u1;
      double forth = 0, back = 0;
      cast(middle, u, -1, forth);
      cast(middle, -u, -1, back);
      narrowest = std::min(narrowest, forth + back);
    }
    const bool limb = narrowest < kLimbWidths * chord;
    probe.limbs += limb;
    probe.features.push_back(limb ? chord : 2.0 * chord);
  }
  std::sort(probe.features.begin(), probe.features.end());
  raywarp::poll(interrupter, "thickness", 1.0);
  return probe;
}

}  // namespace raywarp
