#include "deformers/twist.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <numbers>
#include <string>

#include "base/error.h"

namespace raywarp {

namespace {

// R_a(theta) v for the right-handed rotation about +a, given c = cos(theta), s = sin(theta):
// the pair (u, v) = (a + 1, a + 2) mod 3 turns as (x, y) does about z.
Eigen::Vector3d rotate_about(int a, double c, double s, const Eigen::Vector3d& p) {
  const int u = (a + 1) % 3, v = (a + 2) % 3;
  Eigen::Vector3d out = p;
  out[u] = c * p[u] - s * p[v];
  out[v] = s * p[u] + c * p[v];
  return out;
}

class Twist final : public Deformer {
 public:
  Twist(const Eigen::Vector3d& half_extents, Axis axis, double angle_deg)
      : h_(half_extents),
        a_(static_cast<int>(axis)),
        angle_deg_(angle_deg),
        phi_(angle_deg * std::numbers::pi / 180.0),
        length_(2.0 * half_extents[static_cast<int>(axis)]),
        far_(1e30 * half_extents.maxCoeff()) {}

  std::string describe() const override {
    return std::string("twist about ") + axis_name(static_cast<Axis>(a_)) + " by " +
           shortest_text(angle_deg_) + "\u00b0";
  }

  Eigen::Vector3d forward(const Eigen::Vector3d& p) const override {
    const double theta = twist_angle(p[a_]);
    return rotate_about(a_, std::cos(theta), std::sin(theta), p);
  }

  Eigen::Matrix3d jacobian(const Eigen::Vector3d& p) const override {
    const double theta = twist_angle(p[a_]);
    const double c = std::cos(theta), s = std::sin(theta);
    Eigen::Matrix3d J;
    for (int i = 0; i < 3; ++i) J.col(i) = rotate_about(a_, c, s, Eigen::Vector3d::Unit(i));
    const double t = (p[a_] + h_[a_]) / length_;
    if (t >= 0.0 && t <= 1.0) {
      // dR/dtheta (p - c) is R(theta) p turned by a further quarter turn: (-p'_v, p'_u).
      const Eigen::Vector3d rp = rotate_about(a_, c, s, p);
      const int u = (a_ + 1) % 3, v = (a_ + 2) % 3;
      J(u, a_) += -rp[v] * phi_ / length_;
      J(v, a_) += rp[u] * phi_ / length_;
    }
    return J;
  }

  Eigen::Vector3d inverse(const Eigen::Vector3d& p_def) const override {
    const Eigen::Vector3d q = p_def.cwiseMax(-far_).cwiseMin(far_);
    const double theta = twist_angle(q[a_]);
    return rotate_about(a_, std::cos(theta), -std::sin(theta), q);
  }

  std::array<bool, 6> identity_faces() const override {
    const double turn = 2.0 * std::numbers::pi;
    const bool whole_turns =
        std::abs(std::remainder(phi_, turn)) <= 1e-9 * std::max(std::abs(phi_), turn);
    std::array<bool, 6> faces;
    faces.fill(phi_ == 0.0);
    faces[2 * a_] = true;
    faces[2 * a_ + 1] = whole_turns;
    return faces;
  }

 private:
  // theta = phi * clamp(t, 0, 1), t = (p_a + h_a) / L.
  double twist_angle(double p_a) const {
    return phi_ * std::clamp((p_a + h_[a_]) / length_, 0.0, 1.0);
  }

  Eigen::Vector3d h_;
  int a_;
  double angle_deg_, phi_, length_, far_;
};

}  // namespace

std::unique_ptr<Deformer> make_twist(const Eigen::Vector3d& half_extents, Axis axis,
                                     double angle_deg) {
  check_half_extents("twist", half_extents);
  if (!std::isfinite(angle_deg))
    throw Error("twist angle_deg = " + shortest_text(angle_deg) + ": must be finite");
  return std::make_unique<Twist>(half_extents, axis, angle_deg);
}

}  // namespace raywarp
