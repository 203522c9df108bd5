#include "deformers/box_cut.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "base/error.h"

namespace raywarp {

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// The wedge's in-plane axes for axis w: (u, v) = (w + 1, w + 2) mod 3.
int wedge_u(Axis w) { return (static_cast<int>(w) + 1) % 3; }
int wedge_v(Axis w) { return (static_cast<int>(w) + 2) % 3; }

}  // namespace

BoxCut::BoxCut(const Eigen::Vector3d& half_extents, const BoxCutParams& params)
    : h_(half_extents), params_(params) {
  lo_ = -h_ + 2.0 * h_.cwiseProduct(params.sub_min);
  hi_ = -h_ + 2.0 * h_.cwiseProduct(params.sub_max);
  for (int a = 0; a < 3; ++a) {
    region_.push_back({-Eigen::Vector3d::Unit(a), -lo_[a]});
    region_.push_back({Eigen::Vector3d::Unit(a), hi_[a]});
  }
  if (params.wedge_angle_deg > 0.0) {
    const int u = wedge_u(params.wedge_axis), v = wedge_v(params.wedge_axis);
    const double a0 = params.wedge_from_deg * kDeg,
                 a1 = (params.wedge_from_deg + params.wedge_angle_deg) * kDeg;
    // s_0 = -sin(a0) p_u + cos(a0) p_v >= 0 and s_1 = sin(a1) p_u - cos(a1) p_v >= 0.
    Eigen::Vector3d n0 = Eigen::Vector3d::Zero(), n1 = Eigen::Vector3d::Zero();
    n0[u] = std::sin(a0);
    n0[v] = -std::cos(a0);
    n1[u] = -std::sin(a1);
    n1[v] = std::cos(a1);
    region_.push_back({n0, 0.0});
    region_.push_back({n1, 0.0});
  }
}

std::string BoxCut::describe() const {
  std::string out = "box cut";
  const bool whole = params_.sub_min.isZero() && params_.sub_max.isOnes();
  if (!whole) {
    out += " of [";
    for (int a = 0; a < 3; ++a)
      out += (a ? ", " : "") + shortest_text(params_.sub_min[a]) + ".." +
             shortest_text(params_.sub_max[a]);
    out += "] of the box";
  } else {
    out += " of the whole box";
  }
  if (params_.wedge_angle_deg > 0.0)
    out += ", wedge about " + std::string(1, axis_name(params_.wedge_axis)) + " from " +
           shortest_text(params_.wedge_from_deg) + "\u00b0 over " +
           shortest_text(params_.wedge_angle_deg) + "\u00b0";
  return out;
}

std::array<bool, 6> BoxCut::identity_faces() const {
  std::array<bool, 6> faces;
  faces.fill(true);
  return faces;
}

double BoxCut::alpha(const Eigen::Vector3d& p) const {
  // Exact signed distance to the sub-box, negated (positive inside).
  const Eigen::Vector3d centre = 0.5 * (lo_ + hi_), half = 0.5 * (hi_ - lo_);
  const Eigen::Vector3d q = (p - centre).cwiseAbs() - half;
  const double outside = q.cwiseMax(0.0).norm(), inside = std::min(q.maxCoeff(), 0.0);
  double a = -(outside + inside);
  for (size_t k = 6; k < region_.size(); ++k)
    a = std::min(a, region_[k].offset - region_[k].normal.dot(p));
  return a;
}

std::unique_ptr<BoxCut> make_box_cut(const Eigen::Vector3d& half_extents,
                                     const BoxCutParams& params) {
  check_half_extents("box_cut", half_extents);
  auto field = [](const char* name, int a) {
    std::string out = "box_cut ";
    out += name;
    out += '[';
    out += static_cast<char>('0' + a);
    out += ']';
    return out;
  };
  for (int a = 0; a < 3; ++a) {
    if (!(params.sub_min[a] >= 0.0 && params.sub_min[a] <= 1.0))
      throw Error(field("sub_min", a) + " = " + shortest_text(params.sub_min[a]) +
                  ": must be in [0, 1]");
    if (!(params.sub_max[a] >= 0.0 && params.sub_max[a] <= 1.0))
      throw Error(field("sub_max", a) + " = " + shortest_text(params.sub_max[a]) +
                  ": must be in [0, 1]");
    if (!(params.sub_max[a] > params.sub_min[a]))
      throw Error(field("sub_max", a) + " = " + shortest_text(params.sub_max[a]) +
                  ": must be greater than " + field("sub_min", a).substr(8) + " = " +
                  shortest_text(params.sub_min[a]));
  }
  if (!(params.wedge_angle_deg == 0.0 ||
        (params.wedge_angle_deg > 0.0 && params.wedge_angle_deg <= 180.0)))
    throw Error("box_cut wedge angle_deg = " + shortest_text(params.wedge_angle_deg) +
                ": must be in (0, 180]");
  if (!std::isfinite(params.wedge_from_deg))
    throw Error("box_cut wedge from_deg = " + shortest_text(params.wedge_from_deg) +
                ": must be finite");
  return std::make_unique<BoxCut>(half_extents, params);
}

}  // namespace raywarp
