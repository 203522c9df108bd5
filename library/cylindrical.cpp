#include "library/cylindrical.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "base/clock.h"
#include "base/error.h"
#include "base/parallel.h"
#include "library/refine_layout.h"

namespace raywarp {

namespace {

constexpr double kPi = 3.14159265358979323846;

// x wrapped into (-pi, pi].
double wrap_angle(double x) {
  const double w = std::remainder(x, 2.0 * kPi);
  return w <= -kPi ? w + 2.0 * kPi : w;
}

void check_counts(const char* what, const Eigen::Vector3i& counts) {
  if ((counts.array() < 2).any() || (counts.array() > layout::kMaxCount).any())
    throw Error(std::string(what) + ": texel counts (angle, radius, height) must be in [2, " +
                std::to_string(layout::kMaxCount) + "], got " + std::to_string(counts[0]) + ", " +
                std::to_string(counts[1]) + ", " + std::to_string(counts[2]));
}

void check_domain(const char* what, const CylindricalDomain& d) {
  if (!(d.radius > 0.0) || !(d.high > d.low) || !std::isfinite(d.radius) || !std::isfinite(d.low) ||
      !std::isfinite(d.high))
    throw Error(std::string(what) + ": the cylindrical domain is empty or not finite");
}

// The Cartesian reach of a cylindrical cell at radius r: the diagonal of its arc, radial and
// height sides.
double cell_reach(const Eigen::Vector3d& spacing, double r) {
  return std::sqrt(std::pow(r * spacing[0], 2) + spacing[1] * spacing[1] + spacing[2] * spacing[2]);
}

bool in_box(const Eigen::Vector3d& p, const Eigen::Vector3d& h) {
  return (p.cwiseAbs().array() <= h.array()).all();
}

}  // namespace

Eigen::Vector3d to_cylindrical(const Eigen::Vector3d& p, int axis) {
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  return {std::atan2(p[v], p[u]), std::hypot(p[u], p[v]), p[axis]};
}

Eigen::Vector3d from_cylindrical(const Eigen::Vector3d& c, int axis) {
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  Eigen::Vector3d p;
  p[u] = c[1] * std::cos(c[0]);
  p[v] = c[1] * std::sin(c[0]);
  p[axis] = c[2];
  return p;
}

CylindricalDomain cylindrical_domain(const Eigen::AlignedBox3d& region, int axis) {
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  const double ru = std::max(std::abs(region.min()[u]), std::abs(region.max()[u]));
  const double rv = std::max(std::abs(region.min()[v]), std::abs(region.max()[v]));
  CylindricalDomain d;
  d.radius = std::hypot(ru, rv);
  d.low = region.min()[axis];
  d.high = region.max()[axis];
  return d;
}

CylindricalDomain cylindrical_domain(const Eigen::AlignedBox3d& region, int axis,
                                     const Eigen::Vector3d& half_extents) {
  CylindricalDomain d = cylindrical_domain(region, axis);
  const double h = half_extents[axis];
  if (d.low <= -h && d.high >= h && h > 0.0) {
    d.faces = true;
    d.face_low = -h;
    d.face_high = h;
  }
  return d;
}

void cylindrical_heights(const CylindricalDomain& domain, int n, double* first, double* spacing) {
  const int intervals = std::max(n - 1, 1);
  *first = domain.low;
  *spacing = (domain.high - domain.low) / intervals;
  if (!domain.faces) return;
  const double length = domain.face_high - domain.face_low;
  const double below = std::max(0.0, domain.face_low - domain.low);
  const double above = std::max(0.0, domain.high - domain.face_high);
  if (!(length > 0.0)) return;
  // Whole texels of length / k beyond each face to reach low and high.
  auto pad = [&](double extra, int k) { return int(std::ceil(extra * k / length - 1e-9)); };
  for (int k = intervals; k >= 1; --k)
    if (k + pad(below, k) + pad(above, k) <= intervals) {
      *spacing = length / k;
      *first = domain.face_low - pad(below, k) * *spacing;
      return;
    }
}

Eigen::Vector4d cylindrical_displacement(const Grid3<Eigen::Vector4f>& grid, int axis,
                                         const Eigen::Vector3d& p_def) {
  const Eigen::Vector3d c = to_cylindrical(p_def, axis);
  if (!in_cylindrical_region(grid, c)) return Eigen::Vector4d::Zero();
  const Eigen::Vector4d t = sample_periodic(grid, c);
  const Eigen::Vector3d p = from_cylindrical(c + t.head<3>(), axis);
  Eigen::Vector4d out;
  out << p - p_def, t[3];
  return out;
}

double cylindrical_alpha(const Grid3<float>& grid, int axis, const Eigen::Vector3d& p_def) {
  return sample_periodic(grid, to_cylindrical(p_def, axis)).value();
}

DeformationTexture bake_cylindrical_deformation(const Deformer& deformer, int axis,
                                                const CylindricalDomain& domain,
                                                const Eigen::Vector3i& counts,
                                                Interrupter* interrupter) {
  check_counts("cylindrical deformation texture", counts);
  check_domain("cylindrical deformation texture", domain);
  const auto start = std::chrono::steady_clock::now();
  DeformationTexture out;
  Grid3<Eigen::Vector4f>& g = out.grid =
      cylindrical_layout(domain, counts, Eigen::Vector4f::Zero().eval());
  std::atomic<bool> all_finite{true};
  parallel_for(
      long(g.dims.y()) * g.dims.z(),
      [&](long row) {
        const int j = int(row % g.dims.y()), k = int(row / g.dims.y());
        for (int i = 0; i < g.dims.x(); ++i) {
          const Eigen::Vector3d c = g.texel_centre(i, j, k);
          const Eigen::Vector3d p = deformer.inverse(from_cylindrical(c, axis));
          const Eigen::Vector3d cp = to_cylindrical(p, axis);
          Eigen::Vector4f texel(float(wrap_angle(cp[0] - c[0])), float(cp[1] - c[1]),
                                float(cp[2] - c[2]), 1.0f);
          if (!texel.allFinite() || !p.allFinite()) {
            all_finite = false;
            texel.setZero();
          }
          g.at(i, j, k) = texel;
        }
      },
      interrupter, "cylindrical deformation texture");
  if (!all_finite)
    throw Error("bake_deformation: " + deformer.describe() +
                ": the inverse displacement is not finite at some texels");
  // The angle's difference unwrapped along h, and copied on the axis from the next radius.
  for (int j = 0; j < g.dims.y(); ++j)
    for (int i = 0; i < g.dims.x(); ++i)
      for (int k = 1; k < g.dims.z(); ++k) {
        const float below = g.at(i, j, k - 1)[0];
        float& here = g.at(i, j, k)[0];
        here += float(2.0 * kPi * std::round((below - here) / (2.0 * kPi)));
      }
  for (int k = 0; k < g.dims.z(); ++k)
    for (int i = 0; i < g.dims.x(); ++i) g.at(i, 0, k)[0] = g.at(i, 1, k)[0];
  out.bake_seconds = seconds_since(start);
  return out;
}

AlphaMap bake_cylindrical_alpha(const Deformer& deformer, int axis, const CylindricalDomain& domain,
                                const Eigen::Vector3i& counts, Interrupter* interrupter) {
  if (!deformer.has_cut()) throw Error("bake_alpha: " + deformer.describe() + " has no cut");
  check_counts("cylindrical alpha map", counts);
  check_domain("cylindrical alpha map", domain);
  const auto start = std::chrono::steady_clock::now();
  AlphaMap out;
  Grid3<float>& g = out.grid = cylindrical_layout(domain, counts, 0.0f);
  parallel_for(
      long(g.dims.y()) * g.dims.z(),
      [&](long row) {
        const int j = int(row % g.dims.y()), k = int(row / g.dims.y());
        for (int i = 0; i < g.dims.x(); ++i) {
          const double a = deformer.alpha(from_cylindrical(g.texel_centre(i, j, k), axis));
          g.at(i, j, k) = std::isfinite(a) ? float(a) : (a > 0 ? 1e30f : -1e30f);
        }
      },
      interrupter, "cylindrical alpha map");
  out.bake_seconds = seconds_since(start);
  return out;
}

namespace {

// The largest of error(c) over the centres c of a cylindrical grid's cells (periodic in the
// angle: as many cells as texels around), in parallel by rows; error returns 0 where it does not
// count.
template <class T, class CellError>
double max_over_cells(const Grid3<T>& g, const char* what, Interrupter* interrupter,
                      CellError&& error) {
  const int ni = g.dims.x(), nj = g.dims.y() - 1, nk = g.dims.z() - 1;
  std::vector<double> rows(size_t(nj) * nk, 0.0);
  parallel_for(
      long(nj) * nk,
      [&](long row) {
        const int j = int(row % nj), k = int(row / nj);
        double worst = 0.0;
        for (int i = 0; i < ni; ++i) worst = std::max(worst, error(g.cell_centre(i, j, k)));
        rows[size_t(row)] = worst;
      },
      interrupter, what);
  double worst = 0.0;
  for (double r : rows) worst = std::max(worst, r);
  return worst;
}

}  // namespace

double cylindrical_deformation_error(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                                     const DeformationTexture& texture, int axis,
                                     Interrupter* interrupter) {
  const Grid3<Eigen::Vector4f>& g = texture.grid;
  return max_over_cells(
      g, "cylindrical deformation error", interrupter, [&](const Eigen::Vector3d& c) {
        const Eigen::Vector3d p_def = from_cylindrical(c, axis);
        const Eigen::Vector3d exact = deformer.inverse(p_def);
        if (!in_box(exact, half_extents)) return 0.0;
        if (deformer.has_cut() && deformer.alpha(p_def) > -cell_reach(g.spacing, c[1])) return 0.0;
        const Eigen::Vector4d d = cylindrical_displacement(g, axis, p_def);
        return (p_def + d.head<3>() - exact).norm();
      });
}

double cylindrical_alpha_error(const Deformer& deformer, const AlphaMap& map, int axis, double band,
                               Interrupter* interrupter) {
  return max_over_cells(map.grid, "cylindrical alpha error", interrupter,
                        [&](const Eigen::Vector3d& c) {
                          const double exact = deformer.alpha(from_cylindrical(c, axis));
                          if (!(std::abs(exact) < band)) return 0.0;
                          return std::abs(sample_periodic(map.grid, c).value() - exact);
                        });
}

namespace {

// Per axis, the largest |V(i+1) - 2 V(i) + V(i-1)| / 8 (object units, by `size`) over the texels
// that `counts(i, j, k)` admits, the angle's neighbours periodic.
template <class T, class Size, class Counts>
Eigen::Vector3d second_differences(const Grid3<T>& g, Size&& size, Counts&& counts) {
  Eigen::Vector3d out = Eigen::Vector3d::Zero();
  for (int k = 0; k < g.dims.z(); ++k)
    for (int j = 0; j < g.dims.y(); ++j)
      for (int i = 0; i < g.dims.x(); ++i) {
        if (!counts(i, j, k)) continue;
        const int ip = (i + 1) % g.dims.x(), im = (i + g.dims.x() - 1) % g.dims.x();
        out[0] = std::max(out[0], size(g.at(ip, j, k), g.at(i, j, k), g.at(im, j, k), j) / 8.0);
        if (j > 0 && j + 1 < g.dims.y())
          out[1] =
              std::max(out[1], size(g.at(i, j + 1, k), g.at(i, j, k), g.at(i, j - 1, k), j) / 8.0);
        if (k > 0 && k + 1 < g.dims.z())
          out[2] =
              std::max(out[2], size(g.at(i, j, k + 1), g.at(i, j, k), g.at(i, j, k - 1), j) / 8.0);
      }
  return out;
}

}  // namespace

AutoDeformation bake_cylindrical_deformation_auto(const Deformer& deformer,
                                                  const Eigen::Vector3d& half_extents, int axis,
                                                  const CylindricalDomain& domain, double target,
                                                  std::uint64_t budget_bytes,
                                                  const Eigen::Vector3i& floor,
                                                  Interrupter* interrupter) {
  AutoDeformation out;
  out.choice = layout::start_choice(target, budget_bytes);
  const auto start = std::chrono::steady_clock::now();
  DeformationTexture best;
  layout::refine_layout(
      floor, sizeof(Eigen::Vector4f), 0, out.choice, out.error,
      [&](const Eigen::Vector3i& counts, bool) {
        out.texture = bake_cylindrical_deformation(deformer, axis, domain, counts, interrupter);
        return cylindrical_deformation_error(deformer, half_extents, out.texture, axis,
                                             interrupter);
      },
      [&] {
        const Grid3<Eigen::Vector4f>& g = out.texture.grid;
        const double dr = g.spacing[1];
        return second_differences(
            g,
            [&](const Eigen::Vector4f& a, const Eigen::Vector4f& b, const Eigen::Vector4f& c,
                int j) {
              const Eigen::Vector3d s = (a - 2.0f * b + c).head<3>().cast<double>();
              const double r = std::max(0.0, j * dr + double(b[1]));  // the preimage's radius
              return std::sqrt(r * r * s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
            },
            [&](int i, int j, int k) {
              const Eigen::Vector3d c = g.texel_centre(i, j, k);
              const Eigen::Vector3d p_def = from_cylindrical(c, axis);
              return !deformer.has_cut() ||
                     deformer.alpha(p_def) <= -2.0 * cell_reach(g.spacing, c[1]);
            });
      },
      [&] { best = out.texture; }, [&] { out.texture = std::move(best); });
  out.texture.bake_seconds = seconds_since(start);
  return out;
}

AutoAlpha bake_cylindrical_alpha_auto(const Deformer& deformer, int axis,
                                      const CylindricalDomain& domain, double target, double band,
                                      std::uint64_t budget_bytes, const Eigen::Vector3i& floor,
                                      Interrupter* interrupter) {
  AutoAlpha out;
  out.choice = layout::start_choice(target, budget_bytes);
  const auto start = std::chrono::steady_clock::now();
  AlphaMap best;
  layout::refine_layout(
      floor, sizeof(float), 0, out.choice, out.error,
      [&](const Eigen::Vector3i& counts, bool) {
        out.map = bake_cylindrical_alpha(deformer, axis, domain, counts, interrupter);
        return cylindrical_alpha_error(deformer, out.map, axis, band, interrupter);
      },
      [&] {
        const Grid3<float>& g = out.map.grid;
        return second_differences(
            g, [](float a, float b, float c, int) { return double(std::abs(a - 2.0f * b + c)); },
            [&](int i, int j, int k) { return std::abs(g.at(i, j, k)) < band; });
      },
      [&] { best = out.map; }, [&] { out.map = std::move(best); });
  out.map.bake_seconds = seconds_since(start);
  return out;
}

InverseResidual measure_cylindrical_residual(const Deformer& deformer,
                                             const Eigen::Vector3d& half_extents,
                                             const DeformationTexture& texture, int axis,
                                             double tolerance, Interrupter* interrupter) {
  const Grid3<Eigen::Vector4f>& g = texture.grid;
  struct Row {
    double max = 0, sum = 0;
    long texels = 0, over = 0, folded = 0, in_cut = 0;
  };
  std::vector<Row> rows(size_t(g.dims.y()) * g.dims.z());
  parallel_for(
      long(rows.size()),
      [&](long row) {
        const int j = int(row % g.dims.y()), k = int(row / g.dims.y());
        Row& r = rows[size_t(row)];
        for (int i = 0; i < g.dims.x(); ++i) {
          const Eigen::Vector3d c = g.texel_centre(i, j, k);
          const Eigen::Vector4f t = g.at(i, j, k);
          if (t[3] < 0.5f) continue;
          const Eigen::Vector3d p_def = from_cylindrical(c, axis);
          const Eigen::Vector3d p = from_cylindrical(c + t.head<3>().cast<double>(), axis);
          if (!in_box(p, half_extents)) continue;
          if (deformer.has_cut() && deformer.alpha(p_def) > 0.0) {
            ++r.in_cut;
            continue;
          }
          const double e = (deformer.forward(p) - p_def).norm();
          r.max = std::max(r.max, e);
          r.sum += e;
          ++r.texels;
          if (e > tolerance) ++r.over;
          if (deformer.jacobian(p).determinant() <= 0.0) ++r.folded;
        }
      },
      interrupter, "cylindrical inverse residual");
  InverseResidual out;
  out.tolerance = tolerance;
  for (const Row& r : rows) {
    out.max = std::max(out.max, r.max);
    out.mean += r.sum;
    out.texels += r.texels;
    out.in_cut += r.in_cut;
    out.over_tolerance += r.over;
    out.folded += r.folded;
  }
  if (out.texels > 0) out.mean /= double(out.texels);
  return out;
}

}  // namespace raywarp
