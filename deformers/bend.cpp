#include "deformers/bend.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <numbers>
#include <string>

#include "base/error.h"

namespace raywarp {

namespace {

// The axes of a bend about d (Blender's simpleDeform_bend): limit axis a, bend direction b.
struct BendAxes {
  int d, a, b;
};
BendAxes bend_axes(Axis axis) {
  switch (axis) {
    case Axis::X:
      return {0, 2, 1};
    case Axis::Y:
      return {1, 2, 0};
    case Axis::Z:
      break;
  }
  return {2, 0, 1};
}

class Bend final : public Deformer {
 public:
  Bend(const Eigen::Vector3d& half_extents, Axis axis, double angle_deg)
      : ax_(bend_axes(axis)),
        angle_deg_(angle_deg),
        phi_(angle_deg * std::numbers::pi / 180.0),
        length_(2.0 * half_extents[ax_.a]),
        k_(phi_ / length_),
        far_(1e30 * half_extents.maxCoeff()) {
    pivot_ = Eigen::Vector3d::Zero();
    pivot_[ax_.a] = -half_extents[ax_.a];
    end_ = arc_point(length_);
  }

  std::string describe() const override {
    return std::string("bend about ") + axis_name(static_cast<Axis>(ax_.d)) + " by " +
           shortest_text(angle_deg_) + "\u00b0";
  }

  Eigen::Vector3d forward(const Eigen::Vector3d& p) const override {
    const Eigen::Vector3d q = p - pivot_;
    const double qa = std::clamp(q[ax_.a], 0.0, length_);
    const double overshoot = q[ax_.a] - qa;
    const double theta = k_ * qa;
    const double c = std::cos(theta), s = std::sin(theta);
    const Eigen::Vector2d arc = arc_point(qa);
    Eigen::Vector3d out = q;
    out[ax_.a] = arc[0] - q[ax_.b] * s + overshoot * c;
    out[ax_.b] = arc[1] + q[ax_.b] * c + overshoot * s;
    return pivot_ + out;
  }

  Eigen::Matrix3d jacobian(const Eigen::Vector3d& p) const override {
    const Eigen::Vector3d q = p - pivot_;
    const bool inside = q[ax_.a] >= 0.0 && q[ax_.a] <= length_;
    const double theta = k_ * std::clamp(q[ax_.a], 0.0, length_);
    const double c = std::cos(theta), s = std::sin(theta);
    // Along a the arc stretches by 1 - k q_b inside the limits; beyond them the map is rigid.
    const double stretch = inside ? 1.0 - k_ * q[ax_.b] : 1.0;
    Eigen::Matrix3d J = Eigen::Matrix3d::Identity();
    J(ax_.a, ax_.a) = stretch * c;
    J(ax_.b, ax_.a) = stretch * s;
    J(ax_.a, ax_.b) = -s;
    J(ax_.b, ax_.b) = c;
    return J;
  }

  Eigen::Vector3d inverse(const Eigen::Vector3d& p_def) const override {
    if (k_ == 0.0) return p_def;
    const Eigen::Vector3d q_def = p_def.cwiseMax(-far_).cwiseMin(far_) - pivot_;
    const double xa = q_def[ax_.a], xb = q_def[ax_.b];
    const double u = k_ * xa, w = 1.0 - k_ * xb;
    const double root_s = std::hypot(u, w);  // = 1 - k q_b on the non-folded branch
    const double theta = unwrap(root_s == 0.0 ? 0.5 * phi_ : std::atan2(u, w));
    Eigen::Vector3d q = q_def;
    if (theta * phi_ < 0.0) {
      // Before face -a: F is the identity there.
    } else if (std::abs(theta) <= std::abs(phi_)) {
      q[ax_.a] = std::clamp(theta / k_, 0.0, length_);
      q[ax_.b] = (2.0 * xb - (xa * u + xb * (k_ * xb))) / (1.0 + root_s);
    } else {
      // Beyond face +a: F(q) = end + q_b n + (q_a - L) t with t = (cos phi, sin phi) and
      // n = (-sin phi, cos phi) in (a, b), an orthonormal pair.
      const double c = std::cos(phi_), s = std::sin(phi_);
      const double da = xa - end_[0], db = xb - end_[1];
      q[ax_.a] = length_ + c * da + s * db;
      q[ax_.b] = -s * da + c * db;
    }
    return pivot_ + q;
  }

  std::array<bool, 6> identity_faces() const override {
    std::array<bool, 6> faces;
    faces.fill(phi_ == 0.0);
    faces[2 * ax_.a] = true;
    return faces;
  }

 private:
  // (q'_a, q'_b) of the point (q_a, q_b = 0), 0 <= q_a <= L: (sin(theta) / k, 2 sin^2(theta/2) / k)
  // with theta = k q_a, written without dividing by k.
  Eigen::Vector2d arc_point(double qa) const {
    const double theta = k_ * qa;
    return {qa * sinc(theta), qa * sinc(0.5 * theta) * std::sin(0.5 * theta)};
  }

  // theta + 2 pi n in [phi / 2 - pi, phi / 2 + pi]: the window holds all of [0, phi] since
  // |phi| < 2 pi, and splits the rest evenly between the two rigid continuations.
  double unwrap(double theta) const {
    const double turn = 2.0 * std::numbers::pi;
    return theta + turn * std::round((0.5 * phi_ - theta) / turn);
  }

  BendAxes ax_;
  double angle_deg_, phi_, length_, k_, far_;
  Eigen::Vector3d pivot_;
  Eigen::Vector2d end_;  // arc_point(L)
};

}  // namespace

std::unique_ptr<Deformer> make_bend(const Eigen::Vector3d& half_extents, Axis axis,
                                    double angle_deg) {
  check_half_extents("bend", half_extents);
  if (!(std::abs(angle_deg) < 360.0))
    throw Error("bend angle_deg = " + shortest_text(angle_deg) + ": must be in (-360, 360)");
  return std::make_unique<Bend>(half_extents, axis, angle_deg);
}

}  // namespace raywarp
