#include "deformers/deformer.h"

#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <exception>
#include <string>
#include <thread>
#include <vector>

#include "library/error.h"

namespace raywarp {

std::string shortest_text(double x) {
  char buf[32];
  const auto end = std::to_chars(buf, buf + sizeof buf, x).ptr;
  return std::string(buf, end);
}

void check_half_extents(const char* what, const Eigen::Vector3d& half_extents) {
  for (int i = 0; i < 3; ++i)
    if (!(half_extents[i] > 0.0) || !std::isfinite(half_extents[i]))
      throw Error(std::string(what) + " half_extents[" + std::to_string(i) +
                  "] = " + shortest_text(half_extents[i]) + ": must be > 0 and finite");
}

char axis_name(Axis a) {
  switch (a) {
    case Axis::X:
      return 'x';
    case Axis::Y:
      return 'y';
    case Axis::Z:
      break;
  }
  return 'z';
}

std::string face_name(Face f) { return std::string(f.side > 0 ? "+" : "-") + axis_name(f.axis); }

FoldReport measure_folds(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                         int samples_per_axis) {
  if (samples_per_axis < 1)
    throw Error("measure_folds: samples_per_axis = " + std::to_string(samples_per_axis) +
                ": must be >= 1");
  const int n = samples_per_axis;
  const Eigen::Vector3d cell = 2.0 * half_extents / n;
  long folded = 0;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const Eigen::Vector3d p = -half_extents + cell.cwiseProduct(Eigen::Vector3d(i, j, k) +
                                                                    Eigen::Vector3d::Constant(0.5));
        if (deformer.jacobian(p).determinant() <= 0.0) ++folded;
      }
  FoldReport report;
  report.box_volume = 8.0 * half_extents.prod();
  report.folded_volume = static_cast<double>(folded) * cell.prod();
  return report;
}

namespace {

// Bounds of F over an (n + 1) x (n + 1) lattice of nodes on each of the six faces of the box
// (edges and corners included).
Eigen::AlignedBox3d face_lattice_bounds(const Deformer& deformer, const Eigen::Vector3d& h, int n) {
  Eigen::AlignedBox3d bounds;
  for (int normal = 0; normal < 3; ++normal) {
    const int u = (normal + 1) % 3, v = (normal + 2) % 3;
    for (double side : {-1.0, 1.0})
      for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
          Eigen::Vector3d p;
          p[normal] = side * h[normal];
          p[u] = h[u] * (2.0 * i / n - 1.0);
          p[v] = h[v] * (2.0 * j / n - 1.0);
          bounds.extend(deformer.forward(p));
        }
  }
  return bounds;
}

// Runs body(k) for k in [0, slices) on all hardware threads (a slice goes to one thread only), and
// rethrows the first exception a body threw.
template <class Body>
void for_each_slice(int slices, const Body& body) {
  std::atomic<int> next_slice{0};
  const int threads =
      std::clamp(static_cast<int>(std::thread::hardware_concurrency()), 1, std::max(slices, 1));
  std::vector<std::thread> workers;
  std::vector<std::exception_ptr> errors(threads);
  for (int t = 0; t < threads; ++t)
    workers.emplace_back([&, t]() {
      try {
        for (int k = next_slice++; k < slices; k = next_slice++) body(k);
      } catch (...) {
        errors[t] = std::current_exception();
        next_slice = slices;
      }
    });
  for (std::thread& worker : workers) worker.join();
  for (const std::exception_ptr& error : errors)
    if (error) std::rethrow_exception(error);
}

}  // namespace

// F is continuous, so the boundary of F(box) lies in F(boundary of box) and the extremes of F(box)
// are reached on the faces. Between lattice nodes F bulges by up to (1/8) spacing^2 max|F''|
// (a chord's sagitta), which grows with the angle; worse, a twist of many turns can alias with the
// lattice (16 turns over 64 intervals visit 4 angles per edge: a square section's corners then
// reach 0.71 of their radius).
// So the lattice is refined by halves until the bounds grow by less than 1e-4 of their diagonal,
// which leaves about a third of that unseen (the sagitta shrinks 4x per halving), or until 1024
// intervals. A lattice that aliases at two successive levels (64 whole turns) still fools it; the
// one-texel pad of bake_deformation absorbs the rest.
Eigen::AlignedBox3d deformed_bounds(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                                    double pad) {
  constexpr int kFirstIntervals = 64, kMaxIntervals = 1024;
  Eigen::AlignedBox3d bounds = face_lattice_bounds(deformer, half_extents, kFirstIntervals);
  for (int n = 2 * kFirstIntervals; n <= kMaxIntervals; n *= 2) {
    const Eigen::AlignedBox3d finer = face_lattice_bounds(deformer, half_extents, n);
    const double growth =
        std::max((bounds.min() - finer.min()).maxCoeff(), (finer.max() - bounds.max()).maxCoeff());
    bounds.extend(finer);
    if (growth <= 1e-4 * bounds.diagonal().norm()) break;
  }
  // A cut makes F discontinuous: the images of the cut surface (inside the box) may reach beyond
  // those of the faces (a peeled flap's underside is its outermost layer). Sample the volume too.
  if (deformer.has_cut()) {
    constexpr int n = 96;
    for (int k = 0; k <= n; ++k)
      for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
          const Eigen::Vector3d f(2.0 * i / n - 1.0, 2.0 * j / n - 1.0, 2.0 * k / n - 1.0);
          bounds.extend(deformer.forward(f.cwiseProduct(half_extents)));
        }
  }
  bounds.min().array() -= pad;
  bounds.max().array() += pad;
  return bounds;
}

DeformationTexture bake_deformation(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                                    int resolution, bool centre_on_lower_faces) {
  if (resolution < 1)
    throw Error("bake_deformation: resolution = " + std::to_string(resolution) + ": must be >= 1");
  const auto start = std::chrono::steady_clock::now();
  Eigen::AlignedBox3d bounds = deformed_bounds(deformer, half_extents);
  const double pad = bounds.sizes().maxCoeff() / resolution;
  bounds.min().array() -= pad;
  bounds.max().array() += pad;

  DeformationTexture texture;
  Grid3<Eigen::Vector4f>& grid = texture.grid;
  grid = make_grid_over(bounds.min(), bounds.max(), resolution, Eigen::Vector4f::Zero().eval());
  if (centre_on_lower_faces) {
    for (int a = 0; a < 3; ++a) {
      const double k = (-half_extents[a] - grid.origin[a]) / grid.spacing - 0.5;
      const double shift = k - std::floor(k);  // a centre lies `shift` texels above -h
      grid.origin[a] += (shift - 1.0) * grid.spacing;
      grid.dims[a] += 1;
    }
    grid.data.assign(static_cast<size_t>(grid.dims.x()) * grid.dims.y() * grid.dims.z(),
                     Eigen::Vector4f::Zero());
  }

  std::atomic<bool> all_finite{true};
  for_each_slice(grid.dims.z(), [&](int k) {
    for (int j = 0; j < grid.dims.y(); ++j)
      for (int i = 0; i < grid.dims.x(); ++i) {
        const Eigen::Vector3d p_def = grid.texel_centre(i, j, k);
        const Eigen::Vector3d p = deformer.inverse(p_def);
        const bool inside = (p.cwiseAbs().array() <= half_extents.array()).all();
        Eigen::Vector4f texel;
        texel << (p - p_def).cast<float>(), inside ? 1.0f : 0.0f;
        if (!texel.allFinite()) all_finite = false;
        grid.at(i, j, k) = texel;
      }
  });
  if (!all_finite)
    throw Error("bake_deformation: " + deformer.describe() +
                ": the inverse displacement is not finite at some texels");

  texture.bake_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return texture;
}

AlphaMap bake_alpha(const Deformer& deformer, const Eigen::AlignedBox3d& region, int resolution) {
  if (!deformer.has_cut()) throw Error("bake_alpha: " + deformer.describe() + " has no cut");
  if (resolution < 1)
    throw Error("bake_alpha: resolution = " + std::to_string(resolution) + ": must be >= 1");
  const auto start = std::chrono::steady_clock::now();
  AlphaMap map;
  Grid3<float>& grid = map.grid;
  grid = make_grid_over(region.min(), region.max(), resolution, 0.0f);
  std::atomic<bool> all_finite{true};
  for_each_slice(grid.dims.z(), [&](int k) {
    for (int j = 0; j < grid.dims.y(); ++j)
      for (int i = 0; i < grid.dims.x(); ++i) {
        const float a = static_cast<float>(deformer.alpha(grid.texel_centre(i, j, k)));
        if (!std::isfinite(a)) all_finite = false;
        grid.at(i, j, k) = a;
      }
  });
  if (!all_finite)
    throw Error("bake_alpha: " + deformer.describe() +
                ": the alpha map is not finite at some texels");
  map.bake_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return map;
}

double displacement_lipschitz(const Deformer& deformer, const DeformationTexture& texture) {
  const Grid3<Eigen::Vector4f>& grid = texture.grid;
  const Eigen::Vector3i cells = (grid.dims - Eigen::Vector3i::Ones()).cwiseMax(0);
  std::vector<double> slice_max(std::max(cells.z(), 1), 0.0);
  const bool cut = deformer.has_cut();
  for_each_slice(cells.z(), [&](int k) {
    double worst = 0.0;
    for (int j = 0; j < cells.y(); ++j)
      for (int i = 0; i < cells.x(); ++i) {
        const Eigen::Vector3d centre =
            grid.texel_centre(i, j, k) + Eigen::Vector3d::Constant(0.5 * grid.spacing);
        if (cut && deformer.alpha(centre) > 0.0) continue;
        double sum = 0.0;
        for (int a = 0; a < 3; ++a) {
          const int u = (a + 1) % 3, v = (a + 2) % 3;
          double m = 0.0;
          for (int du = 0; du < 2; ++du)
            for (int dv = 0; dv < 2; ++dv) {
              Eigen::Vector3i c0(i, j, k);
              c0[u] += du;
              c0[v] += dv;
              Eigen::Vector3i c1 = c0;
              c1[a] += 1;
              const Eigen::Vector3f diff = grid.at(c1.x(), c1.y(), c1.z()).head<3>() -
                                           grid.at(c0.x(), c0.y(), c0.z()).head<3>();
              m = std::max(m, static_cast<double>(diff.norm()));
            }
          m /= grid.spacing;
          sum += m * m;
        }
        worst = std::max(worst, std::sqrt(sum));
      }
    slice_max[k] = worst;
  });
  double worst = 0.0;
  for (double w : slice_max) worst = std::max(worst, w);
  // Float rounding of the texels (relative 2^-24 of |D|, divided by the spacing) is far below
  // this margin.
  return (1.0 + worst) * (1.0 + 1e-5);
}

double deformation_texture_error(const Deformer& deformer, const DeformationTexture& texture,
                                 int stride) {
  const Grid3<Eigen::Vector4f>& grid = texture.grid;
  stride = std::max(stride, 1);
  const int slices = std::max(0, (grid.dims.z() - 1 + stride - 1) / stride);
  std::vector<double> slice_max(std::max(slices, 1), 0.0);
  const bool cut = deformer.has_cut();
  for_each_slice(slices, [&](int ks) {
    const int k = ks * stride;
    if (k + 1 >= grid.dims.z()) return;
    double worst = 0.0;
    for (int j = 0; j + 1 < grid.dims.y(); j += stride)
      for (int i = 0; i + 1 < grid.dims.x(); i += stride) {
        bool valid = true;
        for (int c = 0; c < 8 && valid; ++c)
          valid = grid.at(i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2)).w() >= 0.5f;
        if (!valid) continue;
        const Eigen::Vector3d centre =
            grid.texel_centre(i, j, k) + Eigen::Vector3d::Constant(0.5 * grid.spacing);
        if (cut && deformer.alpha(centre) > -std::sqrt(3.0) * grid.spacing) continue;
        const Eigen::Vector3d exact = deformer.inverse(centre) - centre;
        worst = std::max(worst, (grid.sample(centre).head<3>() - exact).norm());
      }
    slice_max[ks] = worst;
  });
  double worst = 0.0;
  for (double w : slice_max) worst = std::max(worst, w);
  return worst;
}

}  // namespace raywarp
