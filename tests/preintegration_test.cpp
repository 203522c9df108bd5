// Pre-integrated transfer functions (library/preintegration.h): the quadrature reference against
// closed forms, the incremental table (Lum, Ma & Clyne 2004) against the reference at its nodes
// and at random (s_front, s_back, length), and the refusals of bad inputs.
#include "library/preintegration.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "base/error.h"

namespace raywarp {
namespace {

using Vec3 = Eigen::Vector3d;

// A transfer function with a control point every 1/8 over [0, 1]: colours that turn and τ from 0
// to 3 per unit, non-monotonic.
TransferFunction ramp() {
  TransferFunction tf;
  const double tau[9] = {0.0, 0.4, 1.5, 0.8, 2.2, 3.0, 1.2, 0.3, 2.0};
  for (int i = 0; i <= 8; ++i) {
    const double s = i / 8.0;
    tf.points.push_back(
        {s, Vec3(0.5 + 0.5 * std::cos(6.0 * s), 0.5 + 0.5 * std::sin(5.0 * s), s * s), tau[i]});
  }
  return tf;
}

// A smooth transfer function sampled at 129 control points over [0, 1] (one on every node of a
// 129-node table): τ from 0.4 to 2.0 per unit, colours that turn. The table's error near the
// diagonal s_front = s_back grows with the slope jumps between control points (docs/tet_walk.md),
// which sampling a smooth curve keeps small.
TransferFunction smooth() {
  TransferFunction tf;
  for (int i = 0; i <= 128; ++i) {
    const double s = i / 128.0;
    tf.points.push_back(
        {s, Vec3(0.5 + 0.4 * std::cos(4.0 * s), 0.5 + 0.4 * std::sin(3.0 * s), 0.2 + 0.6 * s * s),
         1.2 + 0.5 * std::sin(2.0 * M_PI * s) + 0.3 * std::cos(3.0 * s)});
  }
  return tf;
}

double difference(const SegmentColour& a, const SegmentColour& b) {
  return std::max((a.colour - b.colour).cwiseAbs().maxCoeff(), std::abs(a.alpha - b.alpha));
}

TEST(Preintegration, ConstantScalarHasTheClosedForm) {
  const TransferFunction tf = ramp();
  double worst = 0.0;
  for (double s : {0.0, 0.1, 0.3125, 0.5, 0.77, 1.0, 1.5, -0.2})
    for (double l : {0.0, 1e-6, 0.05, 0.5, 1.0, 3.0}) {
      const Eigen::Vector4d v = tf.at(s);
      SegmentColour closed;
      closed.alpha = 1.0 - std::exp(-v[3] * l);
      closed.colour = v.head<3>() * (1.0 - std::exp(-v[3] * l));
      worst = std::max(worst, difference(preintegrate_exact(tf, s, s, l), closed));
      worst = std::max(worst, difference(preintegrate_constant(tf, s, l), closed));
    }
  std::printf("[figures] constant scalar: quadrature against 1 - exp(-tau l): %.2e\n", worst);
  EXPECT_LT(worst, 1e-13);
}

// Optically thick segments (τ l up to 3e4, τ up to the allowed 1e6 per unit): the colour of an
// opaque segment is the colour where it starts, for the quadrature, for one panel (as a table's
// slab is integrated) and for the table itself; with τ rising linearly from 0, the closed form
// C = c (1 - exp(-τ_b l / 2)) of a constant colour.
TEST(Preintegration, OpticallyThickSegmentsKeepTheirColour) {
  TransferFunction opaque;
  opaque.points.push_back({0.0, Vec3(1.0, 0.2, 0.0), 1e6});
  double worst = 0.0;
  for (double l : {1e-5, 3e-3, 0.03})
    for (int panels : {1, 256}) {
      SegmentColour closed;
      closed.alpha = 1.0 - std::exp(-1e6 * l);
      closed.colour = Vec3(1.0, 0.2, 0.0) * closed.alpha;
      worst = std::max(worst, difference(preintegrate_exact(opaque, 0.0, 0.0, l, panels), closed));
    }
  TransferFunction rising;
  rising.points.push_back({0.0, Vec3(0.3, 0.6, 0.9), 0.0});
  rising.points.push_back({1.0, Vec3(0.3, 0.6, 0.9), 2e4});
  for (double l : {1e-3, 0.1, 3.0}) {
    SegmentColour closed;
    closed.alpha = 1.0 - std::exp(-2e4 * l / 2.0);
    closed.colour = Vec3(0.3, 0.6, 0.9) * closed.alpha;
    for (int panels : {1, 256})
      worst = std::max(worst, difference(preintegrate_exact(rising, 0.0, 1.0, l, panels), closed));
  }
  std::printf("[figures] optically thick segments against closed forms: %.2e\n", worst);
  EXPECT_LT(worst, 1e-9);
  PreintegrationSizes sizes;
  sizes.scalar_samples = 8;
  sizes.length_samples = 16;
  sizes.s_max = 1.0;
  sizes.max_length = 0.2;
  const PreintegrationTable table(opaque, sizes);
  const SegmentColour c = table.lookup(0.3, 0.6, 0.1);
  EXPECT_NEAR(c.alpha, 1.0, 1e-6);
  EXPECT_NEAR(c.colour.x(), 1.0, 1e-6);
  EXPECT_NEAR(c.colour.y(), 0.2, 1e-6);
}

TEST(Preintegration, QuadratureMatchesClosedFormsOfVaryingScalars) {
  // A constant colour with any τ: C = c α exactly (∫ τ exp(-∫τ) = 1 - exp(-∫τ)).
  TransferFunction grey = ramp();
  for (TransferPoint& p : grey.points) p.colour = Vec3(0.3, 0.6, 0.9);
  // τ linear over one piece: the optical depth is the trapezoid, exactly.
  TransferFunction linear;
  linear.points = {{0.0, Vec3(1, 0, 0), 0.5}, {1.0, Vec3(0, 0, 1), 2.5}};
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  double worst_grey = 0.0, worst_depth = 0.0, worst_refine = 0.0, worst_colour = 0.0;
  const TransferFunction tf = ramp();
  for (int i = 0; i < 300; ++i) {
    const double sf = unit(rng), sb = unit(rng), l = 2.0 * unit(rng);
    const SegmentColour g = preintegrate_exact(grey, sf, sb, l);
    worst_grey =
        std::max(worst_grey, (g.colour - Vec3(0.3, 0.6, 0.9) * g.alpha).cwiseAbs().maxCoeff());
    const SegmentColour lin = preintegrate_exact(linear, sf, sb, l);
    const double depth = l * (0.5 + 2.0 * (sf + sb) / 2.0);
    worst_depth = std::max(worst_depth, std::abs(lin.alpha - (1.0 - std::exp(-depth))));
    // The quadrature has converged: 256 panels (the default) against 4096.
    worst_refine = std::max(worst_refine, difference(preintegrate_exact(tf, sf, sb, l, 256),
                                                     preintegrate_exact(tf, sf, sb, l, 4096)));
    // The linear function's red colour by an independent midpoint sum (c = 1 - s, τ = 0.5 + 2 s,
    // the depth in closed form).
    double sum_r = 0.0;
    const int n = 20000;
    for (int q = 0; q < n; ++q) {
      const double t = (q + 0.5) / n * l;
      const double s = sf + (sb - sf) * t / l;
      const double tau = 0.5 + 2.0 * s;
      const double d = t * (0.5 + 2.0 * sf + (sb - sf) * t / l);  // ∫_0^t τ
      sum_r += (1.0 - s) * tau * std::exp(-d) * (l / n);
    }
    worst_colour = std::max(worst_colour, std::abs(lin.colour[0] - sum_r));
  }
  std::printf(
      "[figures] quadrature: grey C - c alpha %.2e, linear tau's opacity %.2e, 256 vs 4096 panels "
      "%.2e, against a 20000-step midpoint sum %.2e\n",
      worst_grey, worst_depth, worst_refine, worst_colour);
  EXPECT_LT(worst_grey, 1e-13);
  EXPECT_LT(worst_depth, 1e-13);
  EXPECT_LT(worst_refine, 1e-13);
  EXPECT_LT(worst_colour, 1e-8);
}

TEST(Preintegration, IncrementalTableMatchesTheQuadrature) {
  const TransferFunction tf = smooth();
  PreintegrationSizes sizes;
  sizes.scalar_samples = 129;  // nodes every 1/128: the control points lie on nodes
  sizes.length_samples = 129;
  sizes.s_min = 0.0;
  sizes.s_max = 1.0;
  sizes.max_length = 1.0;
  const PreintegrationTable table(tf, sizes);
  const double mib = table.bytes() / double(1 << 20);
  EXPECT_EQ(table.bytes(), PreintegrationTable::bytes_for(sizes));

  // At the nodes: only the incremental build's error.
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> node(0, 128);
  double worst_node = 0.0;
  for (int q = 0; q < 2000; ++q) {
    const int i = node(rng), j = node(rng), k = node(rng);
    worst_node = std::max(
        worst_node,
        difference(table.entry(i, j, k), preintegrate_exact(tf, i / 128.0, j / 128.0, k / 128.0)));
  }
  // Anywhere: the build's and the trilinear lookup's error; a third of the samples near the
  // diagonal s_front = s_back (thin tetrahedra), where the transfer function's kinks matter most.
  std::uniform_real_distribution<double> unit(0.0, 1.0), near(-0.02, 0.02);
  double worst = 0.0, sum = 0.0;
  const int samples = 6000;
  for (int q = 0; q < samples; ++q) {
    const double sf = unit(rng);
    const double sb = q % 3 == 0 ? std::clamp(sf + near(rng), 0.0, 1.0) : unit(rng);
    const double l = unit(rng);
    const double e = difference(table.lookup(sf, sb, l), preintegrate_exact(tf, sf, sb, l));
    worst = std::max(worst, e);
    sum += e;
  }
  // Lengths beyond the table: pieces composited.
  double worst_long = 0.0;
  for (int q = 0; q < 500; ++q) {
    const double sf = unit(rng), sb = unit(rng), l = 1.0 + 2.0 * unit(rng);
    worst_long = std::max(worst_long,
                          difference(table.lookup(sf, sb, l), preintegrate_exact(tf, sf, sb, l)));
  }
  std::printf(
      "[figures] smooth transfer function (129 points), incremental table 129 x 129 x 129 (%.1f "
      "MiB, RGBA float32) built in %.3f s (%ld slab integrations); error against the quadrature: "
      "%.2e at nodes, %.2e max / %.2e mean at %d random (s_f, s_b, l), %.2e for l in [1, 3] "
      "(composited pieces)\n",
      mib, table.build_seconds(), 129L * 129 * 128, worst_node, worst, sum / samples, samples,
      worst_long);
  EXPECT_LT(worst_node, 1e-4);
  EXPECT_LT(worst, 1e-4);
  EXPECT_LT(worst_long, 2e-4);
  // The empty segment and the closed form on the diagonal.
  EXPECT_EQ(table.lookup(0.3, 0.6, 0.0).alpha, 0.0);
  const Eigen::Vector4d v = tf.at(0.375);
  EXPECT_NEAR(table.lookup(0.375, 0.375, 0.5).alpha, 1.0 - std::exp(-0.5 * v[3]), 1e-5);
}

TEST(Preintegration, SharpTransferFunctionErrsNearItsKinks) {
  // Nine control points with slope jumps of τ up to 20 per unit of s: near s_front = s_back at a
  // control point the entries bend within one node spacing h, and any table read linearly errs
  // by about (slope jump) · l · h / 16 there; the incremental build adds its reads' errors.
  const TransferFunction tf = ramp();
  PreintegrationSizes sizes;
  sizes.scalar_samples = 129;
  sizes.length_samples = 129;
  const PreintegrationTable table(tf, sizes);
  std::mt19937 rng(13);
  std::uniform_int_distribution<int> node(0, 128);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  double worst_node = 0.0, worst = 0.0, worst_far = 0.0;
  for (int q = 0; q < 3000; ++q) {
    const int i = node(rng), j = node(rng), k = node(rng);
    worst_node = std::max(
        worst_node,
        difference(table.entry(i, j, k), preintegrate_exact(tf, i / 128.0, j / 128.0, k / 128.0)));
    const double sf = unit(rng), sb = unit(rng), l = unit(rng);
    const double e = difference(table.lookup(sf, sb, l), preintegrate_exact(tf, sf, sb, l));
    worst = std::max(worst, e);
    if (std::abs(sf - sb) > 0.25) worst_far = std::max(worst_far, e);
  }
  std::printf(
      "[figures] sharp transfer function (9 points), table 129 x 129 x 129: error %.2e "
      "at nodes, %.2e at random points, %.2e where |s_f - s_b| > 0.25\n",
      worst_node, worst, worst_far);
  EXPECT_LT(worst, 1e-2);
  EXPECT_LT(worst_far, 1e-3);
}

TEST(Preintegration, IncrementalErrorShrinksWithTheTable) {
  // The same transfer function at coarser and finer samplings: the error falls by more than half
  // with each halving of the node spacing.
  const TransferFunction tf = smooth();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<std::array<double, 3>> points(1500);
  for (auto& p : points) p = {unit(rng), unit(rng), unit(rng)};
  std::vector<SegmentColour> exact;
  for (const auto& p : points) exact.push_back(preintegrate_exact(tf, p[0], p[1], p[2]));
  double previous = 0.0;
  for (int n : {33, 65, 129}) {
    PreintegrationSizes sizes;
    sizes.scalar_samples = n;
    sizes.length_samples = n;
    const PreintegrationTable table(tf, sizes);
    double worst = 0.0;
    for (size_t q = 0; q < points.size(); ++q)
      worst = std::max(
          worst, difference(table.lookup(points[q][0], points[q][1], points[q][2]), exact[q]));
    std::printf("[figures] table %d x %d x %d (%.2f MiB): max error %.2e (%.3f s)\n", n, n, n,
                table.bytes() / double(1 << 20), worst, table.build_seconds());
    if (previous > 0.0) {
      EXPECT_LT(worst, 0.5 * previous);
    }
    previous = worst;
  }
}

TEST(Preintegration, BadInputsAreRefused) {
  const TransferFunction tf = ramp();
  PreintegrationSizes ok;
  ok.scalar_samples = 8;
  ok.length_samples = 8;
  EXPECT_NO_THROW(PreintegrationTable(tf, ok));
  auto with = [&](auto change) {
    PreintegrationSizes s = ok;
    change(s);
    return s;
  };
  EXPECT_THROW(PreintegrationTable(tf, with([](auto& s) { s.scalar_samples = 1; })), Error);
  EXPECT_THROW(PreintegrationTable(tf, with([](auto& s) { s.scalar_samples = 1025; })), Error);
  EXPECT_THROW(PreintegrationTable(tf, with([](auto& s) { s.length_samples = 0; })), Error);
  EXPECT_THROW(PreintegrationTable(tf, with([](auto& s) { s.s_max = s.s_min; })), Error);
  EXPECT_THROW(PreintegrationTable(tf, with([](auto& s) { s.s_min = std::nan(""); })), Error);
  EXPECT_THROW(PreintegrationTable(tf, with([](auto& s) { s.max_length = 0.0; })), Error);
  EXPECT_THROW(PreintegrationTable(tf, with([](auto& s) { s.max_length = INFINITY; })), Error);
  // 1024 x 1024 x 1024 entries are 16 GiB, over the 512 MiB cap.
  try {
    PreintegrationTable(tf, with([](auto& s) {
                          s.scalar_samples = 1024;
                          s.length_samples = 1024;
                        }));
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    std::printf("[figures] refused: %s\n", e.what());
    EXPECT_NE(std::string(e.what()).find("512 MiB"), std::string::npos);
  }

  TransferFunction bad = tf;
  bad.points.clear();
  EXPECT_THROW(bad.validate(), Error);
  bad = tf;
  bad.points[3].s = bad.points[2].s;
  EXPECT_THROW(bad.validate(), Error);
  bad = tf;
  bad.points[1].colour[2] = 1.5;
  EXPECT_THROW(bad.validate(), Error);
  bad = tf;
  bad.points[4].tau = -1.0;
  EXPECT_THROW(bad.validate(), Error);
  EXPECT_THROW(PreintegrationTable(bad, ok), Error);
  EXPECT_THROW(preintegrate_exact(tf, 0.1, 0.2, -1.0), Error);
  EXPECT_THROW(preintegrate_exact(tf, 0.1, 0.2, std::nan("")), Error);
  EXPECT_THROW(preintegrate_exact(tf, 0.1, 0.2, 1.0, 0), Error);
  EXPECT_THROW(preintegrate_exact(tf, std::nan(""), 0.2, 1.0), Error);
}

}  // namespace
}  // namespace raywarp
