// The detail deformer (deformers/detail.h) and a list that adds it (deformers/composed.h,
// AddedDetail): the map's forward, exact inverse and analytic Jacobian, its identity faces,
// determinism of the seed, the refusal of scales that could fold; then the summed inverse
// displacement of [twist 90, detail] against the exact composition, baked and measured as the
// bake measures it (measure_inverse_residual, measure_added_detail), at several scales; and the
// bake's report of it, also when read back from the disk cache.
#include "deformers/detail.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "base/box.h"
#include "base/error.h"
#include "base/json_reader.h"
#include "deformers/composed.h"
#include "deformers/registry.h"
#include "deformers/twist.h"
#include "library/added_detail.h"
#include "library/bake.h"
#include "library/bake_cache.h"
#include "library/deformation_bake.h"
#include "library/scene.h"
#include "tests/sanitizer.h"

namespace raywarp {
namespace {

const Eigen::Vector3d kHalf(1.0, 1.5, 1.0);

Eigen::Vector3d random_point(std::mt19937& rng, double scale = 1.0) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  return scale * Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).cwiseProduct(kHalf);
}

std::string refusal(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(accepted)";
}

// At 0.95 of the largest accepted scale, the strongest detail of this wavelength.
TEST(Detail, ForwardInverseAndJacobian) {
  const double wavelength = 0.5;
  const double s = 0.95 * detail_max_scale(kHalf, wavelength, 7);
  const auto f = make_detail(kHalf, s, wavelength, 7);
  std::mt19937 rng(11);
  double worst_round = 0, worst_back = 0, worst_jacobian = 0, worst_contraction = 0,
         largest_move = 0, smallest_det = 1e300;
  const double e = 1e-6;
  for (int n = 0; n < 3000; ++n) {
    const Eigen::Vector3d p = random_point(rng);
    const Eigen::Vector3d q = f->forward(p);
    largest_move = std::max(largest_move, (q - p).norm());
    const Eigen::Vector3d back = f->inverse(q);
    worst_back = std::max(worst_back, (back - p).norm());
    worst_round = std::max(worst_round, (f->forward(back) - q).norm());
    Eigen::Matrix3d numeric;
    for (int a = 0; a < 3; ++a) {
      const Eigen::Vector3d d = e * Eigen::Vector3d::Unit(a);
      numeric.col(a) = (f->forward(p + d) - f->forward(p - d)) / (2 * e);
    }
    const Eigen::Matrix3d J = f->jacobian(p);
    worst_jacobian = std::max(worst_jacobian, (J - numeric).norm());
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(J - Eigen::Matrix3d::Identity());
    worst_contraction = std::max(worst_contraction, svd.singularValues()[0]);
    smallest_det = std::min(smallest_det, J.determinant());
  }
  std::printf(
      "[figures] detail scale %.4g (0.95 of the largest), wavelength %g: |F^-1(F(p)) - p| max "
      "%.3g, |F(F^-1(p')) - p'| max %.3g, |J - central difference| max %.3g, |J - I| max %.3f "
      "(bound %.3f), det J min %.3f, |F(p) - p| max %.4g\n",
      s, wavelength, worst_back, worst_round, worst_jacobian, worst_contraction,
      0.95 * kMaxDetailContraction, smallest_det, largest_move);
  EXPECT_LE(worst_back, 1e-12);
  EXPECT_LE(worst_round, 1e-12);
  EXPECT_LE(worst_jacobian, 1e-7);
  // The stated bound holds: |J - I| <= s L <= 1/2, so F does not fold.
  EXPECT_LE(worst_contraction, 0.95 * kMaxDetailContraction + 1e-12);
  EXPECT_GT(smallest_det, 0.0);
  EXPECT_LE(largest_move, s);
  EXPECT_GT(largest_move, 0.2 * s);  // the noise is not negligible against its bound
}

TEST(Detail, IdentityOnTheFacesAndOutside) {
  const auto f = make_detail(kHalf, 0.02, 0.4, 3);
  for (bool face : f->identity_faces()) EXPECT_TRUE(face);
  std::mt19937 rng(12);
  for (int n = 0; n < 600; ++n) {
    Eigen::Vector3d p = random_point(rng);
    const int axis = n % 3;
    p[axis] = (n / 3) % 2 ? kHalf[axis] : -kHalf[axis];
    EXPECT_EQ(f->forward(p), p) << p.transpose();
    EXPECT_EQ(f->inverse(p), p) << p.transpose();
    EXPECT_TRUE(f->jacobian(p).isIdentity(0.0)) << p.transpose();
    const Eigen::Vector3d outside = random_point(rng, 3.0);
    if ((outside.cwiseAbs() - kHalf).maxCoeff() >= 0.0) {
      EXPECT_EQ(f->forward(outside), outside);
    }
  }
  // Near a face the displacement falls off as the square of the distance (w is C^1): 1e-3 from
  // the face, u = 1e-3 / 0.4 (the margin is the wavelength) and S(u) <= 3 u^2.
  const Eigen::Vector3d near_face(0.3, 1.5 - 1e-3, -0.2);
  const double move = (f->forward(near_face) - near_face).norm();
  EXPECT_LE(move, 0.02 * 3 * std::pow(1e-3 / 0.4, 2));
  EXPECT_GT(move, 0.0);
}

TEST(Detail, SeedPicksTheNoise) {
  const auto a = make_detail(kHalf, 0.02, 0.5, 7);
  const auto b = make_detail(kHalf, 0.02, 0.5, 7);
  const auto c = make_detail(kHalf, 0.02, 0.5, 8);
  std::mt19937 rng(13);
  double differs = 0;
  for (int n = 0; n < 200; ++n) {
    const Eigen::Vector3d p = random_point(rng);
    EXPECT_EQ(a->forward(p), b->forward(p));  // bit for bit
    EXPECT_EQ(a->inverse(p), b->inverse(p));
    differs = std::max(differs, (a->forward(p) - c->forward(p)).norm());
  }
  EXPECT_GT(differs, 0.005);
  EXPECT_EQ(a->describe(), "detail noise of scale 0.02, wavelength 0.5, seed 7");
  EXPECT_EQ(detail_lipschitz(kHalf, 0.5, 7), detail_lipschitz(kHalf, 0.5, 7));
  // The bound grows as the wavelength shrinks (the noise's slope is 2 pi / lambda).
  EXPECT_GT(detail_lipschitz(kHalf, 0.25, 7), 1.5 * detail_lipschitz(kHalf, 0.5, 7));
}

TEST(Detail, RefusesScalesThatCouldFold) {
  const double max_scale = detail_max_scale(kHalf, 0.5, 7);
  EXPECT_EQ(refusal([&] { make_detail(kHalf, max_scale, 0.5, 7); }), "(accepted)");
  EXPECT_EQ(refusal([&] { make_detail(kHalf, 0.0, 0.5, 7); }), "(accepted)");
  const std::string m = refusal([&] { make_detail(kHalf, 1.01 * max_scale, 0.5, 7); });
  EXPECT_EQ(m.rfind("scale = ", 0), 0u) << m;
  EXPECT_NE(m.find("must be in [0, "), std::string::npos) << m;
  EXPECT_NE(m.find("fold"), std::string::npos) << m;
  for (double bad : {-0.01, std::nan(""), HUGE_VAL})
    EXPECT_EQ(refusal([&] { make_detail(kHalf, bad, 0.5, 7); }).rfind("scale = ", 0), 0u);
  for (double bad : {0.0, -1.0, HUGE_VAL})
    EXPECT_EQ(refusal([&] { make_detail(kHalf, 0.01, bad, 7); }).rfind("wavelength = ", 0), 0u);
  EXPECT_EQ(refusal([&] { make_detail(kHalf, 0.01, 0.5, 1ULL << 32); }).rfind("seed = ", 0), 0u);

  // The limit the message gives is accepted (rounded down), through the registry.
  const size_t at = m.find("must be in [0, ") + 15;
  const double said = std::stod(m.substr(at));
  EXPECT_LE(said, max_scale);
  EXPECT_GT(said, 0.99 * max_scale);
  DeformerSpec d;
  d.type = "detail";
  d.scale = said;
  d.wavelength = 0.5;
  d.seed = 7;
  EXPECT_NO_THROW(make_deformer(d, kHalf));
  // Wavelength 0: a quarter of the box's shortest side.
  d.wavelength = 0;
  d.scale = 0.01;
  EXPECT_EQ(make_deformer(d, kHalf)->describe(),
            "detail noise of scale 0.01, wavelength 0.5, seed 7");
}

Box unit_box() {
  Box box;
  box.half_extents = kHalf;
  return box;
}

TEST(Detail, SceneReaderRefusesAFractionalSeed) {
  const JsonReader r("detail.json");
  const std::string m = refusal([&] {
    read_deformer(r, nlohmann::json::parse(R"({"type": "detail", "scale": 0.01, "seed": 1.5})"),
                  "boxes[0].deformer[1]", unit_box());
  });
  EXPECT_NE(m.find("boxes[0].deformer[1].seed"), std::string::npos) << m;
  EXPECT_NE(m.find("whole number"), std::string::npos) << m;
}

// A list: detail entries come last and are added; the list means the composition.
TEST(AddedDetail, ForwardComposesInverseAdds) {
  std::shared_ptr<const Deformer> twist = make_twist(kHalf, Axis::Y, 90);
  std::shared_ptr<const Deformer> detail = make_detail(kHalf, 0.02, 0.5, 7);
  const auto list = make_composed({twist, detail});
  const auto* added = dynamic_cast<const AddedDetail*>(list.get());
  ASSERT_NE(added, nullptr);
  EXPECT_EQ(added->rest_count(), 1u);
  EXPECT_EQ(added->detail_count(), 1u);
  EXPECT_EQ(list->describe(), twist->describe() + ", plus added " + detail->describe());
  std::mt19937 rng(14);
  double worst_exact = 0, largest_gap = 0;
  for (int n = 0; n < 500; ++n) {
    const Eigen::Vector3d p = random_point(rng);
    const Eigen::Vector3d q = list->forward(p);
    EXPECT_EQ(q, detail->forward(twist->forward(p)));
    worst_exact = std::max(worst_exact, (added->exact_inverse(q) - p).norm());
    const Eigen::Vector3d summed = twist->inverse(q) + (detail->inverse(q) - q);
    EXPECT_LE((list->inverse(q) - summed).norm(), 1e-15);
    largest_gap = std::max(largest_gap, (list->inverse(q) - p).norm());
  }
  EXPECT_LE(worst_exact, 1e-12);
  // Adding is not composing: the summed inverse misses p by a fraction of the detail's scale.
  EXPECT_GT(largest_gap, 1e-4);
  EXPECT_LT(largest_gap, 3 * 0.02);

  // A detail before another deformer is refused, naming its index.
  const std::string m = refusal([&] { make_composed({detail, twist}); });
  EXPECT_EQ(m.rfind("[0] (detail", 0), 0u) << m;
  EXPECT_NE(m.find("list it after every other deformer"), std::string::npos) << m;
  // Details only: the sum of one detail is its exact inverse.
  const auto alone = make_composed({detail});
  const Eigen::Vector3d p(0.3, -0.4, 0.2);
  EXPECT_LE((alone->forward(alone->inverse(p)) - p).norm(), 1e-12);
}

struct SumFigures {
  InverseResidual residual;
  AddedDetailFigures difference;
  double seconds = 0;
};

// [twist 90 about y, detail of scale s], baked at `resolution` and measured as the bake does.
SumFigures bake_sum(double s, int resolution) {
  std::shared_ptr<const Deformer> twist = make_twist(kHalf, Axis::Y, 90);
  std::shared_ptr<const Deformer> detail = make_detail(kHalf, s, 0.5, 7);
  const auto list = make_composed({twist, detail});
  const auto& added = dynamic_cast<const AddedDetail&>(*list);
  SumFigures out;
  const DeformationTexture texture = bake_deformation(*list, kHalf, resolution);
  out.seconds = texture.bake_seconds;
  out.residual = measure_inverse_residual(*list, texture, 1e-6);
  out.difference = measure_added_detail(added, kHalf, texture);
  return out;
}

// The summed inverse of [twist 90, detail] against the exact composition, at scales s, 2 s and
// 4 s (s = a quarter of the largest accepted). A bound of the residual: with x = R^-1(p'),
// delta = F_d^-1(p') - p' (|delta| <= s) and q = p' + delta, the texel's point is x + delta, and
//   |F(x + delta) - p'| = |F_d(R(x + delta)) - F_d(q)| <= (1 + 1/2) |R(x + delta) - R(x) - delta|
//                      <= 1.5 max |J_R - I| s,
// |J_R - I| <= |R_theta - I| + r |dtheta/dy| <= 2 sin(45 deg) + r_max (pi / 2) / 3 for the twist
// by 90 degrees over the box's 3 units along y, r_max the largest distance from the axis the
// texels' points reach (|(h_x, h_z)| + 2 s). |D - D_exact| = |R^-1(p') + delta - R^-1(p' + delta)|
// has the same bound without the 1.5.
TEST(AddedDetail, SummedInverseResidualGrowsWithScale) {
  const int resolution = raywarp::testing::kSmallGrid;
  const double max_scale = detail_max_scale(kHalf, 0.5, 7);
  const double diagonal = 2.0 * kHalf.norm();
  std::vector<SumFigures> runs;
  std::vector<double> scales;
  for (double f : {0.25, 0.5, 1.0}) {
    const double s = f * max_scale;
    scales.push_back(s);
    runs.push_back(bake_sum(s, resolution));
    const SumFigures& r = runs.back();
    const double j_bound =
        2.0 * std::sin(M_PI / 4) + (std::hypot(kHalf.x(), kHalf.z()) + 2 * s) * (M_PI / 2) / 3.0;
    std::printf(
        "[figures] twist 90 + detail scale %.4g (box diagonal %.3g), %d texels along the longest "
        "side: residual |F(p' + D) - p'| max %.3g (%.2f %% of the diagonal, %.2f times the scale), "
        "mean %.3g "
        "(%.3f %%); |D - D_exact| max %.3g (%.2f %%), mean %.3g; bound of the residual %.3g; bake "
        "%.2f s over %ld texels\n",
        s, diagonal, resolution, r.residual.max, 100 * r.residual.max / diagonal,
        r.residual.max / s, r.residual.mean, 100 * r.residual.mean / diagonal,
        r.difference.difference_max, 100 * r.difference.difference_max / diagonal,
        r.difference.difference_mean, 1.5 * j_bound * s, r.seconds, r.residual.texels);
    EXPECT_GT(r.residual.texels, 1000);
    EXPECT_EQ(r.difference.texels, r.residual.texels);
    EXPECT_LE(r.residual.max, 1.5 * j_bound * s);
    EXPECT_LE(r.difference.difference_max, j_bound * s + 1e-6);
    EXPECT_GT(r.residual.max, 0.05 * s);  // measured, not float noise
  }
  for (size_t i = 1; i < runs.size(); ++i) {
    // Linear in s to first order: doubling s doubles the residual, within 25 %.
    const double ratio = runs[i].residual.max / runs[i - 1].residual.max;
    const double mean_ratio = runs[i].residual.mean / runs[i - 1].residual.mean;
    EXPECT_GT(ratio, 1.5) << scales[i];
    EXPECT_LT(ratio, 2.5) << scales[i];
    EXPECT_GT(mean_ratio, 1.5) << scales[i];
    EXPECT_LT(mean_ratio, 2.5) << scales[i];
    EXPECT_GT(runs[i].difference.difference_max, runs[i - 1].difference.difference_max);
  }
  // Small for a small scale: under 0.5 % of the box diagonal at a quarter of the largest.
  EXPECT_LT(runs[0].residual.max, 0.005 * diagonal);
}

// Without a rest the sum is the detail's exact inverse: the residual is the float storage's.
TEST(AddedDetail, ADetailAloneHasNoSummationResidual) {
  std::shared_ptr<const Deformer> detail = make_detail(kHalf, 0.05, 0.8, 2);
  const auto list = make_composed({detail});
  const DeformationTexture texture = bake_deformation(*list, kHalf, raywarp::testing::kSmallGrid);
  const InverseResidual r = measure_inverse_residual(*list, texture, 1e-6);
  const AddedDetailFigures d =
      measure_added_detail(dynamic_cast<const AddedDetail&>(*list), kHalf, texture);
  EXPECT_LE(r.max, 1e-6);
  EXPECT_LE(d.difference_max, 1e-6);
}

namespace fs = std::filesystem;

// The bake reports both figures for a list that adds detail, with no inverse_residual warning,
// and reads them back from the disk cache.
TEST(AddedDetail, BakeReportsTheSummationResidual) {
  const fs::path dir =
      fs::temp_directory_path() / ("raywarp_detail_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path scene_file = dir / "scene.json";
  std::ofstream(scene_file) << R"({"mesh": ")" << RAYWARP_SOURCE_DIR
                            << R"(/examples/meshes/bunny.ply", "boxes": [{
      "min": [-5.2, 1.93, -4.0], "max": [5.2, 7.72, 4.0],
      "deformer": [{"type": "twist", "axis": "y", "angle_deg": 90},
                   {"type": "detail", "scale": 0.1, "wavelength": 1.5, "seed": 7}],
      "implicit": {"type": "sdf", "resolution": 48}, "deformation": {"resolution": 48}}]})";
  Scene scene = load_scene(scene_file);
  BakeCache cache(dir / "cache");
  BakeReport first, second;
  {
    BakeSession session(&cache);
    first = session.bake(make_job(scene, 0, session.mesh(scene.mesh))).report;
  }
  {
    BakeSession session(&cache);
    const BakedBox box = session.bake(make_job(scene, 0, session.mesh(scene.mesh)));
    second = box.report;
    EXPECT_EQ(second.stage(Stage::Deformation)->source, Source::Disk);
    // The figures are those of the texture and deformer.
    const auto& added = dynamic_cast<const AddedDetail&>(*box.deformer);
    const AddedDetailFigures again =
        measure_added_detail(added, scene.boxes[0].box.half_extents, box.textures.deformation);
    ASSERT_TRUE(second.added_detail);
    EXPECT_EQ(second.added_detail->difference_max, again.difference_max);
  }
  for (const BakeReport* r : {&first, &second}) {
    ASSERT_TRUE(r->added_detail);
    EXPECT_GT(r->added_detail->texels, 1000);
    EXPECT_GT(r->added_detail->difference_max, 0.0);
    EXPECT_LE(r->added_detail->difference_max, 3 * 0.1);
    EXPECT_GT(r->residual.max, 0.0);
    EXPECT_NEAR(r->added_detail->box_diagonal, 2.0 * scene.boxes[0].box.half_extents.norm(), 1e-12);
    for (const BakeWarning& w : r->warnings) EXPECT_NE(w.code, "inverse_residual") << w.message;
    EXPECT_NE(r->deformer.find("plus added detail noise"), std::string::npos) << r->deformer;
  }
  EXPECT_EQ(first.added_detail->difference_max, second.added_detail->difference_max);
  EXPECT_EQ(first.residual.max, second.residual.max);

  // A twist alone has no such figures.
  scene.boxes[0].then.clear();
  BakeSession session;
  EXPECT_FALSE(session.bake(make_job(scene, 0, session.mesh(scene.mesh))).report.added_detail);

  // A scale that could fold is refused at the bake, naming the file and the field.
  scene.boxes[0].then.push_back(DeformerSpec{});
  scene.boxes[0].then[0].type = "detail";
  scene.boxes[0].then[0].scale = 5.0;
  const std::string m =
      refusal([&] { session.bake(make_job(scene, 0, session.mesh(scene.mesh))); });
  EXPECT_NE(m.find("scene.json: boxes[0].deformer[1].scale = 5: must be in [0, "),
            std::string::npos)
      << m;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace raywarp
