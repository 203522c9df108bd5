#include "library/textures.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <vector>

#include "library/cylindrical.h"

namespace raywarp {

const char* cut_mode_name(CutMode mode) {
  switch (mode) {
    case CutMode::Hollow:
      return "hollow";
    case CutMode::Solid:
      return "solid";
    case CutMode::ThickShell:
      break;
  }
  return "thick_shell";
}

double implicit_spacing(const BoxTextures& b) {
  return b.uses_depth_cube ? b.depth_cube.spacing : b.sdf.grid.voxel();
}

double implicit_background(const BoxTextures& b) {
  return b.uses_depth_cube ? b.depth_cube.far_depth : b.sdf.background;
}

std::optional<Eigen::Vector3d> texture_preimage(const BoxTextures& b, const Eigen::Vector3d& p) {
  const Eigen::Vector3d q = b.box.to_local(p);
  if (b.moves_nothing) return b.box.contains_local(q) ? std::optional(p) : std::nullopt;
  if (b.cylindrical()) {  // w = 1 wherever D holds a preimage; the box decides
    const Eigen::Vector4d d = cylindrical_displacement(b.deformation.grid, b.cylindrical_axis, q);
    const Eigen::Vector3d local = q + d.head<3>();
    if (!(d[3] >= 0.5) || !d.allFinite() || !b.box.contains_local(local)) return std::nullopt;
    return b.box.to_object(local);
  }
  const Eigen::Vector3d m = (b.texture_map * q.homogeneous()).head<3>();
  const Grid3<Eigen::Vector4f>& g = b.deformation.grid;
  const bool mapped = !b.texture_map.isIdentity(0.0);
  const bool in_grid = Eigen::AlignedBox3d(g.origin, g.upper()).contains(m);
  if (g.data.empty() || (!in_grid && !mapped)) return std::nullopt;
  const Eigen::Vector4d d = g.sample(m);
  if (!d.allFinite()) return std::nullopt;
  // Read through M, a texel beyond the box holding the identity is the identity (as the ray
  // caster's sample_at): the box decides.
  const bool mapped_out =
      mapped && !b.box.contains_local(m) && d.head<3>().norm() < kSeamVoxels * implicit_spacing(b);
  if (!((in_grid && d[3] >= 0.5) || mapped_out)) return std::nullopt;
  const Eigen::Vector3d local = q + d.head<3>();
  if (mapped_out && !b.box.contains_local(local)) return std::nullopt;
  return b.box.to_object(local);
}

double implicit_value(const BoxTextures& b, const Eigen::Vector3d& p) {
  return b.uses_depth_cube ? depth_cube_value(b.depth_cube, p) : b.sdf.grid.sample(p).value();
}

Eigen::AlignedBox3d ray_cast_region(const BoxTextures& b) {
  if (!b.region.isEmpty()) return b.region;
  return Eigen::AlignedBox3d(b.deformation.grid.origin, b.deformation.grid.upper());
}

double cut_margin(const BoxTextures& b) {
  if (!b.has_cut) return 0.0;
  // The diagonal of an alpha cell plus half that of a D cell.
  return alpha_step(b).norm() + 0.5 * deformation_step(b).norm();
}

namespace {
Eigen::Vector3d difference_step(const Eigen::Vector3d& spacing, bool cylindrical) {
  if (!cylindrical) return spacing;
  return Eigen::Vector3d::Constant(std::min(spacing[1], spacing[2]));
}
}  // namespace

Eigen::Vector3d deformation_step(const BoxTextures& b) {
  return difference_step(b.deformation.grid.spacing, b.cylindrical() && !b.moves_nothing);
}

Eigen::Vector3d alpha_step(const BoxTextures& b) {
  return difference_step(b.alpha.grid.spacing, b.cylindrical());
}

float round_to_half(float x) {
  if (!std::isfinite(x) || x == 0.0f) return x;
  constexpr float kLargest = 65504.0f;
  if (std::abs(x) >= kLargest) return std::copysign(kLargest, x);
  int e = 0;
  std::frexp(x, &e);  // |x| in [2^(e-1), 2^e)
  // 11 significant bits; below the smallest normal half (2^-14) the spacing stays 2^-24.
  const float ulp = std::ldexp(1.0f, std::max(e, -13) - 11);
  const float r = std::nearbyint(x / ulp) * ulp;  // the default rounding mode: ties to even
  return std::abs(r) > kLargest ? std::copysign(kLargest, r) : r;
}

void round_textures_to_half(BoxTextures& b) {
  for (float& v : b.sdf.grid.data) v = round_to_half(v);
  b.sdf.background = round_to_half(b.sdf.background);
  for (DepthMap& m : b.depth_cube.maps)
    for (float& v : m.depth) v = round_to_half(v);
  b.depth_cube.far_depth = round_to_half(b.depth_cube.far_depth);
  for (Eigen::Vector4f& v : b.deformation.grid.data)
    for (int c = 0; c < 4; ++c) v[c] = round_to_half(v[c]);
  for (float& v : b.alpha.grid.data) v = round_to_half(v);
  b.half_precision = true;
}

bool skipping_pays(const BoxTextures& b, double step_voxels, bool requested) {
  if (!requested || b.cylindrical()) return false;
  if (b.has_cut) return true;
  if (b.uses_depth_cube) return false;
  return b.sdf.background / (std::sqrt(3.0) * b.lipschitz) > step_voxels * b.sdf.grid.voxel();
}

namespace {

// Rounding of float texels and of the GPU's float arithmetic is far below this relative margin.
constexpr double kBoundMargin = 1.0 + 1e-4;

// Calls cell(i, j, k) for every interpolation cell of a grid: the cell between texel centres
// (i, j, k) and (i + 1, j + 1, k + 1), with the upper index clamped on an axis of one texel.
template <class F>
void for_each_cell(const Eigen::Vector3i& dims, F&& cell) {
  const Eigen::Vector3i cells = (dims.array() - 1).max(1);
  for (int k = 0; k < cells.z(); ++k)
    for (int j = 0; j < cells.y(); ++j)
      for (int i = 0; i < cells.x(); ++i) cell(i, j, k);
}

// Calls edge(a, e, lo, hi) for the four edges e along axis a of cell (i, j, k) of a grid of
// `dims` texels, for each axis a; lo and hi are the texel indices at the edge's ends (equal on
// an axis of one texel).
template <class F>
void for_each_cell_edge(const Eigen::Vector3i& n, int i, int j, int k, F&& edge) {
  const int is[2] = {i, std::min(i + 1, n.x() - 1)}, js[2] = {j, std::min(j + 1, n.y() - 1)},
            ks[2] = {k, std::min(k + 1, n.z() - 1)};
  const int* idx[3] = {is, js, ks};
  for (int a = 0; a < 3; ++a) {
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    for (int e = 0; e < 4; ++e) {
      int lo[3], hi[3];
      lo[a] = idx[a][0];
      hi[a] = idx[a][1];
      lo[b] = hi[b] = idx[b][e & 1];
      lo[c] = hi[c] = idx[c][e >> 1];
      edge(a, e, lo, hi);
    }
  }
}

// |grad| bound of a scalar grid's interpolant over cell (i, j, k) (see interpolant_lipschitz).
double cell_slope(const Grid3<float>& grid, int i, int j, int k) {
  double largest[3] = {0.0, 0.0, 0.0};
  for_each_cell_edge(grid.dims, i, j, k, [&](int a, int, const int* lo, const int* hi) {
    largest[a] = std::max(largest[a], std::abs(double(grid.at(hi[0], hi[1], hi[2])) -
                                               double(grid.at(lo[0], lo[1], lo[2]))));
  });
  const Eigen::Vector3d slope =
      Eigen::Vector3d(largest[0], largest[1], largest[2]).cwiseQuotient(grid.spacing);
  return slope.norm() * kBoundMargin;
}

// Bricks of `cells_per_brick`^3 cells over a grid of `dims` texels: the grid of their bounds
// (origin at the first texel centre), each the largest `per_cell` of its cells.
// Polls `interrupter` every 2^14 cells of `total` (a few milliseconds of work).
class CellPoller {
 public:
  CellPoller(Interrupter* interrupter, const char* stage, const Eigen::Vector3i& dims)
      : interrupter_(interrupter),
        stage_(stage),
        total_(double((dims.array() - 1).max(1).prod())) {}
  void operator()() {
    if (interrupter_ && (++count_ & 0x3fff) == 0)
      interrupter_->poll(stage_, double(count_) / total_);
  }

 private:
  Interrupter* interrupter_;
  const char* stage_;
  double total_;
  long count_ = 0;
};

template <class Grid, class F>
Grid3<float> brick_maxima(const Grid& grid, int cells_per_brick, F&& per_cell,
                          Interrupter* interrupter) {
  const Eigen::Vector3i cells = (grid.dims.array() - 1).max(1);
  const Eigen::Vector3i nb = (cells.array() + cells_per_brick - 1) / cells_per_brick;
  Grid3<float> raw(grid.origin + 0.5 * grid.spacing, grid.spacing * cells_per_brick, nb, 0.0f);
  CellPoller poll(interrupter, "step bounds", grid.dims);
  for_each_cell(grid.dims, [&](int i, int j, int k) {
    poll();
    float& brick = raw.at(i / cells_per_brick, j / cells_per_brick, k / cells_per_brick);
    brick = std::max(brick, static_cast<float>(per_cell(i, j, k)));
  });
  return raw;
}

// Each brick's bound raised to the largest over it and its 26 neighbours, and to at least 1.
Grid3<float> dilate_at_least_one(const Grid3<float>& raw) {
  Grid3<float> out = raw;
  const Eigen::Vector3i& nb = raw.dims;
  for (int k = 0; k < nb.z(); ++k)
    for (int j = 0; j < nb.y(); ++j)
      for (int i = 0; i < nb.x(); ++i) {
        float m = 1.0f;
        for (int dk = -1; dk <= 1; ++dk)
          for (int dj = -1; dj <= 1; ++dj)
            for (int di = -1; di <= 1; ++di) {
              const int x = i + di, y = j + dj, z = k + dk;
              if (x >= 0 && y >= 0 && z >= 0 && x < nb.x() && y < nb.y() && z < nb.z())
                m = std::max(m, raw.at(x, y, z));
            }
        out.at(i, j, k) = m;
      }
  return out;
}

}  // namespace

double interpolant_lipschitz(const Grid3<float>& grid, Interrupter* interrupter) {
  if (grid.data.empty()) return 0.0;
  double worst = 0.0;
  CellPoller poll(interrupter, "step bounds", grid.dims);
  for_each_cell(grid.dims, [&](int i, int j, int k) {
    poll();
    worst = std::max(worst, cell_slope(grid, i, j, k));
  });
  return worst;
}

StepBounds bake_step_bounds(const DistanceGrid& sdf, const DeformationTexture& deformation,
                            int brick_cells, Interrupter* interrupter) {
  StepBounds out;
  out.brick_cells = std::max(1, brick_cells);
  const Grid3<Eigen::Vector4f>& d = deformation.grid;
  if (d.data.empty() || sdf.grid.data.empty()) return out;
  const Grid3<float> f_raw = brick_maxima(
      sdf.grid, out.brick_cells, [&](int i, int j, int k) { return cell_slope(sdf.grid, i, j, k); },
      interrupter);
  out.sdf_lipschitz = *std::max_element(f_raw.data.begin(), f_raw.data.end());
  out.sdf_bricks = dilate_at_least_one(f_raw);
  Grid3<float> validity(d.origin, d.spacing, d.dims);
  for (size_t i = 0; i < d.data.size(); ++i) validity.data[i] = d.data[i].w();
  out.validity_lipschitz = interpolant_lipschitz(validity, interrupter);

  // Per cell: in a cell, column a of J_D is a bilinear blend of the cell's four a-edge
  // differences (/ spacing). With J0 their mean per column, ||I + J(x)|| <= ||I + J0|| +
  // ||J(x) - J0||_F, and |col_a(x) - col_a0| is at most the largest over the four edges (a norm
  // is convex).
  const Eigen::Vector3i& n = d.dims;
  auto cell_norm = [&](int i, int j, int k) {
    Eigen::Vector3d edges[3][4];
    Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
    for_each_cell_edge(n, i, j, k, [&](int a, int e, const int* lo, const int* hi) {
      // On an axis of one texel lo = hi: D has no slope along it.
      edges[a][e] = (d.at(hi[0], hi[1], hi[2]).head<3>().cast<double>() -
                     d.at(lo[0], lo[1], lo[2]).head<3>().cast<double>()) /
                    d.spacing[a];
      m.col(a) += 0.25 * edges[a][e];
    });
    double deviation = 0.0;
    const int ijk[3] = {i, j, k};
    for (int a = 0; a < 3; ++a) {
      const Eigen::Vector3d mean = m.col(a) - Eigen::Vector3d::Unit(a);
      double worst = 0.0;
      for (int e = 0; e < 4; ++e) worst = std::max(worst, (edges[a][e] - mean).norm());
      // Beyond the outer texel centres clamp-to-edge holds D constant along a: there column a of
      // J_D is 0, which need not lie between the edges, so a boundary cell's bound covers it.
      if (ijk[a] == 0 || ijk[a] >= n[a] - 2) worst = std::max(worst, mean.norm());
      deviation += worst * worst;
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
    eig.computeDirect(m.transpose() * m, Eigen::EigenvaluesOnly);
    const double norm = std::sqrt(std::max(eig.eigenvalues().maxCoeff(), 0.0));
    return (norm + std::sqrt(deviation)) * kBoundMargin;
  };
  out.bricks = dilate_at_least_one(brick_maxima(d, out.brick_cells, cell_norm, interrupter));
  return out;
}

namespace {

float brick_at(const Grid3<float>& bricks, const Eigen::Vector3d& p) {
  Eigen::Vector3i b;
  for (int a = 0; a < 3; ++a)
    b[a] = std::clamp(static_cast<int>(std::floor(
                          std::clamp((p[a] - bricks.origin[a]) / bricks.spacing[a], -1.0, 1e9))),
                      0, bricks.dims[a] - 1);
  return bricks.at(b.x(), b.y(), b.z());
}

}  // namespace

StepBound step_bound_at(const StepBounds& bounds, const Eigen::Vector3d& p_def,
                        const Eigen::Vector3d& p) {
  const double l_d = brick_at(bounds.bricks, p_def);
  StepBound out;
  out.lipschitz = brick_at(bounds.sdf_bricks, p) * l_d;
  out.longest = std::min(bounds.bricks.voxel(), bounds.sdf_bricks.voxel() / l_d);
  return out;
}

bool traces_bounded(Sampling sampling, bool has_cut, bool moves_nothing) {
  return sampling == Sampling::Bounded && !has_cut && !moves_nothing;
}

}  // namespace raywarp
