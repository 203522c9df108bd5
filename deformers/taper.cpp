#include "deformers/taper.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "base/error.h"

namespace raywarp {

namespace {

constexpr double kMaxFactor = 10.0;

class Taper final : public Deformer {
 public:
  Taper(const Eigen::Vector3d& half_extents, Axis axis, double factor)
      : h_(half_extents),
        a_(static_cast<int>(axis)),
        f_(factor),
        length_(2.0 * half_extents[static_cast<int>(axis)]),
        far_(std::min(1e30 * half_extents.maxCoeff(), 1e300)) {}

  std::string describe() const override {
    return std::string("taper along ") + axis_name(static_cast<Axis>(a_)) + " by " +
           shortest_text(f_);
  }

  Eigen::Vector3d forward(const Eigen::Vector3d& p) const override {
    const Eigen::Vector3d q = clamp_input(p);
    const double s = scale(q[a_]);
    Eigen::Vector3d out = s * q;
    out[a_] = q[a_];  // the axis coordinate is kept, bit for bit
    return clamp_finite(out);
  }

  Eigen::Matrix3d jacobian(const Eigen::Vector3d& p) const override {
    const Eigen::Vector3d q = clamp_input(p);
    const double qa = q[a_] + h_[a_];
    Eigen::Matrix3d J = scale(q[a_]) * Eigen::Matrix3d::Identity();
    J(a_, a_) = 1.0;
    if (qa >= 0.0 && qa <= length_) {
      // ds/dq_a = f / L inside the limits, 0 outside (the clamp).
      const double g = f_ / length_;
      for (int i : {(a_ + 1) % 3, (a_ + 2) % 3}) J(i, a_) = g * q[i];
    }
    return clamp_finite(J);
  }

  Eigen::Vector3d inverse(const Eigen::Vector3d& p_def) const override {
    const Eigen::Vector3d q = clamp_input(p_def);
    const double s = scale(q[a_]);  // q'_a = q_a: the same slice, the same scale
    Eigen::Vector3d out = q / s;
    out[a_] = q[a_];
    return clamp_finite(out);
  }

  std::array<bool, 6> identity_faces() const override {
    std::array<bool, 6> faces;
    faces.fill(f_ == 0.0);
    faces[2 * a_] = true;
    return faces;
  }

 private:
  Eigen::Vector3d clamp_input(const Eigen::Vector3d& p) const {
    return p.cwiseMax(-far_).cwiseMin(far_);
  }

  // s(z) = 1 + f z / L, z = clamp(p_a + h_a, 0, L) (Blender's axis_limit to [0, L]).
  double scale(double p_a) const {
    const double z = std::clamp(p_a + h_[a_], 0.0, length_);
    return 1.0 + f_ * (z / length_);
  }

  Eigen::Vector3d h_;
  int a_;
  double f_, length_, far_;
};

}  // namespace

std::unique_ptr<Deformer> make_taper(const Eigen::Vector3d& half_extents, Axis axis,
                                     double factor) {
  check_half_extents("taper", half_extents);
  if (!(factor > -1.0 && factor <= kMaxFactor))
    throw Error("taper factor = " + shortest_text(factor) + ": must be in (-1, " +
                shortest_text(kMaxFactor) + "]");
  return std::make_unique<Taper>(half_extents, axis, factor);
}

}  // namespace raywarp
