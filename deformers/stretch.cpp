#include "deformers/stretch.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "base/error.h"

namespace raywarp {

namespace {

constexpr double kMaxFactor = 10.0;

// The accepted factors for a box of length L along the axis (stretch.h): lo < f < hi, or f <= hi
// when hi is the cap kMaxFactor.
struct FactorRange {
  double lo, hi;
  bool hi_closed;
};
FactorRange factor_range(double L) {
  FactorRange r;
  // 1 + k > 0 gives -L; s(L) = 1 + f (L - 1 / L) > 0 gives -1 / (L - 1 / L), the tighter one
  // past L = sqrt(2) (written without L^2, which may overflow).
  r.lo = L <= std::sqrt(2.0) ? -L : -1.0 / (L - 1.0 / L);
  r.hi_closed = L > kMaxFactor;
  r.hi = r.hi_closed ? kMaxFactor : L;  // s(0) = 1 - f / L > 0
  return r;
}

class Stretch final : public Deformer {
 public:
  Stretch(const Eigen::Vector3d& half_extents, Axis axis, double factor)
      : h_(half_extents),
        a_(static_cast<int>(axis)),
        f_(factor),
        length_(2.0 * half_extents[static_cast<int>(axis)]),
        k_(factor / length_),
        far_(std::min(1e30 * half_extents.maxCoeff(), 1e300)) {}

  std::string describe() const override {
    return std::string("stretch along ") + axis_name(static_cast<Axis>(a_)) + " by " +
           shortest_text(f_);
  }

  Eigen::Vector3d forward(const Eigen::Vector3d& p) const override {
    const Eigen::Vector3d q = clamp_input(p);
    const double qa = q[a_] + h_[a_];
    const double z = std::clamp(qa, 0.0, length_);
    Eigen::Vector3d out = scale(z) * q;
    // Blender's z (1 + k) + dcut, dcut = q_a - z; the pivot is added back.
    out[a_] = (z * (1.0 + k_) + (qa - z)) - h_[a_];
    return clamp_finite(out);
  }

  Eigen::Matrix3d jacobian(const Eigen::Vector3d& p) const override {
    const Eigen::Vector3d q = clamp_input(p);
    const double qa = q[a_] + h_[a_];
    const bool inside = qa >= 0.0 && qa <= length_;
    Eigen::Matrix3d J = scale(std::clamp(qa, 0.0, length_)) * Eigen::Matrix3d::Identity();
    J(a_, a_) = inside ? 1.0 + k_ : 1.0;
    if (inside) {
      // ds/dq_a = 2 k q_a; (k q_a) <= |f| keeps the product finite.
      const double g = 2.0 * (k_ * qa);
      for (int i : {(a_ + 1) % 3, (a_ + 2) % 3}) J(i, a_) = g * q[i];
    }
    return clamp_finite(J);
  }

  Eigen::Vector3d inverse(const Eigen::Vector3d& p_def) const override {
    const Eigen::Vector3d q = clamp_input(p_def);
    const double qa_def = q[a_] + h_[a_];
    const double z = std::clamp(qa_def / (1.0 + k_), 0.0, length_);
    Eigen::Vector3d out = q / scale(z);
    out[a_] = (qa_def - k_ * z) - h_[a_];
    return clamp_finite(out);
  }

  std::array<bool, 6> identity_faces() const override {
    std::array<bool, 6> faces;
    faces.fill(f_ == 0.0);
    return faces;
  }

 private:
  Eigen::Vector3d clamp_input(const Eigen::Vector3d& p) const {
    return p.cwiseMax(-far_).cwiseMin(far_);
  }

  // Blender's s = z z k - k + 1 for z in [0, L], as (k z) z so that z^2 cannot overflow.
  double scale(double z) const { return (k_ * z) * z - k_ + 1.0; }

  Eigen::Vector3d h_;
  int a_;
  double f_, length_, k_, far_;
};

}  // namespace

std::unique_ptr<Deformer> make_stretch(const Eigen::Vector3d& half_extents, Axis axis,
                                       double factor) {
  check_half_extents("stretch", half_extents);
  const double L = 2.0 * half_extents[static_cast<int>(axis)];
  const FactorRange r = factor_range(L);
  // The conditions themselves, as evaluated: 1 + k > 0 (the axis does not fold) and s > 0 at
  // both ends of [0, L] (s is monotonic in z^2 between them).
  const double k = factor / L;
  const bool ok = std::isfinite(factor) && std::abs(factor) <= kMaxFactor && 1.0 + k > 0.0 &&
                  1.0 - k > 0.0 && (k * L) * L - k + 1.0 > 0.0;
  if (!ok)
    throw Error(
        "stretch factor = " + shortest_text(factor) + ": must be in (" + shortest_text(r.lo) +
        ", " + shortest_text(r.hi) + (r.hi_closed ? "]" : ")") + " for a box " + shortest_text(L) +
        " long along " + axis_name(axis) +
        " (beyond, the cross-section scale 1 + (factor / L)(z^2 - 1) reaches 0 in the box)");
  return std::make_unique<Stretch>(half_extents, axis, factor);
}

}  // namespace raywarp
