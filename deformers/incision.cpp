#include "deformers/incision.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "base/error.h"

namespace raywarp {

namespace {

class Incision final : public Deformer {
 public:
  Incision(const Eigen::Vector3d& half_extents, Axis normal, Face from, double depth,
           double opening)
      : h_(half_extents),
        n_(static_cast<int>(normal)),
        e_(static_cast<int>(from.axis)),
        l_(3 - n_ - e_),
        side_(from.side > 0 ? 1.0 : -1.0),
        depth_(depth),
        opening_(opening),
        u_end_(half_extents[e_] - depth),
        lip_(std::hypot(1.0, 0.5 * opening / depth, opening / half_extents[l_])) {}

  std::string describe() const override {
    return std::string("incision normal ") + axis_name(static_cast<Axis>(n_)) + " from " +
           face_name(Face{static_cast<Axis>(e_), static_cast<int>(side_)}) + ", depth " +
           shortest_text(depth_) + ", opening " + shortest_text(opening_);
  }

  Eigen::Vector3d forward(const Eigen::Vector3d& p) const override {
    const double xn = p[n_];
    if (!(std::abs(xn) < h_[n_])) return p;  // beyond the +-n faces
    Eigen::Vector3d out = p;
    out[n_] = xn + side_of(xn) * opening_at(p) * (1.0 - std::abs(xn) / h_[n_]);
    return out;
  }

  Eigen::Matrix3d jacobian(const Eigen::Vector3d& p) const override {
    Eigen::Matrix3d J = Eigen::Matrix3d::Identity();
    const double xn = p[n_];
    if (!(std::abs(xn) < h_[n_])) return J;
    const double u = side_ * p[e_], xl = p[l_];
    const double r = ramp(u), m = profile(xl), c = 0.5 * opening_ * r * m;
    const double g = side_of(xn) * (1.0 - std::abs(xn) / h_[n_]);
    J(n_, n_) = 1.0 - c / h_[n_];
    if (u > u_end_ && u < h_[e_]) J(n_, e_) = g * 0.5 * opening_ * m * side_ / depth_;
    if (std::abs(xl) < h_[l_]) J(n_, l_) = -g * 0.5 * opening_ * r * 2.0 * xl / (h_[l_] * h_[l_]);
    return J;
  }

  Eigen::Vector3d inverse(const Eigen::Vector3d& p_def) const override {
    const double xn = p_def[n_];
    if (!(std::abs(xn) < h_[n_])) return p_def;
    const double c = opening_at(p_def);
    Eigen::Vector3d p = p_def;
    // The side x'_n >= 0 is the + side's image (x_n = 0 included), the rest the - side's; in the
    // gap each formula continues the nearer side's inverse.
    p[n_] = (xn - side_of(xn) * c) / (1.0 - c / h_[n_]);
    return p;
  }

  std::array<bool, 6> identity_faces() const override {
    std::array<bool, 6> faces;
    faces.fill(true);
    faces[2 * e_ + (side_ > 0.0 ? 1 : 0)] = false;
    return faces;
  }

  bool has_cut() const override { return true; }

  double alpha(const Eigen::Vector3d& p_def) const override {
    return (opening_at(p_def) - std::abs(p_def[n_])) / lip_;
  }

 private:
  // sgn with sgn(0) = sgn(-0) = +1.
  static double side_of(double xn) { return xn >= 0.0 ? 1.0 : -1.0; }
  // r(u) = clamp((u - u_end) / depth, 0, 1); an overflow to +-inf clamps too.
  double ramp(double u) const { return std::clamp((u - u_end_) / depth_, 0.0, 1.0); }
  // m(x_l) = 1 - (min(|x_l|, h_l) / h_l)^2.
  double profile(double xl) const {
    const double t = std::min(std::abs(xl), h_[l_]) / h_[l_];
    return 1.0 - t * t;
  }
  // c(p) = (opening / 2) r(u) m(x_l).
  double opening_at(const Eigen::Vector3d& p) const {
    return 0.5 * opening_ * ramp(side_ * p[e_]) * profile(p[l_]);
  }

  Eigen::Vector3d h_;
  int n_, e_, l_;
  double side_, depth_, opening_, u_end_, lip_;
};

}  // namespace

std::unique_ptr<Deformer> make_incision(const Eigen::Vector3d& half_extents, Axis normal, Face from,
                                        double depth, double opening) {
  check_half_extents("incision", half_extents);
  if (normal == from.axis)
    throw Error(std::string("incision normal = ") + axis_name(normal) +
                ": must differ from the axis of `from` (" + face_name(from) + ")");
  if (from.side != 1 && from.side != -1)
    throw Error("incision from.side = " + std::to_string(from.side) + ": must be +1 or -1");
  const double depth_max = 2.0 * half_extents[static_cast<int>(from.axis)];
  if (!(depth > 0.0 && depth <= depth_max))
    throw Error("incision depth = " + shortest_text(depth) + ": must be in (0, 2 h_" +
                axis_name(from.axis) + " = " + shortest_text(depth_max) + "]");
  const double opening_max = 2.0 * half_extents[static_cast<int>(normal)];
  if (!(opening > 0.0 && opening < opening_max))
    throw Error("incision opening = " + shortest_text(opening) + ": must be in (0, 2 h_" +
                axis_name(normal) + " = " + shortest_text(opening_max) + ")");
  return std::make_unique<Incision>(half_extents, normal, from, depth, opening);
}

}  // namespace raywarp
