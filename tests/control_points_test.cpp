// The control-point deformer (deformers/control_points.h): interpolation, identity, the analytic
// Jacobian against central differences, the Newton inverse and the baked texture's residual, the
// reproduction of an analytic twist (field and rendered image against the twist's exact ground
// truth), and ill-posed input.
#include "deformers/control_points.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "base/error.h"
#include "deformers/twist.h"
#include "gl/context.h"
#include "gl/renderer.h"
#include "library/deformation_bake.h"
#include "library/image.h"
#include "library/implicit.h"
#include "library/mesh.h"
#include "library/scene.h"
#include "verify/reference.h"

namespace raywarp {
namespace {

// A box of uneven aspect ratio, so that a mixed-up axis shows.
const Eigen::Vector3d kHalf(0.7, 1.3, 0.4);
const double kDiagonal = 2.0 * kHalf.norm();

std::array<bool, 6> pins(const std::string& faces) {
  std::array<bool, 6> out{};
  for (size_t i = 0; i + 1 < faces.size(); i += 3) {
    const int axis = faces[i + 1] - 'x';
    out[2 * axis + (faces[i] == '+' ? 1 : 0)] = true;
  }
  return out;
}

// Uniform in [-scale h, scale h].
Eigen::Vector3d random_point(std::mt19937_64& rng, const Eigen::Vector3d& h, double scale = 1.0) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  return scale * Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).cwiseProduct(h);
}

// Sources on an n x n x n lattice over the box (faces included).
std::vector<Eigen::Vector3d> lattice(const Eigen::Vector3d& h, int n) {
  std::vector<Eigen::Vector3d> out;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        out.push_back(
            h.cwiseProduct(Eigen::Vector3d(i, j, k) * (2.0 / (n - 1)) - Eigen::Vector3d::Ones()));
  return out;
}

// Whether p lies on a pinned face.
bool on_pinned_face(const Eigen::Vector3d& p, const Eigen::Vector3d& h,
                    const std::array<bool, 6>& pinned) {
  for (int f = 0; f < 6; ++f)
    if (pinned[f] && p[f / 2] == (f % 2 ? 1.0 : -1.0) * h[f / 2]) return true;
  return false;
}

// Random sources in the box (off its faces), each moved by up to `move` (object units) along
// each axis.
std::vector<ControlPoint> random_pairs(std::mt19937_64& rng, int n, double move) {
  std::vector<ControlPoint> points;
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d s = random_point(rng, kHalf);
    points.push_back({s, s + move * Eigen::Vector3d(unit(rng), unit(rng), unit(rng))});
  }
  return points;
}

// The warning of `warnings` that contains `needle`, or "" (and a failure).
std::string find_warning(const std::vector<std::string>& warnings, const std::string& needle) {
  for (const std::string& w : warnings)
    if (w.find(needle) != std::string::npos) {
      std::printf("[figures] warning: %s\n", w.c_str());
      return w;
    }
  ADD_FAILURE() << "no warning contains \"" << needle << "\" among " << warnings.size();
  return "";
}

struct Config {
  const char* name;
  double radius;
  const char* pinned;
};
const Config kConfigs[] = {{"global", 0.0, ""},
                           {"global pinned -y", 0.0, "-y"},
                           {"global pinned -x +x -z", 0.0, "-x +x -z"},
                           {"local", 0.9, ""},
                           {"local pinned -y +y", 0.9, "-y +y"},
                           {"local pinned +z", 0.9, "+z"}};

// ------------------------------------------------------------------------------------------------
// 1. Sources = targets: the identity.

TEST(ControlPoints, SourcesEqualTargetsIsTheIdentity) {
  std::mt19937_64 rng(1);
  for (const Config& config : kConfigs) {
    auto points = random_pairs(rng, 20, 0.0);
    const auto cp = make_control_points(kHalf, points, config.radius, pins(config.pinned));
    const DeformationTexture texture = bake_deformation(*cp, kHalf, 32);
    double worst = 0.0;
    for (const Eigen::Vector4f& texel : texture.grid.data)
      worst = std::max(worst, static_cast<double>(texel.head<3>().norm()));
    EXPECT_LE(worst, 1e-6) << config.name;
    for (int n = 0; n < 1000; ++n) {
      const Eigen::Vector3d p = random_point(rng, kHalf, 1.5);
      EXPECT_EQ(cp->forward(p), p) << config.name;
      EXPECT_EQ(cp->inverse(p), p) << config.name;
      EXPECT_EQ(cp->jacobian(p), Eigen::Matrix3d::Identity()) << config.name;
    }
    for (bool face : cp->identity_faces()) EXPECT_TRUE(face) << config.name;
    std::printf("[figures] identity (%s): max |D| over %zu texels %.3g\n", config.name,
                texture.grid.data.size(), worst);
  }
}

// ------------------------------------------------------------------------------------------------
// Interpolation and pinned faces.

TEST(ControlPoints, InterpolatesEveryPairAndHoldsPinnedFaces) {
  std::mt19937_64 rng(2);
  for (const Config& config : kConfigs) {
    const auto pinned = pins(config.pinned);
    auto points = random_pairs(rng, 30, 0.2);
    // One source on each pinned face, held.
    for (int f = 0; f < 6; ++f)
      if (pinned[f]) {
        Eigen::Vector3d s = random_point(rng, kHalf);
        s[f / 2] = (f % 2 ? 1.0 : -1.0) * kHalf[f / 2];
        points.push_back({s, s});
      }
    const auto cp = make_control_points(kHalf, points, config.radius, pinned);
    double worst = 0.0;
    for (const ControlPoint& c : points)
      worst = std::max(worst, (cp->forward(c.source) - c.target).norm());
    EXPECT_LE(worst, 1e-9 * kDiagonal) << config.name;
    // Exactly the identity on the pinned faces (m = 0 there).
    const auto faces = cp->identity_faces();
    for (int f = 0; f < 6; ++f) {
      EXPECT_EQ(faces[f], pinned[f]) << config.name << " face " << f;
      if (!pinned[f]) continue;
      for (int n = 0; n < 100; ++n) {
        Eigen::Vector3d p = random_point(rng, kHalf);
        p[f / 2] = (f % 2 ? 1.0 : -1.0) * kHalf[f / 2];
        EXPECT_EQ(cp->forward(p), p) << config.name << " face " << f;
      }
    }
    std::printf("[figures] interpolation (%s): max |F(s_i) - t_i| / L = %.3g over %zu pairs\n",
                config.name, worst / kDiagonal, points.size());
  }
}

TEST(ControlPoints, Describe) {
  std::vector<ControlPoint> points;
  for (int i = 0; i < 12; ++i) {
    const Eigen::Vector3d s(0.05 * i, 0.01 * i * i, -0.02 * i);
    points.push_back({s, s + Eigen::Vector3d(0.0, 0.1, 0.0)});
  }
  EXPECT_EQ(make_control_points(kHalf, points, 0.5, pins("-y +y"))->describe(),
            "control points (12 pairs, radius 0.5, pinned -y +y)");
  EXPECT_EQ(make_control_points(kHalf, points, 0.0, pins(""))->describe(),
            "control points (12 pairs, global)");
  points.resize(1);
  EXPECT_EQ(make_control_points(kHalf, points, 0.0, pins("+x"))->describe(),
            "control points (1 pair, global, pinned +x)");
}

TEST(ControlPoints, FewSourcesGiveATranslationOrAnAffineMapInTheirSpan) {
  // One pair: a translation everywhere (global, no pins).
  const Eigen::Vector3d d(0.1, -0.2, 0.05);
  const auto one = make_control_points(
      kHalf, {{Eigen::Vector3d(0.1, 0.2, 0.3) * 0.5, Eigen::Vector3d(0.1, 0.2, 0.3) * 0.5 + d}},
      0.0, pins(""));
  std::mt19937_64 rng(3);
  for (int n = 0; n < 100; ++n) {
    const Eigen::Vector3d p = random_point(rng, kHalf);
    EXPECT_LE((one->forward(p) - p - d).norm(), 1e-12);
  }
  // An affine map sampled at 4+ points in general position is reproduced exactly (global).
  Eigen::Matrix3d A;
  A << 1.1, 0.1, 0.0, -0.05, 0.95, 0.1, 0.02, 0.0, 1.05;
  const Eigen::Vector3d b(0.03, -0.02, 0.01);
  std::vector<ControlPoint> points;
  for (int i = 0; i < 10; ++i) {
    const Eigen::Vector3d s = random_point(rng, kHalf);
    points.push_back({s, A * s + b});
  }
  const auto affine = make_control_points(kHalf, points, 0.0, pins(""));
  double worst = 0.0;
  for (int n = 0; n < 1000; ++n) {
    const Eigen::Vector3d p = random_point(rng, kHalf);
    worst = std::max(worst, (affine->forward(p) - (A * p + b)).norm());
  }
  EXPECT_LE(worst, 1e-9 * kDiagonal);
  std::printf("[figures] affine reproduction from 10 pairs: max |F - A p - b| / L = %.3g\n",
              worst / kDiagonal);
  // Collinear sources: no error, interpolation holds.
  std::vector<ControlPoint> line;
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d s(0.2 * i - 0.2, 0.0, 0.0);
    line.push_back({s, s + Eigen::Vector3d(0.0, 0.1 * i, 0.0)});
  }
  const auto collinear = make_control_points(kHalf, line, 0.0, pins(""));
  for (const ControlPoint& c : line)
    EXPECT_LE((collinear->forward(c.source) - c.target).norm(), 1e-12);
}

// ------------------------------------------------------------------------------------------------
// 2. Jacobian against central differences.

// Central differences with step d: truncation d^2 / 6 |F'''| (phi is C2 with a bounded, jumping
// third derivative) plus rounding, which for the global spline is that of its sum of large,
// cancelling kernel terms rather than eps |F|. Measured: the error falls as d^2 from d = 1e-4 L
// down to 1e-5 L for the global spline (at 1e-6 L rounding takes over) and to 1e-6 L for the local
// one; at those steps it stays below 3e-8 of 1 + |J_u| (steep fields, |J_u| up to ~40, have
// proportionally larger derivatives, so the error is measured relative to that). A wrong term
// would be off by O(|J_u|).
// Points within 2d of a box face (where F is only C1) are skipped; a quarter of the points lie
// beyond the box, where F is its first-order continuation.
TEST(ControlPoints, JacobianMatchesCentralDifferences) {
  std::mt19937_64 rng(4);
  for (const Config& config : kConfigs) {
    const double d = (config.radius == 0.0 ? 1e-5 : 1e-6) * kDiagonal;
    const auto pinned = pins(config.pinned);
    const auto cp = make_control_points(kHalf, random_pairs(rng, 20, 0.15), config.radius, pinned);
    double worst = 0.0, worst_absolute = 0.0, largest = 0.0;
    for (int n = 0; n < 2000; ++n) {
      const Eigen::Vector3d p = random_point(rng, kHalf, n % 4 == 0 ? 1.5 : 1.0);
      if (((p.cwiseAbs() - kHalf).cwiseAbs().array() < 2.0 * d).any()) continue;
      Eigen::Matrix3d numeric;
      for (int j = 0; j < 3; ++j) {
        const Eigen::Vector3d step = d * Eigen::Vector3d::Unit(j);
        numeric.col(j) = (cp->forward(p + step) - cp->forward(p - step)) / (2.0 * d);
      }
      const Eigen::Matrix3d J = cp->jacobian(p);
      const double size = (J - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
      const double error = (numeric - J).cwiseAbs().maxCoeff();
      worst = std::max(worst, error / (1.0 + size));
      worst_absolute = std::max(worst_absolute, error);
      largest = std::max(largest, size);
    }
    EXPECT_LE(worst, 1e-7) << config.name;
    EXPECT_GT(largest, 0.01) << config.name;  // the field is not trivial
    std::printf(
        "[figures] Jacobian (%s): max |J - central differences| = %.3g, relative to 1 + |J_u| "
        "%.3g (max |J_u| %.3g)\n",
        config.name, worst_absolute, worst, largest);
  }
}

// Beyond the box F continues by its first-order Taylor expansion at the nearest box point, so F
// and dF/dp are continuous across the faces, edges and corners: across a face, F changes by
// O(e) and dF/dp by O(e) (the second derivative times e) over a step of 2e.
TEST(ControlPoints, ContinuesSmoothlyBeyondTheBox) {
  std::mt19937_64 rng(9);
  const double e = 1e-7 * kDiagonal;
  for (const Config& config : kConfigs) {
    const auto pinned = pins(config.pinned);
    const auto cp = make_control_points(kHalf, random_pairs(rng, 20, 0.15), config.radius, pinned);
    double jump_f = 0.0, jump_j = 0.0;
    for (int n = 0; n < 600; ++n) {
      Eigen::Vector3d p = random_point(rng, kHalf);
      Eigen::Vector3d out = Eigen::Vector3d::Zero();
      for (int a = 0; a < 3; ++a)  // on a face (n % 3 == 0), an edge (1) or a corner (2)
        if (a <= n % 3) {
          const int axis = (a + n / 3) % 3;
          const double side = (n / 9) % 2 ? 1.0 : -1.0;
          p[axis] = side * kHalf[axis];
          out[axis] = side;
        }
      const Eigen::Vector3d inside = p - e * out, beyond = p + e * out;
      jump_f = std::max(jump_f, (cp->forward(beyond) - cp->forward(inside)).norm() / (2.0 * e));
      jump_j = std::max(jump_j, (cp->jacobian(beyond) - cp->jacobian(inside)).norm());
    }
    EXPECT_LE(jump_f, 1e3) << config.name;  // |dF/dp| along the step: bounded, so F continuous
    EXPECT_LE(jump_j, 1e-3) << config.name;
    std::printf(
        "[figures] across the box faces (%s): max |F(+e) - F(-e)| / 2e = %.3g, max |J(+e) - "
        "J(-e)| = %.3g (e = 1e-7 L)\n",
        config.name, jump_f, jump_j);
  }
}

// ------------------------------------------------------------------------------------------------
// 3. The inverse.

// A lattice of 4 x 4 x 4 sources, each moved by up to 15 % of the lattice spacing: no folds.
std::vector<ControlPoint> gentle_pairs(std::mt19937_64& rng, const std::array<bool, 6>& pinned) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<ControlPoint> points;
  const Eigen::Vector3d spacing = 2.0 * kHalf / 3.0;
  for (const Eigen::Vector3d& s : lattice(kHalf, 4)) {
    Eigen::Vector3d t = s;
    if (!on_pinned_face(s, kHalf, pinned))
      t += 0.15 * spacing.cwiseProduct(Eigen::Vector3d(unit(rng), unit(rng), unit(rng)));
    points.push_back({s, t});
  }
  return points;
}

TEST(ControlPoints, InverseOfANonFoldingSet) {
  std::mt19937_64 rng(5);
  for (const Config& config : kConfigs) {
    const auto pinned = pins(config.pinned);
    const double radius = config.radius > 0.0 ? 1.2 : 0.0;  // > the lattice diagonal step
    const auto cp = make_control_points(kHalf, gentle_pairs(rng, pinned), radius, pinned);
    ASSERT_FALSE(measure_folds(*cp, kHalf, 32).folds()) << config.name;
    double forward_of_inverse = 0.0, inverse_of_forward = 0.0;
    for (int n = 0; n < 2000; ++n) {
      const Eigen::Vector3d p = random_point(rng, kHalf);
      const Eigen::Vector3d p_def = cp->forward(p);
      const Eigen::Vector3d back = cp->inverse(p_def);
      forward_of_inverse = std::max(forward_of_inverse, (cp->forward(back) - p_def).norm());
      inverse_of_forward = std::max(inverse_of_forward, (back - p).norm());
    }
    EXPECT_LE(forward_of_inverse, 1e-9 * kDiagonal) << config.name;
    EXPECT_LE(inverse_of_forward, 1e-9 * kDiagonal) << config.name;

    const auto start = std::chrono::steady_clock::now();
    const DeformationTexture texture = bake_deformation(*cp, kHalf, 40);
    const double bake =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const InverseResidual r = measure_inverse_residual(*cp, texture, 1e-6 * kDiagonal);
    EXPECT_GT(r.texels, 1000) << config.name;
    EXPECT_EQ(r.over_tolerance, 0) << config.name;
    EXPECT_EQ(r.folded, 0) << config.name;
    EXPECT_LE(r.max, 1e-6 * kDiagonal) << config.name;
    std::printf(
        "[figures] inverse (%s): round trips max |F(F^-1(p')) - p'| / L = %.3g, |F^-1(F(p)) - p| "
        "/ L = %.3g; baked texture %dx%dx%d (%.2f s): residual |F(p' + D) - p'| / L max %.3g, "
        "mean %.3g over %ld valid texels (tolerance 1e-6)\n",
        config.name, forward_of_inverse / kDiagonal, inverse_of_forward / kDiagonal,
        texture.grid.dims.x(), texture.grid.dims.y(), texture.grid.dims.z(), bake,
        r.max / kDiagonal, r.mean / kDiagonal, r.texels);
  }
}

TEST(ControlPoints, InverseIsFiniteForAnyFiniteInput) {
  const double big = std::numeric_limits<double>::max();
  const double tiny = std::numeric_limits<double>::denorm_min();
  std::mt19937_64 rng(6);
  for (const Config& config : kConfigs) {
    const auto pinned = pins(config.pinned);
    const auto cp = make_control_points(kHalf, random_pairs(rng, 20, 0.5), config.radius, pinned);
    for (const Eigen::Vector3d& p :
         {Eigen::Vector3d(big, -big, big), Eigen::Vector3d(tiny, 0.0, -tiny),
          Eigen::Vector3d(1e200, 1e-200, -1e100), Eigen::Vector3d(3.0, -5.0, 0.1)}) {
      EXPECT_TRUE(cp->inverse(p).allFinite()) << config.name;
      EXPECT_TRUE(cp->forward(p).allFinite()) << config.name;
      EXPECT_TRUE(cp->jacobian(p).allFinite()) << config.name;
    }
  }
}

// ------------------------------------------------------------------------------------------------
// 4. Reproducing a twist.

// The bunny_twist example's box and mesh.
struct BunnyScene {
  Scene scene;
  Mesh mesh;
  Camera camera;
  DistanceGrid sdf;
};
const BunnyScene& bunny() {
  static const BunnyScene scene = [] {
    const std::string root = RAYWARP_SOURCE_DIR;
    BunnyScene s;
    s.scene = load_scene(root + "/examples/bunny_twist.json");
    s.mesh = load_mesh(s.scene.mesh.string());
    s.camera = load_camera(root + "/examples/cameras/front.json");
    s.sdf = bake_distance_grid(s.mesh, s.scene.boxes.at(0).box, s.scene.boxes.at(0).implicit);
    return s;
  }();
  return scene;
}

// Control points on an n^3 lattice over the box, targets the twist's forward map.
std::unique_ptr<Deformer> twist_by_points(const Eigen::Vector3d& h, const Deformer& twist, int n,
                                          double radius, const std::array<bool, 6>& pinned) {
  std::vector<ControlPoint> points;
  for (const Eigen::Vector3d& s : lattice(h, n)) points.push_back({s, twist.forward(s)});
  return make_control_points(h, points, radius, pinned);
}

// F of the control points against the twist's forward map, at random points in the box.
struct FieldError {
  double max = 0, mean = 0;
};
FieldError field_error(const Deformer& a, const Deformer& b, const Eigen::Vector3d& h) {
  std::mt19937_64 rng(7);
  FieldError e;
  const int samples = 5000;
  for (int n = 0; n < samples; ++n) {
    const Eigen::Vector3d p = random_point(rng, h);
    const double err = (a.forward(p) - b.forward(p)).norm();
    e.max = std::max(e.max, err);
    e.mean += err / samples;
  }
  return e;
}

TEST(ControlPoints, ReproducesATwistField) {
  const Eigen::Vector3d h = bunny().scene.boxes.at(0).box.half_extents;
  const double diagonal = 2.0 * h.norm();
  const auto twist = make_twist(h, Axis::Y, 90.0);
  double previous = std::numeric_limits<double>::infinity();
  for (int n : {4, 5, 6, 7}) {
    const auto cp = twist_by_points(h, *twist, n, 0.0, pins("-y"));
    const FieldError e = field_error(*cp, *twist, h);
    std::printf(
        "[figures] twist 90 deg about y by %d^3 control points (global, pinned -y): |F - "
        "F_twist| / L max %.3g, mean %.3g\n",
        n, e.max / diagonal, e.mean / diagonal);
    EXPECT_LT(e.max, previous);  // converges as the lattice refines
    previous = e.max;
    if (n == 6) {
      EXPECT_LE(e.max, 0.01 * diagonal);
      EXPECT_FALSE(measure_folds(*cp, h, 24).folds());
    }
  }
  // A full turn by 9^3 points is too twisted for them: the field folds at the box's vertical edges
  // (det(dF/dp) down to -0.45), which the warning reports.
  {
    const auto full_turn = make_twist(h, Axis::Y, 360.0);
    std::vector<ControlPoint> points;
    for (const Eigen::Vector3d& s : lattice(h, 9)) points.push_back({s, full_turn->forward(s)});
    std::vector<std::string> warnings;
    make_control_points(h, points, 0.0, pins("-y"), &warnings);
    find_warning(warnings, "the deformation folds space");
  }
  // The local kernel with a radius of two lattice spacings, for comparison.
  const double spacing = (2.0 * h / 5.0).maxCoeff();
  const auto local = twist_by_points(h, *twist, 6, 2.0 * spacing, pins("-y"));
  const FieldError e = field_error(*local, *twist, h);
  std::printf(
      "[figures] twist 90 deg by 6^3 control points (local, radius %.3g, pinned -y): |F - F_twist| "
      "/ L max %.3g, mean %.3g\n",
      2.0 * spacing, e.max / diagonal, e.mean / diagonal);
}

gl::Context& context() {
  static auto ctx = gl::create_osmesa_context();
  return *ctx;
}

// The box's textures as prepare_scene (library/prepare.h) builds them, for `deformer`.
BoxTextures box_textures(const BunnyScene& s, const Deformer& deformer) {
  const BoxSpec& spec = s.scene.boxes.at(0);
  BoxTextures tex;
  tex.box = spec.box;
  tex.sdf = s.sdf;
  tex.deformation = bake_deformation(deformer, spec.box.half_extents, kAutoFloorResolution);
  tex.region = Eigen::AlignedBox3d(tex.deformation.grid.origin, tex.deformation.grid.upper());
  tex.lipschitz = displacement_lipschitz(deformer, tex.deformation);
  if (s.scene.render.texture_bits == 16) round_textures_to_half(tex);
  if (s.scene.render.sampling == Sampling::Bounded)
    tex.step_bounds = bake_step_bounds(tex.sdf, tex.deformation);
  return tex;
}

TEST(ControlPoints, RendersATwistLikeTheTwist) {
  constexpr int kSize = 256;
  const BunnyScene& s = bunny();
  const Box& box = s.scene.boxes.at(0).box;
  const Eigen::Vector3d h = box.half_extents;
  const auto twist = make_twist(h, Axis::Y, 90.0);
  const auto cp = twist_by_points(h, *twist, 6, 0.0, pins("-y"));

  const auto start = std::chrono::steady_clock::now();
  const BoxTextures tex = box_textures(s, *cp);
  const double bake =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const InverseResidual residual =
      measure_inverse_residual(*cp, tex.deformation, 1e-6 * box.diagonal());
  EXPECT_EQ(residual.over_tolerance, 0);
  EXPECT_EQ(residual.folded, 0);
  const BoxTextures twist_tex = box_textures(s, *twist);

  context();
  gl::Renderer renderer;
  renderer.set_mesh(s.mesh);
  gl::FrameStats stats;
  renderer.set_boxes({tex});
  const Image image = renderer.render(s.camera, kSize, kSize, s.scene.render, &stats);
  EXPECT_EQ(stats.nonfinite_pixels, 0);
  renderer.set_boxes({twist_tex});
  const Image twist_image = renderer.render(s.camera, kSize, kSize, s.scene.render, &stats);

  const double quarter_voxel = 0.25 * s.sdf.grid.voxel();
  const Mesh truth_mesh = ground_truth_mesh(
      s.mesh, box, [&](const Eigen::Vector3d& p) { return twist->forward(p); }, quarter_voxel);
  const Image truth = rasterize(truth_mesh, s.camera, kSize, kSize, s.scene.render);
  const double diagonal = mesh_bounds(truth_mesh).diagonal().norm();
  const ImageComparison vs_truth = compare_images(image, truth, 0.01 * diagonal);
  const ImageComparison twist_vs_truth = compare_images(twist_image, truth, 0.01 * diagonal);
  std::filesystem::create_directories("control_points_test_images");
  write_png("control_points_test_images/bunny_twist90_points_gl.png", image);
  write_png("control_points_test_images/bunny_twist90_analytic_gl.png", twist_image);
  write_png("control_points_test_images/bunny_twist90_truth.png", truth);
  std::printf(
      "[figures] bunny, twist 90 deg about y by 6^3 control points (global, pinned -y): texture "
      "%dx%dx%d baked in %.2f s, inverse residual / L max %.3g mean %.3g over %ld texels; GL vs "
      "the twist's ground truth: IoU %.4f, over 1%% of diag %.2f%%, mean depth err %.4g; the "
      "analytic twist through the same pipeline: IoU %.4f, over %.2f%%\n",
      tex.deformation.grid.dims.x(), tex.deformation.grid.dims.y(), tex.deformation.grid.dims.z(),
      bake, residual.max / box.diagonal(), residual.mean / box.diagonal(), residual.texels,
      vs_truth.iou, 100.0 * vs_truth.fraction_over, vs_truth.mean_depth_error, twist_vs_truth.iou,
      100.0 * twist_vs_truth.fraction_over);
  EXPECT_GE(vs_truth.iou, 0.98);
  EXPECT_LE(vs_truth.fraction_over, 0.02);
}

// ------------------------------------------------------------------------------------------------
// 5. Ill-posed input.

void expect_error(const std::function<void()>& make, const std::string& needle) {
  try {
    make();
    ADD_FAILURE() << "no error; expected one containing \"" << needle << "\"";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    std::printf("[figures] error: %s\n", e.what());
  }
}

TEST(ControlPoints, RejectsIllPosedInput) {
  std::mt19937_64 rng(8);
  const auto base = random_pairs(rng, 8, 0.1);
  auto with = [&](const std::function<void(std::vector<ControlPoint>&)>& edit) {
    std::vector<ControlPoint> points = base;
    edit(points);
    return points;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  expect_error([&] { make_control_points(kHalf, {}, 0.0, pins("")); }, "points: none given");
  expect_error(
      [&] {
        make_control_points(kHalf, with([&](auto& p) { p[3].source.y() = nan; }), 0.0, pins(""));
      },
      "points[3].source");
  expect_error(
      [&] {
        make_control_points(kHalf, with([&](auto& p) { p[6].target.z() = inf; }), 0.0, pins(""));
      },
      "points[6].target");
  expect_error(
      [&] {
        make_control_points(kHalf, with([&](auto& p) { p[2].source.x() = 1.01 * kHalf.x(); }), 0.0,
                            pins(""));
      },
      "points[2].source");
  expect_error(
      [&] {
        make_control_points(kHalf, with([&](auto& p) {
                              p[5].source = p[2].source + Eigen::Vector3d(1e-7, 0.0, 0.0);
                            }),
                            0.5, pins(""));
      },
      "points[2] and points[5] have coincident sources");
  expect_error(
      [&] {
        make_control_points(kHalf, with([&](auto& p) { p[4].source.y() = -kHalf.y(); }), 0.0,
                            pins("-y"));
      },
      "points[4] lies on pinned face -y");
  for (double radius : {-1.0, nan, inf})
    expect_error([&] { make_control_points(kHalf, base, radius, pins("")); }, "radius = ");
  expect_error([&] { make_control_points(Eigen::Vector3d(1, 0, 1), base, 0.0, pins("")); },
               "half_extents[1]");

  // A source within 1e-9 L outside the box is accepted (onto the face), as is a held source on a
  // pinned face.
  EXPECT_NO_THROW(make_control_points(
      kHalf, with([&](auto& p) { p[1].source.x() = kHalf.x() * (1.0 + 1e-12); }), 0.0, pins("")));
  EXPECT_NO_THROW(make_control_points(kHalf, with([&](auto& p) {
                                        p[4].source.y() = -kHalf.y();
                                        p[4].target = p[4].source;
                                      }),
                                      0.0, pins("-y")));
}

TEST(ControlPoints, Warnings) {
  std::vector<ControlPoint> points = {
      {Eigen::Vector3d(0.6, 0.0, 0.0), Eigen::Vector3d(0.9, 0, 0)},
      {Eigen::Vector3d(-0.6, 0.0, 0.0), Eigen::Vector3d(-0.6, 0, 0)}};
  std::vector<std::string> warnings;
  EXPECT_NO_THROW(make_control_points(kHalf, points, 0.0, pins(""), &warnings));
  ASSERT_EQ(warnings.size(), 1u);
  find_warning(warnings, "1 of the 2 targets lie outside the box (points[0])");
  // Moving further than the distance to a pinned face: steep, here folding.
  warnings.clear();
  points[1].target = Eigen::Vector3d(-0.6, 1.0, 0.0);
  make_control_points(kHalf, points, 0.0, pins("-x"), &warnings);
  EXPECT_NE(find_warning(warnings, "points[1] moves by 1 but lies ").find("pinned face -x"),
            std::string::npos);
  // A gentle field (sources on the faces moved outwards, though) warns of nothing else.
  warnings.clear();
  std::mt19937_64 rng(10);
  make_control_points(kHalf, gentle_pairs(rng, pins("-y")), 0.0, pins("-y"), &warnings);
  EXPECT_EQ(warnings.size(), 1u);
  find_warning(warnings, "targets lie outside the box");
}

TEST(ControlPoints, FoldingSetStaysFinite) {
  // Two nearby sources with crossed targets, the box corners held: space must fold between them.
  for (double radius : {0.0, 0.8}) {
    std::vector<ControlPoint> points = {
        {Eigen::Vector3d(-0.1, 0.0, 0.0), Eigen::Vector3d(0.15, 0.0, 0.0)},
        {Eigen::Vector3d(0.1, 0.0, 0.0), Eigen::Vector3d(-0.15, 0.0, 0.0)}};
    for (const Eigen::Vector3d& corner : lattice(kHalf, 2)) points.push_back({corner, corner});
    const auto cp = make_control_points(kHalf, points, radius, pins(""));
    const FoldReport folds = measure_folds(*cp, kHalf, 32);
    EXPECT_TRUE(folds.folds()) << cp->describe();
    std::vector<std::string> warnings;
    make_control_points(kHalf, points, radius, pins(""), &warnings);
    find_warning(warnings, "the deformation folds space");
    DeformationTexture texture;
    ASSERT_NO_THROW(texture = bake_deformation(*cp, kHalf, 40)) << cp->describe();
    long nonfinite = 0;
    for (const Eigen::Vector4f& texel : texture.grid.data) nonfinite += !texel.allFinite();
    EXPECT_EQ(nonfinite, 0);
    const InverseResidual r = measure_inverse_residual(*cp, texture, 1e-6 * kDiagonal);
    EXPECT_GT(r.folded, 0) << cp->describe();
    std::printf(
        "[figures] folding set (%s): folded %.2f %% of the box; baked texture: %ld valid texels, "
        "%ld with a folded preimage, %ld over tolerance, residual / L max %.3g mean %.3g\n",
        cp->describe().c_str(), 100.0 * folds.folded_volume / folds.box_volume, r.texels, r.folded,
        r.over_tolerance, r.max / kDiagonal, r.mean / kDiagonal);
  }
}

TEST(ControlPoints, IllConditionedSystemIsReported) {
  // Two sources just above the coincidence limit that move apart: the global system's condition
  // grows like the inverse cube of their distance.
  std::vector<ControlPoint> points;
  for (const Eigen::Vector3d& corner : lattice(kHalf, 2)) points.push_back({corner, corner});
  const Eigen::Vector3d s(0.1, 0.2, 0.0);
  points.push_back({s, s + Eigen::Vector3d(0.1, 0.0, 0.0)});
  points.push_back({s + Eigen::Vector3d(2e-6 * kDiagonal, 0.0, 0.0), s});
  expect_error([&] { make_control_points(kHalf, points, 0.0, pins("")); }, "ill-conditioned");
}

}  // namespace
}  // namespace raywarp
