// Generalised winding number of a triangle mesh (Jacobson et al. 2013), evaluated fast and
// hierarchically after Barill et al. 2018, "Fast winding numbers for soups and clouds":
// a bounding-volume tree whose nodes carry the first-order (dipole) expansion of their
// triangles; a node far enough from the query (distance > beta * radius) is taken by its
// expansion, a near one is opened, leaves are summed exactly (solid angle, Van Oosterom &
// Strackee 1983). w ~ 1 inside a closed outward-oriented mesh, ~0 outside, and degrades
// gracefully on holes and several shells: inside is w > 0.5.
#pragma once
#include <Eigen/Core>
#include <memory>
#include <vector>

#include "library/mesh.h"

namespace raywarp {

class WindingNumber {
 public:
  explicit WindingNumber(const Mesh& mesh, double beta = 2.0);
  ~WindingNumber();
  WindingNumber(WindingNumber&&) noexcept;
  double operator()(const Eigen::Vector3d& q) const;  // hierarchical
  double exact(const Eigen::Vector3d& q) const;       // sum over all triangles (for tests)

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace raywarp
