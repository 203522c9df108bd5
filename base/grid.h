// Dense, cell-centred 3D grids with the sampling rules of an OpenGL 3D texture.
//
// A grid covers the axis-aligned region [origin, origin + dims * spacing] of some frame (for
// raywarp's textures: a box's local frame, object units). Texels are boxes of sides `spacing`
// (per axis: cubes for the distance grid, the alpha map's and the bricks' grids; the
// deformation texture may have a different count along each axis); texel (i, j, k) has its
// centre at origin + (i + 0.5, j + 0.5, k + 0.5) * spacing (per axis), which is texture
// coordinate u = (i + 0.5) / n as in OpenGL. Storage is x fastest:
// index = i + dims.x * (j + dims.y * k).
// sample() is trilinear with clamp-to-edge, exactly what GL_LINEAR + GL_CLAMP_TO_EDGE computes
// (in double; a float grid gives a 1-vector: grid.sample(p).value()),
// so the CPU reference renderer and the shader read the same function (docs/conventions.md).
#pragma once
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace raywarp {

template <class T>
struct Grid3 {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();   // lower corner of the region
  Eigen::Vector3d spacing = Eigen::Vector3d::Ones();  // texel sides per axis, object units
  Eigen::Vector3i dims = Eigen::Vector3i::Zero();
  std::vector<T> data;

  Grid3() = default;
  Grid3(const Eigen::Vector3d& origin_, const Eigen::Vector3d& spacing_,
        const Eigen::Vector3i& dims_, const T& fill = T())
      : origin(origin_),
        spacing(spacing_),
        dims(dims_),
        data(static_cast<size_t>(dims_.x()) * dims_.y() * dims_.z(), fill) {}
  // Cubic texels of side `side`.
  Grid3(const Eigen::Vector3d& origin_, double side, const Eigen::Vector3i& dims_,
        const T& fill = T())
      : Grid3(origin_, Eigen::Vector3d::Constant(side), dims_, fill) {}

  size_t size() const { return data.size(); }
  size_t index(int i, int j, int k) const {
    return static_cast<size_t>(i) +
           static_cast<size_t>(dims.x()) * (j + static_cast<size_t>(dims.y()) * k);
  }
  T& at(int i, int j, int k) { return data[index(i, j, k)]; }
  const T& at(int i, int j, int k) const { return data[index(i, j, k)]; }
  Eigen::Vector3d texel_centre(int i, int j, int k) const {
    return origin + spacing.cwiseProduct(Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5));
  }
  // The centre of the interpolation cell whose lower corner is texel (i, j, k)'s centre.
  Eigen::Vector3d cell_centre(int i, int j, int k) const {
    return origin + spacing.cwiseProduct(Eigen::Vector3d(i + 1.0, j + 1.0, k + 1.0));
  }
  Eigen::Vector3d extent() const { return spacing.cwiseProduct(dims.cast<double>()); }
  // The side of a cubic texel (the grids make_grid_over lays out); for a grid with per-axis
  // spacing, its shortest side.
  double voxel() const { return spacing.minCoeff(); }
  Eigen::Vector3d upper() const { return origin + extent(); }

  // Trilinear interpolation with clamp-to-edge (GL_LINEAR, GL_CLAMP_TO_EDGE), computed in
  // double: float grids give double, Vector4f grids give Vector4d.
  auto sample(const Eigen::Vector3d& p) const {
    Eigen::Vector3d u = (p - origin).cwiseQuotient(spacing) - Eigen::Vector3d::Constant(0.5);
    int i0[3], i1[3];
    double w[3];
    for (int a = 0; a < 3; ++a) {
      double f = std::floor(u[a]);
      w[a] = u[a] - f;
      int base = static_cast<int>(std::clamp(f, -1.0, static_cast<double>(dims[a])));
      i0[a] = std::clamp(base, 0, dims[a] - 1);
      i1[a] = std::clamp(base + 1, 0, dims[a] - 1);
    }
    auto v = [this](int i, int j, int k) { return to_double(at(i, j, k)); };
    auto lerp = [](const auto& a, const auto& b, double t) {
      return (a * (1.0 - t) + b * t).eval();
    };
    auto c00 = lerp(v(i0[0], i0[1], i0[2]), v(i1[0], i0[1], i0[2]), w[0]);
    auto c10 = lerp(v(i0[0], i1[1], i0[2]), v(i1[0], i1[1], i0[2]), w[0]);
    auto c01 = lerp(v(i0[0], i0[1], i1[2]), v(i1[0], i0[1], i1[2]), w[0]);
    auto c11 = lerp(v(i0[0], i1[1], i1[2]), v(i1[0], i1[1], i1[2]), w[0]);
    return lerp(lerp(c00, c10, w[1]), lerp(c01, c11, w[1]), w[2]);
  }

 private:
  static Eigen::Matrix<double, 1, 1> to_double(float x) { return Eigen::Matrix<double, 1, 1>(x); }
  template <int N>
  static Eigen::Matrix<double, N, 1> to_double(const Eigen::Matrix<float, N, 1>& x) {
    return x.template cast<double>();
  }
};

// Cubic texels over `lower..upper` with `resolution` texels along the longest side; the region
// is grown symmetrically to a whole number of texels on the other sides.
template <class T>
Grid3<T> make_grid_over(const Eigen::Vector3d& lower, const Eigen::Vector3d& upper, int resolution,
                        const T& fill = T()) {
  Eigen::Vector3d ext = (upper - lower).cwiseMax(1e-12);
  double spacing = ext.maxCoeff() / resolution;
  Eigen::Vector3i dims;
  for (int a = 0; a < 3; ++a)
    dims[a] = std::max(1, static_cast<int>(std::ceil(ext[a] / spacing - 1e-9)));
  Eigen::Vector3d centre = 0.5 * (lower + upper);
  Eigen::Vector3d origin = centre - 0.5 * spacing * dims.cast<double>();
  return Grid3<T>(origin, spacing, dims, fill);
}

// `counts` texels along the axes of `lower..upper` (each at least 1): texel sides differ per axis.
template <class T>
Grid3<T> make_grid_with_counts(const Eigen::Vector3d& lower, const Eigen::Vector3d& upper,
                               const Eigen::Vector3i& counts, const T& fill = T()) {
  const Eigen::Vector3i dims = counts.cwiseMax(1);
  const Eigen::Vector3d spacing =
      (upper - lower).cwiseMax(1e-12).cwiseQuotient(dims.cast<double>());
  return Grid3<T>(lower, spacing, dims, fill);
}

}  // namespace raywarp
