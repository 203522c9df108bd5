#include "deformers/peel.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "base/error.h"

namespace raywarp {

namespace {

// Blender's bend in the (s, v) plane, restated from bend.h with q_a = s, q_b = v, curvature
// k = 1 / R and limit length L = R Theta (the flap curls from s = 0 on). Its inputs have s >= 0
// except inverse(), which covers the whole plane.
class Curl {
 public:
  Curl(double radius, double theta_max)
      : k_(1.0 / radius),
        theta_max_(theta_max),
        length_(radius * theta_max),
        cos_max_(std::cos(theta_max)),
        sin_max_(std::sin(theta_max)),
        end_(arc_point(length_)) {}

  double length() const { return length_; }

  Eigen::Vector2d forward(double s, double v) const {
    const double sc = std::min(s, length_);
    const double overshoot = s - sc;
    const double theta = k_ * sc;
    const double c = std::cos(theta), sn = std::sin(theta);
    const Eigen::Vector2d arc = arc_point(sc);
    return {arc[0] - v * sn + overshoot * c, arc[1] + v * c + overshoot * sn};
  }

  // d(s', v') / d(s, v): the arc stretches by 1 - k v along s for s <= L; beyond, rigid.
  Eigen::Matrix2d jacobian(double s, double v) const {
    const bool curved = s <= length_;
    const double theta = k_ * std::min(s, length_);
    const double c = std::cos(theta), sn = std::sin(theta);
    const double stretch = curved ? 1.0 - k_ * v : 1.0;
    Eigen::Matrix2d J;
    J << stretch * c, -sn, stretch * sn, c;
    return J;
  }

  // The non-folded branch (1 - k v > 0) of the inverse, with the rigid continuations of bend.h.
  Eigen::Vector2d inverse(double s_def, double v_def) const {
    const double u = k_ * s_def, w = 1.0 - k_ * v_def;
    const double root_s = std::hypot(u, w);  // = 1 - k v on the non-folded branch
    const double theta = unwrap(root_s == 0.0 ? 0.5 * theta_max_ : std::atan2(u, w));
    if (theta < 0.0) return {s_def, v_def};  // before the hinge: the identity
    if (theta <= theta_max_) {
      // v = (2 v' - k (s'^2 + v'^2)) / (1 + sqrt(S)) (bend.h), as two ratios of size <= 1 so
      // that nothing overflows: 2 - k v' = 1 + w, |1 + w| <= 1 + sqrt(S) and |u| <= sqrt(S).
      const double denominator = 1.0 + root_s;
      return {std::clamp(theta / k_, 0.0, length_),
              v_def * ((1.0 + w) / denominator) - s_def * (u / denominator)};
    }
    // Beyond s = L: F(s, v) = end + v n + (s - L) t with t = (cos Theta, sin Theta) and
    // n = (-sin Theta, cos Theta).
    const double da = s_def - end_[0], db = v_def - end_[1];
    return {length_ + cos_max_ * da + sin_max_ * db, -sin_max_ * da + cos_max_ * db};
  }

 private:
  // (s', v') of (s, 0), 0 <= s <= L, without dividing by k (bend.cpp's arc_point).
  Eigen::Vector2d arc_point(double s) const {
    const double theta = k_ * s;
    return {s * sinc(theta), s * sinc(0.5 * theta) * std::sin(0.5 * theta)};
  }

  // theta + 2 pi n in [Theta / 2 - pi, Theta / 2 + pi] (bend.cpp's unwrap).
  double unwrap(double theta) const {
    const double turn = 2.0 * std::numbers::pi;
    return theta + turn * std::round((0.5 * theta_max_ - theta) / turn);
  }

  double k_, theta_max_, length_, cos_max_, sin_max_;
  Eigen::Vector2d end_;  // arc_point(L)
};

class Peel final : public Deformer {
 public:
  Peel(const Eigen::Vector3d& half_extents, Axis curl_axis, Face from, double angle_deg,
       double thickness, double radius, double hinge)
      : h_(half_extents),
        d_(static_cast<int>(curl_axis)),
        e_(static_cast<int>(from.axis)),
        a_(3 - d_ - e_),
        side_(from.side > 0 ? 1.0 : -1.0),
        angle_deg_(angle_deg),
        thickness_(thickness),
        radius_(radius),
        hinge_(hinge),
        cut_(half_extents[e_] - thickness),
        far_(1e30 * half_extents.maxCoeff()),
        curl_(std::clamp(radius, 1e-100 * half_extents.maxCoeff(), 1e100 * half_extents.maxCoeff()),
              angle_deg * std::numbers::pi / 180.0) {}

  std::string describe() const override {
    return "peel of " + face_name(Face{static_cast<Axis>(e_), static_cast<int>(side_)}) +
           " layer " + shortest_text(thickness_) + " thick about " +
           axis_name(static_cast<Axis>(d_)) + " by " + shortest_text(angle_deg_) +
           "\u00b0, radius " + shortest_text(radius_) + ", hinge " + shortest_text(hinge_);
  }

  Eigen::Vector3d forward(const Eigen::Vector3d& p) const override {
    const Eigen::Vector3d q = clamped(p);
    const double s = arc_length(q), v = height(q);
    if (!in_flap_region(s, v)) return p;
    return place(q, curl_.forward(s, v));
  }

  Eigen::Matrix3d jacobian(const Eigen::Vector3d& p) const override {
    Eigen::Matrix3d J = Eigen::Matrix3d::Identity();
    const Eigen::Vector3d q = clamped(p);
    const double s = arc_length(q), v = height(q);
    if (!in_flap_region(s, v)) return J;
    // x_a = hinge + s and x_e = s_e (e_c + v), in and out.
    const Eigen::Matrix2d block = curl_.jacobian(s, v);
    J(a_, a_) = block(0, 0);
    J(a_, e_) = block(0, 1) * side_;
    J(e_, a_) = side_ * block(1, 0);
    J(e_, e_) = block(1, 1);
    return J;
  }

  Eigen::Vector3d inverse(const Eigen::Vector3d& p_def) const override {
    const Eigen::Vector3d p = clamped(p_def);
    const double s = arc_length(p), v = height(p);
    const Eigen::Vector2d flap = curl_.inverse(s, v);
    const Eigen::Vector3d q = place(p, flap);
    // (1) p' in the flap region or the cut: the flap's preimage, or in the cut the nearer cut
    // face's.
    if (v >= 0.0 && (s >= 0.0 || flap[1] < 0.0)) return -flap[1] <= v ? q : p_def;
    // (2) the flap's layer wins over the body's side where they overlap.
    const bool in_layer = in_flap_region(flap[0], flap[1]) && flap[1] <= thickness_ &&
                          std::abs(q[d_]) <= h_[d_] && q[a_] <= h_[a_];
    return in_layer ? q : p_def;
  }

  std::array<bool, 6> identity_faces() const override {
    std::array<bool, 6> faces;
    faces.fill(false);
    faces[2 * a_] = true;                          // -a
    faces[2 * e_ + (side_ > 0.0 ? 0 : 1)] = true;  // opposite `from`
    return faces;
  }

  bool has_cut() const override { return true; }

  double alpha(const Eigen::Vector3d& p_def) const override {
    const Eigen::Vector3d p = clamped(p_def);
    const double s = arc_length(p), v = height(p);
    return std::min(v, -curl_.inverse(s, v)[1]);
  }

 private:
  Eigen::Vector3d clamped(const Eigen::Vector3d& p) const {
    return p.cwiseMax(-far_).cwiseMin(far_);
  }
  double arc_length(const Eigen::Vector3d& p) const { return p[a_] - hinge_; }
  double height(const Eigen::Vector3d& p) const { return side_ * p[e_] - cut_; }
  static bool in_flap_region(double s, double v) { return s >= 0.0 && v >= 0.0; }
  // p with its (s, v) replaced.
  Eigen::Vector3d place(const Eigen::Vector3d& p, const Eigen::Vector2d& sv) const {
    Eigen::Vector3d out = p;
    out[a_] = hinge_ + sv[0];
    out[e_] = side_ * (cut_ + sv[1]);
    return out;
  }

  Eigen::Vector3d h_;
  int d_, e_, a_;
  double side_, angle_deg_, thickness_, radius_, hinge_;
  double cut_;  // e_c = h_e - t
  double far_;
  Curl curl_;
};

}  // namespace

std::unique_ptr<Deformer> make_peel(const Eigen::Vector3d& half_extents, Axis curl_axis, Face from,
                                    double angle_deg, double thickness, double radius,
                                    double hinge) {
  check_half_extents("peel", half_extents);
  if (curl_axis == from.axis)
    throw Error(std::string("peel axis = ") + axis_name(curl_axis) +
                ": must differ from the axis of `from` (" + face_name(from) + ")");
  if (from.side != 1 && from.side != -1)
    throw Error("peel from.side = " + std::to_string(from.side) + ": must be +1 or -1");
  if (!(angle_deg > 0.0 && angle_deg <= 180.0))
    throw Error("peel angle_deg = " + shortest_text(angle_deg) + ": must be in (0, 180]");
  const int e = static_cast<int>(from.axis);
  const double thickness_max = 2.0 * half_extents[e];
  if (!(thickness > 0.0 && thickness < thickness_max))
    throw Error("peel thickness = " + shortest_text(thickness) + ": must be in (0, 2 h_" +
                axis_name(from.axis) + " = " + shortest_text(thickness_max) + ")");
  if (!(radius > 0.0) || !std::isfinite(radius))
    throw Error("peel radius = " + shortest_text(radius) + ": must be > 0 and finite");
  const Axis a = static_cast<Axis>(3 - static_cast<int>(curl_axis) - e);
  const double h_a = half_extents[static_cast<int>(a)];
  if (!(hinge >= -h_a && hinge < h_a))
    throw Error("peel hinge = " + shortest_text(hinge) + ": must be in [-h_" + axis_name(a) +
                ", h_" + axis_name(a) + ") = [" + shortest_text(-h_a) + ", " + shortest_text(h_a) +
                ")");
  return std::make_unique<Peel>(half_extents, curl_axis, from, angle_deg, thickness, radius, hinge);
}

}  // namespace raywarp
