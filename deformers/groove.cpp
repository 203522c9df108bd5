#include "deformers/groove.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "base/error.h"

namespace raywarp {

namespace {

class Groove final : public Deformer {
 public:
  Groove(Axis axis, double radius, double width)
      : a_(static_cast<int>(axis)),
        u_((a_ + 1) % 3),
        v_((a_ + 2) % 3),
        radius_(radius),
        width_(width) {}

  std::string describe() const override {
    return std::string("groove about ") + axis_name(static_cast<Axis>(a_)) + ", radius " +
           shortest_text(radius_) + ", width " + shortest_text(width_);
  }
  Eigen::Vector3d forward(const Eigen::Vector3d& p) const override { return p; }
  Eigen::Matrix3d jacobian(const Eigen::Vector3d&) const override {
    return Eigen::Matrix3d::Identity();
  }
  Eigen::Vector3d inverse(const Eigen::Vector3d& p_def) const override { return p_def; }
  std::array<bool, 6> identity_faces() const override {
    std::array<bool, 6> faces;
    faces.fill(true);
    return faces;
  }
  bool has_cut() const override { return true; }
  bool moves_nothing() const override { return true; }
  double alpha(const Eigen::Vector3d& p) const override {
    return std::min(std::hypot(p[u_], p[v_]) - radius_, 0.5 * width_ - std::abs(p[a_]));
  }

 private:
  int a_, u_, v_;
  double radius_, width_;
};

}  // namespace

std::unique_ptr<Deformer> make_groove(const Eigen::Vector3d& half_extents, Axis axis, double radius,
                                      double width) {
  check_half_extents("groove", half_extents);
  if (!(radius > 0.0) || !std::isfinite(radius))
    throw Error("groove radius = " + shortest_text(radius) + ": must be > 0 and finite");
  const int a = static_cast<int>(axis);
  const double most = 2.0 * half_extents[a];
  if (!(width > 0.0 && width <= most))
    throw Error("groove width = " + shortest_text(width) + ": must be in (0, 2 h_" +
                axis_name(axis) + " = " + shortest_text(most) + "]");
  return std::make_unique<Groove>(axis, radius, width);
}

}  // namespace raywarp
