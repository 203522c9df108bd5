// Named after no one source: one sampler's guarantee across the step bounds and the ray caster.
// The `bounded` tracer's guarantee (library/textures.h, StepBounds): its Lipschitz bounds hold for
// the interpolated textures, and on random rays through random twists and bends of a thin shell
// it misses no hit that a dense march (1/64 voxel) over the same textures finds, and stops no
// later than that march's first hit.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "deformers/bend.h"
#include "deformers/twist.h"
#include "library/deformation_bake.h"
#include "library/implicit.h"
#include "library/mesh.h"
#include "library/textures.h"
#include "verify/reference.h"

using namespace raywarp;

namespace {

// A closed, outward-oriented cuboid of half extents `h`, rotated by `r` about the origin.
Mesh cuboid(const Eigen::Vector3d& h, const Eigen::Matrix3d& r) {
  Mesh m;
  m.V.resize(8, 3);
  for (int c = 0; c < 8; ++c) {
    Eigen::Vector3d p((c & 1) ? h.x() : -h.x(), (c & 2) ? h.y() : -h.y(), (c & 4) ? h.z() : -h.z());
    m.V.row(c) = (r * p).transpose();
  }
  const int faces[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                            {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  m.F.resize(12, 3);
  for (int f = 0; f < 12; ++f)
    for (int c = 0; c < 3; ++c) m.F(f, c) = faces[f][c];
  return m;
}

// What every sampling method counts as inside at p' (the shader's sample_at and value).
bool inside(const BoxTextures& tex, const Eigen::Vector3d& p_def) {
  const Eigen::Vector4d dv = tex.deformation.grid.sample(p_def);
  const Eigen::Vector3d p = p_def + dv.head<3>();
  return dv.w() >= 0.5 && tex.box.contains_local(p) && tex.sdf.grid.sample(p).value() > 0.0;
}

// g of StepBounds, written out again from its definition.
double g_of(const BoxTextures& tex, const Eigen::Vector3d& p_def) {
  const Eigen::Vector4d dv = tex.deformation.grid.sample(p_def);
  const Eigen::Vector3d p = p_def + dv.head<3>();
  double g =
      std::min(tex.sdf.grid.sample(p).value(), (tex.box.half_extents - p.cwiseAbs()).minCoeff());
  if (tex.step_bounds.validity_lipschitz > 0.0)
    g = std::min(g, (dv.w() - 0.5) / tex.step_bounds.validity_lipschitz);
  return g;
}

StepBound bound_at(const BoxTextures& tex, const Eigen::Vector3d& p_def) {
  const Eigen::Vector3d p = p_def + tex.deformation.grid.sample(p_def).head<3>();
  return step_bound_at(tex.step_bounds, p_def, p);
}

struct Case {
  BoxTextures tex;
  std::string name;
};

// A thin slab (1.5 voxels thick), tilted at random, under a random twist or bend.
Case random_case(std::mt19937_64& rng, int index) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const Eigen::Vector3d h(1.0, 0.6, 0.8);
  const Eigen::Matrix3d r =
      Eigen::AngleAxisd(unit(rng) * M_PI,
                        Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized())
          .toRotationMatrix();
  Case c;
  c.tex.box.half_extents = h;
  ImplicitSpec spec;
  spec.resolution = 48;  // voxel 2 / 48 = 0.042 (with the margin a little more)
  const double voxel = 2.0 * h.maxCoeff() / spec.resolution;
  const Mesh slab = cuboid(Eigen::Vector3d(0.7, 0.75 * voxel, 0.55), r);
  c.tex.sdf = bake_distance_grid(slab, c.tex.box, spec);
  const Axis axis = static_cast<Axis>(index % 3);
  std::unique_ptr<Deformer> deformer;
  if (index % 2 == 0) {
    const double angle = 90.0 + 270.0 * (0.5 + 0.5 * unit(rng));
    deformer = make_twist(h, axis, index % 4 == 0 ? angle : -angle);
    c.name = "twist " + std::to_string(static_cast<int>(angle));
  } else {
    const double angle = 30.0 + 150.0 * (0.5 + 0.5 * unit(rng));
    deformer = make_bend(h, axis, angle);
    c.name = "bend " + std::to_string(static_cast<int>(angle));
  }
  c.tex.deformation = bake_deformation(*deformer, h, 48);
  c.tex.region = Eigen::AlignedBox3d(c.tex.deformation.grid.origin, c.tex.deformation.grid.upper());
  c.tex.step_bounds = bake_step_bounds(c.tex.sdf, c.tex.deformation);
  return c;
}

// The ray's parameter range in the region [t0, t1], empty when t0 >= t1.
std::pair<double, double> clip(const Eigen::AlignedBox3d& region, const Eigen::Vector3d& o,
                               const Eigen::Vector3d& d) {
  double t0 = 0.0, t1 = 1e30;
  for (int a = 0; a < 3; ++a) {
    const double inv = 1.0 / d[a];
    double ta = (region.min()[a] - o[a]) * inv, tb = (region.max()[a] - o[a]) * inv;
    t0 = std::max(t0, std::min(ta, tb));
    t1 = std::min(t1, std::max(ta, tb));
  }
  return {t0, t1};
}

TEST(StepBounds, BricksAreAtLeastOneAndBelowTheWholeGridsBound) {
  std::mt19937_64 rng(9);
  Case c = random_case(rng, 1);
  const StepBounds& sb = c.tex.step_bounds;
  for (float v : sb.bricks.data) EXPECT_GE(v, 1.0f);
  for (float v : sb.sdf_bricks.data) {
    EXPECT_GE(v, 1.0f);
    EXPECT_LE(v, std::max(sb.sdf_lipschitz, 1.0) * (1 + 1e-6));
  }
  EXPECT_NEAR(sb.sdf_lipschitz, interpolant_lipschitz(c.tex.sdf.grid), 1e-6);
  // Most of a thin slab's grid is far from its surface, where f is flat at the background.
  long flat = 0;
  for (float v : sb.sdf_bricks.data) flat += v == 1.0f;
  EXPECT_GT(flat, 0);
}

TEST(InterpolantLipschitz, BoundsRandomPairs) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  Case c = random_case(rng, 0);
  const Grid3<float>& g = c.tex.sdf.grid;
  const double bound = interpolant_lipschitz(g);
  double worst = 0.0;
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector3d x =
        g.origin + g.extent().cwiseProduct(0.5 * Eigen::Vector3d(unit(rng), unit(rng), unit(rng)) +
                                           Eigen::Vector3d::Constant(0.5));
    const Eigen::Vector3d y =
        x + 0.3 * g.voxel() * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    worst = std::max(worst, std::abs(g.sample(x).value() - g.sample(y).value()) / (x - y).norm());
  }
  std::printf("[figures] distance grid: largest measured slope %.4f, bound %.4f\n", worst, bound);
  EXPECT_LE(worst, bound);
  EXPECT_GT(bound, 0.9);  // a distance field's slope is about 1
  EXPECT_LT(bound, std::sqrt(3.0) * 1.01);
}

TEST(StepBounds, BoundTheSlopeOfGInEveryBrickNeighbourhood) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), positive(0.0, 1.0);
  for (int n = 0; n < 4; ++n) {
    Case c = random_case(rng, n);
    const Grid3<Eigen::Vector4f>& d = c.tex.deformation.grid;
    const Grid3<float>& bricks = c.tex.step_bounds.bricks;
    double worst_g = 0.0, worst_d = 0.0;
    for (int i = 0; i < 20000; ++i) {
      // Anywhere in D's region, its clamp-to-edge borders included.
      const Eigen::Vector3d x = d.origin + d.extent().cwiseProduct(Eigen::Vector3d(
                                               positive(rng), positive(rng), positive(rng)));
      const Eigen::Vector3d v = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized();
      const StepBound bound = bound_at(c.tex, x);
      const double s = positive(rng) * bound.longest;
      if (s <= 0.0) continue;
      const Eigen::Vector3d y = x + s * v;
      worst_g = std::max(worst_g, std::abs(g_of(c.tex, y) - g_of(c.tex, x)) / s / bound.lipschitz);
      // The displacement's bound on its own (f's could hide an error in it): the preimage
      // moves at most L_D s.
      Eigen::Vector3i b;
      for (int a = 0; a < 3; ++a)
        b[a] =
            std::clamp(static_cast<int>(std::floor((x[a] - bricks.origin[a]) / bricks.spacing[a])),
                       0, bricks.dims[a] - 1);
      const Eigen::Vector3d moved = (y + d.sample(y).head<3>()) - (x + d.sample(x).head<3>());
      worst_d = std::max(worst_d, moved.norm() / s / bricks.at(b.x(), b.y(), b.z()));
    }
    std::printf(
        "[figures] %s: largest slope of g over its bound %.3f; of the preimage over L_D %.3f\n",
        c.name.c_str(), worst_g, worst_d);
    EXPECT_LE(worst_g, 1.0) << c.name;
    EXPECT_LE(worst_d, 1.0) << c.name;
  }
}

TEST(Bounded, MissesNoHitOfADenseMarchOnThinShells) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  RenderSettings bounded;
  bounded.sampling = Sampling::Bounded;
  bounded.max_steps = 20000;
  RenderSettings linear;
  linear.sampling = Sampling::Linear;
  linear.step_voxels = 1.0;
  long rays = 0, dense_hits = 0, bounded_misses = 0, bounded_late = 0, linear_misses = 0,
       near_misses = 0;
  for (int n = 0; n < 6; ++n) {
    Case c = random_case(rng, n);
    const double fine = c.tex.sdf.grid.voxel() / 64.0;
    long case_hits = 0, case_linear_misses = 0;
    for (int i = 0; i < 150; ++i) {
      // From a random point around the box towards a random point of its middle.
      const Eigen::Vector3d o = 3.0 * Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized();
      const Eigen::Vector3d target =
          0.6 *
          Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).cwiseProduct(c.tex.box.half_extents);
      const Eigen::Vector3d d = (target - o).normalized();
      const auto [t0, t1] = clip(c.tex.region, o, d);
      if (!(t0 < t1)) continue;
      ++rays;
      double first = -1.0;
      for (double t = t0; t <= t1; t += fine)
        if (inside(c.tex, o + t * d)) {
          first = t;
          break;
        }
      auto b = ray_cast_box(c.tex, o, d, t0, t1, bounded);
      if (first >= 0.0) {
        ++dense_hits;
        ++case_hits;
        if (!b)
          ++bounded_misses;
        else if (b->t > first + fine)
          ++bounded_late;
        if (!ray_cast_box(c.tex, o, d, t0, t1, linear)) {
          ++linear_misses;
          ++case_linear_misses;
        }
      } else if (b) {
        ++near_misses;  // g came within epsilon without turning positive
      }
    }
    std::printf("[figures] %s: %ld dense hits; linear (1 voxel) missed %ld\n", c.name.c_str(),
                case_hits, case_linear_misses);
  }
  std::printf(
      "[figures] bounded on %ld rays: %ld dense hits, %ld missed, %ld later than the dense march, "
      "%ld hits within epsilon where the dense march found none; linear at 1 voxel missed %ld\n",
      rays, dense_hits, bounded_misses, bounded_late, near_misses, linear_misses);
  EXPECT_GT(dense_hits, 200);
  EXPECT_EQ(bounded_misses, 0);
  EXPECT_EQ(bounded_late, 0);
}

}  // namespace
