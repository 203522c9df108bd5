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

namespace raywarp {

DeformationTexture bake_deformation(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                                    int resolution, bool centre_on_lower_faces,
                                    Interrupter* interrupter) {
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

  texture.bake_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return texture;
}

AlphaMap bake_alpha(const Deformer& deformer, const Eigen::AlignedBox3d& region, int resolution,
                    Interrupter* interrupter) {
  if (!deformer.has_cut()) throw Error("bake_alpha: " + deformer.describe() + " has no cut");
  if (resolution < 1)
    throw Error("bake_alpha: resolution = " + std::to_string(resolution) + ": must be >= 1");
  const auto start = std::chrono::steady_clock::now();
  AlphaMap map;
  Grid3<float>& grid = map.grid;
  grid = make_grid_over(region.min(), region.max(), resolution, 0.0f);
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
  map.bake_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return map;
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
            const Eigen::Vector3d centre =
                grid.texel_centre(i, j, k) + Eigen::Vector3d::Constant(0.5 * grid.spacing);
            if (cut && deformer.alpha(centre) > -std::sqrt(3.0) * grid.spacing) continue;
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
    long texels = 0, over = 0, folded = 0;
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
    out.over_tolerance += s.over;
    out.folded += s.folded;
  }
  out.mean = out.texels > 0 ? sum / out.texels : 0.0;
  return out;
}

}  // namespace raywarp
