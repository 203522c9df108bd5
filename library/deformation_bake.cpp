#include "library/deformation_bake.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "base/error.h"
#include "base/parallel.h"
#include "library/refine_layout.h"

namespace raywarp {

namespace {

// D at the texel centres of `grid` (its texels already laid out).
void bake_on_grid(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                  Grid3<Eigen::Vector4f>& grid, Interrupter* interrupter) {
  std::atomic<bool> all_finite{true};
  // One row of texels per index: a control-point deformer's Newton iterations make a slice too
  // long between polls.
  const int rows = grid.dims.y();
  parallel_for(
      long(rows) * grid.dims.z(),
      [&](long row) {
        const int j = int(row % rows), k = int(row / rows);
        for (int i = 0; i < grid.dims.x(); ++i) {
          const Eigen::Vector3d p_def = grid.texel_centre(i, j, k);
          const Eigen::Vector3d p = deformer.inverse(p_def);
          const bool inside = (p.cwiseAbs().array() <= half_extents.array()).all();
          Eigen::Vector4f texel;
          texel << (p - p_def).cast<float>(), inside ? 1.0f : 0.0f;
          if (!texel.allFinite()) all_finite = false;
          grid.at(i, j, k) = texel;
        }
      },
      interrupter, "deformation texture");
  if (!all_finite)
    throw Error("bake_deformation: " + deformer.describe() +
                ": the inverse displacement is not finite at some texels");
}

// Shifts `grid` down by less than a texel along each axis, and grows it by one, so that texel
// centres lie on the planes -h (see bake_deformation).
void centre_on_lower_faces(Grid3<Eigen::Vector4f>& grid, const Eigen::Vector3d& half_extents) {
  for (int a = 0; a < 3; ++a) {
    const double k = (-half_extents[a] - grid.origin[a]) / grid.spacing[a] - 0.5;
    const double shift = k - std::floor(k);  // a centre lies `shift` texels above -h
    grid.origin[a] += (shift - 1.0) * grid.spacing[a];
    grid.dims[a] += 1;
  }
  grid.data.assign(static_cast<size_t>(grid.dims.x()) * grid.dims.y() * grid.dims.z(),
                   Eigen::Vector4f::Zero());
}

DeformationTexture bake_layout(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                               Grid3<Eigen::Vector4f> grid, bool centred,
                               Interrupter* interrupter) {
  const auto start = std::chrono::steady_clock::now();
  if (centred) centre_on_lower_faces(grid, half_extents);
  DeformationTexture texture;
  texture.grid = std::move(grid);
  bake_on_grid(deformer, half_extents, texture.grid, interrupter);
  texture.bake_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return texture;
}

using layout::kMaxCount;

}  // namespace

Grid3<Eigen::Vector4f> deformation_layout(const Deformer& deformer,
                                          const Eigen::Vector3d& half_extents, int resolution) {
  if (resolution < 1)
    throw Error("bake_deformation: resolution = " + std::to_string(resolution) + ": must be >= 1");
  Eigen::AlignedBox3d bounds = deformed_bounds(deformer, half_extents);
  const double pad = bounds.sizes().maxCoeff() / resolution;
  bounds.min().array() -= pad;
  bounds.max().array() += pad;
  return make_grid_over(bounds.min(), bounds.max(), resolution, Eigen::Vector4f::Zero().eval());
}

Grid3<Eigen::Vector4f> deformation_layout(const Deformer& deformer,
                                          const Eigen::Vector3d& half_extents,
                                          const Eigen::Vector3i& counts) {
  if ((counts.array() < 3).any())
    throw Error("bake_deformation: texel counts must be >= 3 per axis");
  const Eigen::AlignedBox3d bounds = deformed_bounds(deformer, half_extents);
  // One texel of padding on each side: spacing_a = extent_a / (n_a - 2).
  const Eigen::Vector3d spacing =
      bounds.sizes().cwiseMax(1e-12).cwiseQuotient((counts.array() - 2).cast<double>().matrix());
  return Grid3<Eigen::Vector4f>(bounds.min() - spacing, spacing, counts, Eigen::Vector4f::Zero());
}

DeformationTexture bake_deformation(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                                    int resolution, bool centred, Interrupter* interrupter) {
  return bake_layout(deformer, half_extents, deformation_layout(deformer, half_extents, resolution),
                     centred, interrupter);
}

DeformationTexture bake_deformation(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                                    const Eigen::Vector3i& counts, bool centred,
                                    Interrupter* interrupter) {
  return bake_layout(deformer, half_extents, deformation_layout(deformer, half_extents, counts),
                     centred, interrupter);
}

Eigen::Vector3d axis_interpolation_errors(const Deformer& deformer,
                                          const DeformationTexture& texture,
                                          Interrupter* interrupter) {
  const Grid3<Eigen::Vector4f>& grid = texture.grid;
  const bool cut = deformer.has_cut();
  const double reach = 2.0 * grid.spacing.norm();  // texels this near the cut are skipped
  const int slices = grid.dims.z();
  std::vector<Eigen::Vector3d> slice_max(std::max(slices, 1), Eigen::Vector3d::Zero());
  parallel_for(
      slices,
      [&](long ks) {
        const int k = int(ks);
        Eigen::Vector3d worst = Eigen::Vector3d::Zero();
        for (int j = 0; j < grid.dims.y(); ++j)
          for (int i = 0; i < grid.dims.x(); ++i) {
            const Eigen::Vector4f& c = grid.at(i, j, k);
            if (!(c.w() >= 0.5f)) continue;
            bool near_cut_known = false, near_cut = false;
            const int ijk[3] = {i, j, k};
            for (int a = 0; a < 3; ++a) {
              if (ijk[a] == 0 || ijk[a] + 1 >= grid.dims[a]) continue;
              int lo[3] = {i, j, k}, hi[3] = {i, j, k};
              --lo[a];
              ++hi[a];
              const Eigen::Vector4f& l = grid.at(lo[0], lo[1], lo[2]);
              const Eigen::Vector4f& h = grid.at(hi[0], hi[1], hi[2]);
              if (!(l.w() >= 0.5f) || !(h.w() >= 0.5f)) continue;
              if (cut && !near_cut_known) {
                near_cut = deformer.alpha(grid.texel_centre(i, j, k)) > -reach;
                near_cut_known = true;
              }
              if (near_cut) break;
              const double second = (h.head<3>().cast<double>() - 2.0 * c.head<3>().cast<double>() +
                                     l.head<3>().cast<double>())
                                        .norm();
              // Linear interpolation between two texels misses f by about h^2 f'' / 8 halfway.
              worst[a] = std::max(worst[a], second / 8.0);
            }
          }
        slice_max[k] = worst;
      },
      interrupter, "deformation texture: error per axis");
  Eigen::Vector3d worst = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& w : slice_max) worst = worst.cwiseMax(w);
  return worst;
}

Eigen::Vector3i counts_for_error(const Eigen::Vector3i& counts, const Eigen::Vector3d& errors,
                                 double target, const Eigen::Vector3i& floor) {
  // The error along axis a falls as 1 / n_a^2: c_a = e_a n_a^2. The fewest texels (the least
  // product of the counts) with sum_a c_a / n_a^2 <= target share the target equally among the
  // axes that are not held at their floor (a Lagrange multiplier gives equal terms).
  Eigen::Vector3d c;
  for (int a = 0; a < 3; ++a) c[a] = errors[a] * double(counts[a]) * double(counts[a]);
  bool fixed[3] = {false, false, false};
  Eigen::Vector3d n = floor.cast<double>();
  for (int round = 0; round < 3; ++round) {
    double left = target;
    int free = 0;
    for (int a = 0; a < 3; ++a) {
      if (fixed[a])
        left -= c[a] / (n[a] * n[a]);
      else
        ++free;
    }
    if (free == 0) break;
    const double share = std::max(left, 1e-3 * target) / free;
    bool changed = false;
    for (int a = 0; a < 3; ++a) {
      if (fixed[a]) continue;
      n[a] = std::sqrt(c[a] / share);
      if (n[a] <= floor[a]) {
        n[a] = floor[a];
        fixed[a] = true;
        changed = true;
      }
    }
    if (!changed) break;
  }
  Eigen::Vector3i out;
  for (int a = 0; a < 3; ++a)
    out[a] = static_cast<int>(std::clamp(std::ceil(n[a]), double(floor[a]), double(kMaxCount)));
  return out;
}

AutoDeformation bake_deformation_auto(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                                      double target, std::uint64_t budget_bytes,
                                      int floor_resolution, bool centred,
                                      Interrupter* interrupter) {
  AutoDeformation out;
  out.choice = layout::start_choice(target, budget_bytes);
  const auto start = std::chrono::steady_clock::now();
  // The floor: the cubic layout of `floor_resolution` texels along the longest side, baked as
  // such (the same texture an explicit resolution bakes).
  const Eigen::Vector3i floor = deformation_layout(deformer, half_extents, floor_resolution).dims;
  DeformationTexture best;
  layout::refine_layout(
      floor, sizeof(Eigen::Vector4f), centred ? 1 : 0, out.choice, out.error,
      [&](const Eigen::Vector3i& counts, bool as_floor) {
        out.texture =
            as_floor
                ? bake_deformation(deformer, half_extents, floor_resolution, centred, interrupter)
                : bake_deformation(deformer, half_extents, counts, centred, interrupter);
        return deformation_texture_error(deformer, out.texture, 2, interrupter);
      },
      [&] { return axis_interpolation_errors(deformer, out.texture, interrupter); },
      [&] { best = out.texture; }, [&] { out.texture = std::move(best); });
  out.texture.bake_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

namespace {

void bake_alpha_on(const Deformer& deformer, Grid3<float>& grid, Interrupter* interrupter) {
  std::atomic<bool> all_finite{true};
  parallel_for(
      grid.dims.z(),
      [&](long k) {
        for (int j = 0; j < grid.dims.y(); ++j)
          for (int i = 0; i < grid.dims.x(); ++i) {
            const float a = static_cast<float>(deformer.alpha(grid.texel_centre(i, j, int(k))));
            if (!std::isfinite(a)) all_finite = false;
            grid.at(i, j, int(k)) = a;
          }
      },
      interrupter, "alpha map");
  if (!all_finite)
    throw Error("bake_alpha: " + deformer.describe() +
                ": the alpha map is not finite at some texels");
}

AlphaMap bake_alpha_grid(const Deformer& deformer, Grid3<float> grid, Interrupter* interrupter) {
  if (!deformer.has_cut()) throw Error("bake_alpha: " + deformer.describe() + " has no cut");
  const auto start = std::chrono::steady_clock::now();
  AlphaMap map;
  map.grid = std::move(grid);
  bake_alpha_on(deformer, map.grid, interrupter);
  map.bake_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return map;
}

}  // namespace

AlphaMap bake_alpha(const Deformer& deformer, const Eigen::AlignedBox3d& region, int resolution,
                    Interrupter* interrupter) {
  if (resolution < 1)
    throw Error("bake_alpha: resolution = " + std::to_string(resolution) + ": must be >= 1");
  return bake_alpha_grid(deformer, make_grid_over(region.min(), region.max(), resolution, 0.0f),
                         interrupter);
}

AlphaMap bake_alpha(const Deformer& deformer, const Eigen::AlignedBox3d& region,
                    const Eigen::Vector3i& counts, Interrupter* interrupter) {
  if ((counts.array() < 1).any()) throw Error("bake_alpha: texel counts must be >= 1 per axis");
  return bake_alpha_grid(deformer, make_grid_with_counts(region.min(), region.max(), counts, 0.0f),
                         interrupter);
}

double alpha_map_error(const Deformer& deformer, const AlphaMap& map, double band, int stride,
                       Interrupter* interrupter) {
  const Grid3<float>& grid = map.grid;
  stride = std::max(stride, 1);
  const int slices = std::max(0, (grid.dims.z() - 1 + stride - 1) / stride);
  std::vector<double> slice_max(std::max(slices, 1), 0.0);
  parallel_for(
      slices,
      [&](long ks) {
        const int k = int(ks) * stride;
        if (k + 1 >= grid.dims.z()) return;
        double worst = 0.0;
        for (int j = 0; j + 1 < grid.dims.y(); j += stride)
          for (int i = 0; i + 1 < grid.dims.x(); i += stride) {
            const Eigen::Vector3d centre = grid.cell_centre(i, j, k);
            const double exact = deformer.alpha(centre);
            if (!(std::abs(exact) < band)) continue;
            worst = std::max(worst, std::abs(grid.sample(centre).value() - exact));
          }
        slice_max[ks] = worst;
      },
      interrupter, "alpha map: error");
  double worst = 0.0;
  for (double w : slice_max) worst = std::max(worst, w);
  return worst;
}

Eigen::Vector3d alpha_axis_errors(const AlphaMap& map, double band, Interrupter* interrupter) {
  const Grid3<float>& grid = map.grid;
  const int slices = grid.dims.z();
  std::vector<Eigen::Vector3d> slice_max(std::max(slices, 1), Eigen::Vector3d::Zero());
  parallel_for(
      slices,
      [&](long ks) {
        const int k = int(ks);
        Eigen::Vector3d worst = Eigen::Vector3d::Zero();
        for (int j = 0; j < grid.dims.y(); ++j)
          for (int i = 0; i < grid.dims.x(); ++i) {
            const double c = grid.at(i, j, k);
            if (!(std::abs(c) < band)) continue;
            const int ijk[3] = {i, j, k};
            for (int a = 0; a < 3; ++a) {
              if (ijk[a] == 0 || ijk[a] + 1 >= grid.dims[a]) continue;
              int lo[3] = {i, j, k}, hi[3] = {i, j, k};
              --lo[a];
              ++hi[a];
              const double second = double(grid.at(hi[0], hi[1], hi[2])) - 2.0 * c +
                                    double(grid.at(lo[0], lo[1], lo[2]));
              worst[a] = std::max(worst[a], std::abs(second) / 8.0);
            }
          }
        slice_max[k] = worst;
      },
      interrupter, "alpha map: error per axis");
  Eigen::Vector3d worst = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& w : slice_max) worst = worst.cwiseMax(w);
  return worst;
}

AutoAlpha bake_alpha_auto(const Deformer& deformer, const Eigen::AlignedBox3d& region,
                          double target, double band, std::uint64_t budget_bytes,
                          int floor_resolution, Interrupter* interrupter) {
  AutoAlpha out;
  out.choice = layout::start_choice(target, budget_bytes);
  const auto start = std::chrono::steady_clock::now();
  const Eigen::Vector3i floor =
      make_grid_over(region.min(), region.max(), floor_resolution, 0.0f).dims;
  AlphaMap best;
  layout::refine_layout(
      floor, sizeof(float), 0, out.choice, out.error,
      [&](const Eigen::Vector3i& counts, bool as_floor) {
        out.map = as_floor ? bake_alpha(deformer, region, floor_resolution, interrupter)
                           : bake_alpha(deformer, region, counts, interrupter);
        return alpha_map_error(deformer, out.map, band, 1, interrupter);
      },
      [&] { return alpha_axis_errors(out.map, band, interrupter); }, [&] { best = out.map; },
      [&] { out.map = std::move(best); });
  out.map.bake_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

double displacement_lipschitz(const Deformer& deformer, const DeformationTexture& texture,
                              Interrupter* interrupter) {
  const Grid3<Eigen::Vector4f>& grid = texture.grid;
  const Eigen::Vector3i cells = (grid.dims - Eigen::Vector3i::Ones()).cwiseMax(0);
  std::vector<double> slice_max(std::max(cells.z(), 1), 0.0);
  const bool cut = deformer.has_cut();
  parallel_for(
      cells.z(),
      [&](long slice) {
        const int k = int(slice);
        double worst = 0.0;
        for (int j = 0; j < cells.y(); ++j)
          for (int i = 0; i < cells.x(); ++i) {
            const Eigen::Vector3d centre = grid.cell_centre(i, j, k);
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
              m /= grid.spacing[a];
              sum += m * m;
            }
            worst = std::max(worst, std::sqrt(sum));
          }
        slice_max[k] = worst;
      },
      interrupter, "deformation texture: Lipschitz bound");
  double worst = 0.0;
  for (double w : slice_max) worst = std::max(worst, w);
  // Float rounding of the texels (relative 2^-24 of |D|, divided by the spacing) is far below
  // this margin.
  return (1.0 + worst) * (1.0 + 1e-5);
}

double deformation_texture_error(const Deformer& deformer, const DeformationTexture& texture,
                                 int stride, Interrupter* interrupter) {
  const Grid3<Eigen::Vector4f>& grid = texture.grid;
  stride = std::max(stride, 1);
  const int slices = std::max(0, (grid.dims.z() - 1 + stride - 1) / stride);
  std::vector<double> slice_max(std::max(slices, 1), 0.0);
  const bool cut = deformer.has_cut();
  parallel_for(
      slices,
      [&](long ks) {
        const int k = int(ks) * stride;
        if (k + 1 >= grid.dims.z()) return;
        double worst = 0.0;
        for (int j = 0; j + 1 < grid.dims.y(); j += stride)
          for (int i = 0; i + 1 < grid.dims.x(); i += stride) {
            bool valid = true;
            for (int c = 0; c < 8 && valid; ++c)
              valid = grid.at(i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2)).w() >= 0.5f;
            if (!valid) continue;
            const Eigen::Vector3d centre = grid.cell_centre(i, j, k);
            if (cut && deformer.alpha(centre) > -grid.spacing.norm()) continue;
            const Eigen::Vector3d exact = deformer.inverse(centre) - centre;
            worst = std::max(worst, (grid.sample(centre).head<3>() - exact).norm());
          }
        slice_max[ks] = worst;
      },
      interrupter, "deformation texture: error");
  double worst = 0.0;
  for (double w : slice_max) worst = std::max(worst, w);
  return worst;
}

InverseResidual measure_inverse_residual(const Deformer& d, const DeformationTexture& texture,
                                         double tolerance, Interrupter* interrupter) {
  const Grid3<Eigen::Vector4f>& grid = texture.grid;
  struct Slice {
    double max = 0, sum = 0;
    long texels = 0, over = 0, folded = 0, in_cut = 0;
  };
  const int slices = grid.dims.z();
  std::vector<Slice> results(std::max(slices, 0));
  parallel_for(
      slices,
      [&](long slice) {
        const int k = int(slice);
        Slice s;
        for (int j = 0; j < grid.dims.y(); ++j)
          for (int i = 0; i < grid.dims.x(); ++i) {
            const Eigen::Vector4f& texel = grid.at(i, j, k);
            if (!(texel.w() >= 0.5f)) continue;
            const Eigen::Vector3d p_def = grid.texel_centre(i, j, k);
            if (d.has_cut() && d.alpha(p_def) > 0.0) {
              ++s.in_cut;
              continue;
            }
            const Eigen::Vector3d p = p_def + texel.head<3>().cast<double>();
            const double r = (d.forward(p) - p_def).norm();
            ++s.texels;
            s.sum += r;
            s.max = std::max(s.max, std::isfinite(r) ? r : std::numeric_limits<double>::infinity());
            if (!(r <= tolerance)) ++s.over;
            if (!(d.jacobian(p).determinant() > 0.0)) ++s.folded;
          }
        results[k] = s;
      },
      interrupter, "deformation texture: inverse residual");

  InverseResidual out;
  out.tolerance = tolerance;
  double sum = 0.0;
  for (const Slice& s : results) {
    out.max = std::max(out.max, s.max);
    sum += s.sum;
    out.texels += s.texels;
    out.in_cut += s.in_cut;
    out.over_tolerance += s.over;
    out.folded += s.folded;
  }
  out.mean = out.texels > 0 ? sum / out.texels : 0.0;
  return out;
}

}  // namespace raywarp
