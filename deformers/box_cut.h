// Box cut: removes material and moves none (Correa & Silver 2007, section 5: "the removal of
// parts, i.e. a CSG operation"). F is the identity everywhere, D = 0; only the alpha map matters.
//
// The removed region C, in the box's local frame (box [-h, h]), is the intersection of
//   - the sub-box [lo, hi] with lo = -h + 2 h * sub_min, hi = -h + 2 h * sub_max (fractions of
//     the box along its local axes, 0 = min face, 1 = max face; default the whole box), and
//   - optionally a wedge about the axis w through the box centre: with (u, v) = the next two
//     axes cyclically (w = y: u = z, v = x), the points whose polar angle atan2(p_v, p_u) lies
//     in [from, from + angle], angle in (0, 180] degrees. For angle <= 180 the wedge is the
//     intersection of two half-spaces through the axis.
// C is convex: the intersection of at most 8 half-spaces n . p <= c (region()).
//
// alpha(p) = min(-sd_box(p), s_0(p), s_1(p)): sd_box is the exact signed distance to the
// sub-box (negative inside), s_0 = -sin(a0) p_u + cos(a0) p_v and s_1 = sin(a1) p_u - cos(a1) p_v
// the signed distances to the wedge's two planes (positive inside). The minimum of signed
// distances is the CSG intersection: 1-Lipschitz, exact inside near each face, and a lower bound
// of the distance to C outside it (deformer.h's contract). Its gradient is the face normal.
//
// identity_faces(): all six (F is the identity); moves_nothing() is true, so the ray caster
// reads the distance grid just beyond the box faces, where the removed part leaves a cap.
//
// Inputs: half_extents > 0 and finite; sub_min, sub_max in [0, 1] with sub_max > sub_min on
// each axis; wedge_angle_deg in (0, 180], or 0 for no wedge; wedge_from_deg finite.
// Throws raywarp::Error naming the bad input otherwise.
#pragma once
#include <Eigen/Core>
#include <memory>
#include <vector>

#include "base/box.h"
#include "deformers/deformer.h"

namespace raywarp {

struct BoxCutParams {
  Eigen::Vector3d sub_min = Eigen::Vector3d::Zero();
  Eigen::Vector3d sub_max = Eigen::Vector3d::Ones();
  Axis wedge_axis = Axis::Y;
  double wedge_from_deg = 0.0;
  double wedge_angle_deg = 0.0;  // 0: no wedge
};

class BoxCut final : public Deformer {
 public:
  BoxCut(const Eigen::Vector3d& half_extents, const BoxCutParams& params);
  std::string describe() const override;
  Eigen::Vector3d forward(const Eigen::Vector3d& p) const override { return p; }
  Eigen::Matrix3d jacobian(const Eigen::Vector3d&) const override {
    return Eigen::Matrix3d::Identity();
  }
  Eigen::Vector3d inverse(const Eigen::Vector3d& p_def) const override { return p_def; }
  std::array<bool, 6> identity_faces() const override;
  bool has_cut() const override { return true; }
  double alpha(const Eigen::Vector3d& p) const override;
  bool moves_nothing() const override { return true; }
  // The removed region as half-spaces (6 for the sub-box, plus 2 for a wedge).
  const std::vector<HalfSpace>& region() const { return region_; }

 private:
  Eigen::Vector3d h_, lo_, hi_;
  BoxCutParams params_;
  std::vector<HalfSpace> region_;
};

std::unique_ptr<BoxCut> make_box_cut(const Eigen::Vector3d& half_extents,
                                     const BoxCutParams& params);

}  // namespace raywarp
