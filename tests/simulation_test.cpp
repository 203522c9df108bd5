// The simulation deformer (deformers/simulation.h): the lattice body's F and its inverse, runs
// from rest (pins, drags, repeatability, instability), the scene's parameters and the bake
// through a session (docs/simulation.md).
#include "deformers/simulation.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "base/error.h"
#include "base/json_reader.h"
#include "deformers/registry.h"
#include "library/bake.h"
#include "library/deformation_bake.h"
#include "library/scene.h"
#include "tests/sanitizer.h"

namespace raywarp {
namespace {

const Eigen::Vector3d kHalf(1.0, 1.5, 1.0);

// A lattice over kHalf with `cells`, nodes where an ellipsoid (semi-axes 0.8, 1.6, 0.8 at the
// centre) holds the sample: node_of_sample and the rest positions.
struct Lattice {
  Eigen::Vector3i cells;
  Eigen::Vector3d spacing;
  std::vector<int> node_of_sample;
  std::vector<Eigen::Vector3d> rest;
};

Lattice ellipsoid_lattice(const Eigen::Vector3i& cells) {
  Lattice l;
  l.cells = cells;
  l.spacing = (2.0 * kHalf).cwiseQuotient(cells.cast<double>());
  const Eigen::Vector3i n = cells + Eigen::Vector3i::Ones();
  for (int k = 0; k < n.z(); ++k)
    for (int j = 0; j < n.y(); ++j)
      for (int i = 0; i < n.x(); ++i) {
        const Eigen::Vector3d p = -kHalf + l.spacing.cwiseProduct(Eigen::Vector3d(i, j, k));
        const bool inside = p.cwiseQuotient(Eigen::Vector3d(0.8, 1.6, 0.8)).norm() <= 1.0;
        l.node_of_sample.push_back(inside ? static_cast<int>(l.rest.size()) : -1);
        if (inside) l.rest.push_back(p);
      }
  return l;
}

// Whether rest point p lies in a body cell (all 8 corners nodes) of the lattice, at least
// `inset` (cell coordinates) from the cell's faces where those faces border empty cells is not
// tracked: the test keeps points well inside the ellipsoid instead.
bool deep_inside(const Eigen::Vector3d& p) {
  return p.cwiseQuotient(Eigen::Vector3d(0.8, 1.6, 0.8)).norm() <= 0.55;
}

// Nodes moved by an affine map x -> A x + b: F is that map on the body for both models (a
// trilinear or piecewise-linear interpolant reproduces an affine field), so the inverse of
// A p + b is p to rounding: asserted to 1e-9 at random points and at the texel centres of a bake's
// layout whose exact preimage lies deep in the body.
TEST(Simulation, AffineNodesGiveTheExactInverse) {
  const Lattice l = ellipsoid_lattice(Eigen::Vector3i(8, 12, 8));
  Eigen::Matrix3d a = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 0.5).normalized()).matrix();
  a *= Eigen::Vector3d(1.2, 0.9, 1.1).asDiagonal();
  a(0, 1) += 0.15;  // a shear
  const Eigen::Vector3d b(0.1, -0.2, 0.05);
  std::vector<Eigen::Vector3d> moved;
  for (const Eigen::Vector3d& r : l.rest) moved.push_back(a * r + b);
  const Eigen::Matrix3d a_inv = a.inverse();
  for (SimModel model : {SimModel::grid, SimModel::tets}) {
    const auto f = make_lattice_deformer(model, kHalf, l.cells, l.node_of_sample, moved);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    double worst_forward = 0, worst_inverse = 0;
    int checked = 0;
    while (checked < 3000) {
      const Eigen::Vector3d p =
          Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).cwiseProduct(kHalf);
      if (!deep_inside(p)) continue;
      ++checked;
      worst_forward = std::max(worst_forward, (f->forward(p) - (a * p + b)).norm());
      worst_inverse = std::max(worst_inverse, (f->inverse(a * p + b) - p).norm());
      ASSERT_LE((f->jacobian(p) - a).norm(), 1e-9);
    }
    EXPECT_LE(worst_forward, 1e-12);
    EXPECT_LE(worst_inverse, 1e-9);
    // The texel centres of the bake's layout, where the texture is baked.
    const Grid3<Eigen::Vector4f> layout = deformation_layout(*f, kHalf, 48);
    double worst_texel = 0;
    long texels = 0;
    for (int k = 0; k < layout.dims.z(); ++k)
      for (int j = 0; j < layout.dims.y(); ++j)
        for (int i = 0; i < layout.dims.x(); ++i) {
          const Eigen::Vector3d q = layout.texel_centre(i, j, k);
          const Eigen::Vector3d exact = a_inv * (q - b);
          if (!deep_inside(exact)) continue;
          ++texels;
          worst_texel = std::max(worst_texel, (f->inverse(q) - exact).norm());
        }
    EXPECT_GT(texels, 1000);
    EXPECT_LE(worst_texel, 1e-9);
    std::printf(
        "[figures] simulation affine %s: |F - affine| <= %.3g, |F^-1 - affine^-1| <= %.3g at "
        "%d points, <= %.3g at %ld texel centres\n",
        sim_model_names()[static_cast<int>(model)].c_str(), worst_forward, worst_inverse, checked,
        worst_texel, texels);
  }
}

// The harmonic extension keeps F continuous across the body's edge and the identity on pinned
// faces; points F carries out of the box's image have an invalid preimage beyond a box face.
TEST(Simulation, ExtensionIsContinuousAndPinnedFacesStay) {
  const Lattice l = ellipsoid_lattice(Eigen::Vector3i(8, 12, 8));
  std::vector<Eigen::Vector3d> moved;
  for (const Eigen::Vector3d& r : l.rest)  // a bend-like sway growing with y
    moved.push_back(r + Eigen::Vector3d(0.2 * (r.y() + 1.5) * (r.y() + 1.5) / 9.0, 0, 0));
  std::array<bool, 6> pinned{};
  pinned[2] = true;  // -y
  const auto f =
      make_lattice_deformer(SimModel::grid, kHalf, l.cells, l.node_of_sample, moved, pinned);
  EXPECT_TRUE(f->identity_faces()[2]);
  EXPECT_FALSE(f->identity_faces()[3]);
  // Continuity: F across the whole box, sampled finely, has no jump beyond its Lipschitz bound.
  double worst_ratio = 0;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int n = 0; n < 5000; ++n) {
    const Eigen::Vector3d p = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).cwiseProduct(kHalf);
    const Eigen::Vector3d d = 1e-4 * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    worst_ratio = std::max(worst_ratio, (f->forward(p + d) - f->forward(p)).norm() / d.norm());
  }
  EXPECT_LT(worst_ratio, 3.0);
  // Round trip over the whole box (no folds in this sway).
  double worst = 0;
  for (int n = 0; n < 5000; ++n) {
    const Eigen::Vector3d p =
        0.999 * Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).cwiseProduct(kHalf);
    worst = std::max(worst, (f->inverse(f->forward(p)) - p).norm());
  }
  EXPECT_LE(worst, 1e-9);
  std::printf("[figures] simulation extension: |F(p + d) - F(p)| / |d| <= %.3g, round trip %.3g\n",
              worst_ratio, worst);
}

SimulationInput cylinder(double radius) {
  SimulationInput in;
  in.signed_distance = [radius](const Eigen::Vector3d& q) {
    return radius - Eigen::Vector2d(q.x(), q.z()).norm();
  };
  return in;
}

SimulationParams sway_params() {
  SimulationParams p;
  p.resolution = 8;
  p.ks = 2e4;
  p.kd = 5;
  p.density = 100;
  p.steps = 40;
  p.dt = 0.01;
  p.gravity = Eigen::Vector3d(-9.81, 0, 0);  // sideways: the pinned column sways
  return p;
}

// A column through the -y and +y faces: both pinned by default; gravity across it bends it; two
// runs give the same bytes; the pinned nodes stay at rest.
TEST(Simulation, RunsFromRestRepeatably) {
  for (SimIntegrator integrator :
       {SimIntegrator::implicit_euler, SimIntegrator::local_global, SimIntegrator::verlet}) {
    SimulationParams p = sway_params();
    p.integrator = integrator;
    if (integrator == SimIntegrator::verlet) p.dt = 1e-3, p.steps = 400;
    std::vector<std::string> notes;
    Simulation a(p, kHalf, cylinder(0.6), &notes);
    Simulation b(p, kHalf, cylinder(0.6));
    a.run(0, nullptr);
    std::vector<long> kept;
    b.run(10, [&](long step, const std::vector<Eigen::Vector3d>&) { kept.push_back(step); });
    EXPECT_EQ(kept.size(), static_cast<size_t>(p.steps / 10));
    EXPECT_EQ(kept.back(), p.steps);
    const auto pa = a.positions(), pb = b.positions();
    ASSERT_EQ(pa.size(), pb.size());
    double sway = 0;
    for (size_t n = 0; n < pa.size(); ++n) {
      ASSERT_EQ(pa[n], pb[n]) << "node " << n;  // bit for bit
      sway = std::min(sway, pa[n].x() - a.rest()[n].x());
    }
    EXPECT_EQ(a.stats().pinned_faces, "-y, +y");
    EXPECT_GT(a.stats().pinned, 0);
    EXPECT_LT(sway, -1e-3) << sim_integrator_names()[static_cast<int>(integrator)];
    const auto f = a.deformer(pa);
    EXPECT_TRUE(f->identity_faces()[2]);
    EXPECT_TRUE(f->identity_faces()[3]);
    std::printf("[figures] simulation column %s: %d nodes, %d springs, sway %.4g units\n",
                sim_integrator_names()[static_cast<int>(integrator)].c_str(), a.stats().nodes,
                a.stats().springs, -sway);
  }
}

// A drag moves its nodes along its path: at the end they sit at rest + the last offset.
// refine_body splits the body's cells as its own Kuhn split does: at k = 1 it gives the body's
// tetrahedra; at every k the counts are 6 k^3 per cell, every tetrahedron is positive at rest, and
// F of the tets model (linear per body tetrahedron) is linear on each refined one: F at its
// centroid is the mean of F at its corners.
TEST(Simulation, RefinedBodyNestsInTheBody) {
  SimulationParams p = sway_params();
  p.model = SimModel::tets;
  p.steps = 10;
  Simulation sim(p, kHalf, cylinder(0.6));
  sim.run(0, nullptr);
  const SimulationBody& body = sim.body();
  const auto F = sim.deformer(sim.positions());
  ASSERT_FALSE(body.tets.empty());
  const long cells = static_cast<long>(body.tets.size()) / 6;
  auto key = [](const std::vector<Eigen::Vector3d>& rest, const std::array<int, 4>& t) {
    std::vector<std::array<double, 3>> corners;
    for (int c : t) corners.push_back({rest[c].x(), rest[c].y(), rest[c].z()});
    std::sort(corners.begin(), corners.end());
    return corners;
  };
  for (int k : {1, 2, 3}) {
    const SimulationBody fine = refine_body(body, k, 1000000);
    ASSERT_EQ(static_cast<long>(fine.tets.size()), 6L * k * k * k * cells) << k;
    EXPECT_EQ(refined_tet_count(body, k), static_cast<long>(fine.tets.size()));
    EXPECT_EQ(fine.rest.size(), fine.sample.size());
    double worst = 0, smallest = 1e300;
    for (const auto& t : fine.tets) {
      const Eigen::Vector3d &a = fine.rest[t[0]], &b = fine.rest[t[1]], &c = fine.rest[t[2]],
                            &d = fine.rest[t[3]];
      smallest = std::min(smallest, (b - a).dot((c - a).cross(d - a)));
      const Eigen::Vector3d mean =
          (F->forward(a) + F->forward(b) + F->forward(c) + F->forward(d)) / 4.0;
      worst = std::max(worst, (F->forward((a + b + c + d) / 4.0) - mean).norm());
    }
    EXPECT_GT(smallest, 0) << k;
    EXPECT_LT(worst, 1e-12) << k;
    if (k == 1) {
      std::set<std::vector<std::array<double, 3>>> a, b;
      for (const auto& t : body.tets) a.insert(key(body.rest, t));
      for (const auto& t : fine.tets) b.insert(key(fine.rest, t));
      EXPECT_EQ(a, b);
    }
    std::printf("[figures] refined body k=%d: %zu tets, %zu nodes, F linear per tet to %.2g\n", k,
                fine.tets.size(), fine.rest.size(), worst);
  }
  EXPECT_THROW(refine_body(body, 9, 1000000), Error);
  try {
    refine_body(body, 3, 100);
    ADD_FAILURE() << "no error past max_tets";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(std::to_string(27 * 6 * cells)), std::string::npos)
        << e.what();
  }
}

TEST(Simulation, DragsFollowTheirPath) {
  SimulationParams p = sway_params();
  p.gravity.setZero();
  p.pinned = {false, false, true, false, false, false};  // -y only
  p.pins_given = true;
  Drag drag;
  drag.sub_min = Eigen::Vector3d(0, 0.9, 0);
  drag.path = {{0.2, Eigen::Vector3d(0.3, 0, 0)}, {0.3, Eigen::Vector3d(0.3, -0.1, 0)}};
  p.drags = {drag};
  EXPECT_EQ(drag.offset_at(0.1), Eigen::Vector3d(0.15, 0, 0));
  EXPECT_EQ(drag.offset_at(1.0), Eigen::Vector3d(0.3, -0.1, 0));
  Simulation sim(p, kHalf, cylinder(0.6));
  EXPECT_GT(sim.stats().dragged, 0);
  sim.run(0, nullptr);
  const auto x = sim.positions();
  int dragged = 0;
  for (size_t n = 0; n < x.size(); ++n)
    if (sim.rest()[n].y() >= kHalf.y() * 0.8 - 1e-12) {
      EXPECT_LE((x[n] - sim.rest()[n] - Eigen::Vector3d(0.3, -0.1, 0)).norm(), 1e-12);
      ++dragged;
    }
  EXPECT_EQ(dragged, sim.stats().dragged);
  const auto f = sim.deformer(x);
  EXPECT_TRUE(f->identity_faces()[2]);
  EXPECT_FALSE(f->identity_faces()[3]);
}

// A run that blows up stops with a message naming the step; nothing non-finite comes out.
TEST(Simulation, UnstableRunStopsNamingTheStep) {
  SimulationParams p = sway_params();
  p.integrator = SimIntegrator::explicit_euler;
  p.ks = 1e8;
  p.steps = 2000;
  Simulation sim(p, kHalf, cylinder(0.6));
  try {
    sim.run(0, nullptr);
    FAIL() << "an explicit Euler run at ks = 1e8, dt = 0.01 finished";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("step"), std::string::npos) << m;
    EXPECT_NE(m.find("lower dt"), std::string::npos) << m;
  }
  for (const Eigen::Vector3d& x : sim.positions()) EXPECT_TRUE(x.allFinite());
}

// A part thinner than a cell holds no body cell: refused, naming what to raise.
TEST(Simulation, ThinPartIsRefused) {
  SimulationParams p = sway_params();
  p.margin = 0;
  try {
    Simulation sim(p, kHalf, cylinder(0.05));
    FAIL() << "a body of no cell was built";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("raise resolution or margin"), std::string::npos)
        << e.what();
  }
}

std::string scene_error(const std::string& deformer) {
  const std::string text = R"({"mesh": ")" + std::string(RAYWARP_SOURCE_DIR) +
                           R"(/examples/meshes/bunny.ply", "boxes": [{"min": [-5.2, 4, -4],
      "max": [5.2, 9.9, 4], "deformer": )" +
                           deformer + "}]}";
  try {
    load_scene_json(nlohmann::json::parse(text), "sim.json");
  } catch (const Error& e) {
    return e.what();
  }
  return "(accepted)";
}

// The scene's parameters: each refusal names the file, the field and what is allowed.
TEST(Simulation, SceneErrorsAreNamed) {
  struct Case {
    std::string deformer, expect;
  } cases[] = {
      {R"({"type": "simulation"})", "boxes[0].deformer.ks"},
      {R"({"type": "simulation", "ks": 1e4, "integrator": "rk4"})",
       "must be one of explicit_euler, verlet, velocity_verlet, implicit_euler, local_global"},
      {R"({"type": "simulation", "ks": 1e4, "model": "voxels"})", "must be one of grid, tets"},
      {R"({"type": "simulation", "ks": 1e4, "steps": 2.5})", "deformer.steps"},
      {R"({"type": "simulation", "ks": 1e4, "resolution": 500})", "deformer.resolution"},
      {R"({"type": "simulation", "ks": 1e4, "dt": 0})", "deformer.dt"},
      {R"({"type": "simulation", "ks": -3})", "deformer.ks"},
      {R"({"type": "simulation", "ks": 1e4, "gravity": [0, "down", 0]})", "deformer.gravity[1]"},
      {R"({"type": "simulation", "ks": 1e4, "drags": [{"path": [{"t": 1, "offset": [1, 0, 0]},
          {"t": 0.5, "offset": [0, 0, 0]}]}]})",
       "deformer.drags[0].path[1].t"},
      {R"({"type": "simulation", "ks": 1e4, "drags": [{"sub_min": [0, 2, 0], "path": []}]})",
       "deformer.drags[0].sub_min[1]"},
      {R"({"type": "simulation", "ks": 1e4, "drags": [{"sub_min": [0, 0.5, 0]}]})",
       "deformer.drags[0].path"},
  };
  for (const Case& c : cases) {
    const std::string m = scene_error(c.deformer);
    EXPECT_NE(m.find("sim.json"), std::string::npos) << c.deformer << ": " << m;
    EXPECT_NE(m.find(c.expect), std::string::npos) << c.deformer << ": " << m;
  }
  EXPECT_EQ(scene_error(R"({"type": "simulation", "ks": 1e4})"), "(accepted)");
}

// Through a bake session: the body is built over the bunny's head, the run's state is a stage of
// its own (kept in memory: a second bake reads it), D inverts F at every valid texel, and a
// changed parameter runs the simulation again while the distance grid is read from memory.
TEST(Simulation, BakesThroughTheSession) {
  const std::string text = R"({"mesh": ")" + std::string(RAYWARP_SOURCE_DIR) +
                           R"(/examples/meshes/bunny.ply", "boxes": [{"min": [-5.2, 4, -4],
      "max": [5.2, 9.9, 4], "implicit": {"type": "sdf", "resolution": 64},
      "deformation": {"resolution": )" +
                           std::to_string(std::min(48, raywarp::testing::kSmallGrid)) + R"(},
      "deformer": {"type": "simulation", "resolution": 8, "ks": 3e4, "kd": 20, "density": 100,
                   "steps": 30, "drags": [{"sub_min": [0, 0.8, 0],
                   "path": [{"t": 0.3, "offset": [1.5, 0, 0]}]}]}}]})";
  Scene scene = load_scene_json(nlohmann::json::parse(text), "sim.json");
  BakeSession session;
  const PreparedScene first = bake_scene(scene, session);
  const BakeReport& r = first.boxes[0].report;
  ASSERT_TRUE(r.simulation.has_value());
  EXPECT_EQ(r.simulation->steps, 30);
  EXPECT_EQ(r.simulation->body.pinned_faces, "-y");
  ASSERT_NE(r.stage(Stage::Simulation), nullptr);
  EXPECT_EQ(r.stage(Stage::Simulation)->source, Source::Baked);
  EXPECT_EQ(r.residual.over_tolerance, 0);
  EXPECT_GT(r.residual.texels, 1000);
  for (const Eigen::Vector4f& t : first.boxes[0].textures.deformation.grid.data)
    ASSERT_TRUE(t.allFinite());
  const PreparedScene again = bake_scene(scene, session);
  EXPECT_EQ(again.bakes, 0);
  EXPECT_EQ(again.boxes[0].report.stage(Stage::Simulation)->source, Source::Memory);
  scene.boxes[0].deformer.sim_steps = 20;
  const long runs = session.counters().simulation;
  const PreparedScene changed = bake_scene(scene, session);
  EXPECT_EQ(session.counters().simulation, runs + 1);
  EXPECT_EQ(changed.boxes[0].report.stage(Stage::DistanceGrid)->source, Source::Memory);
  std::printf(
      "[figures] simulation bake: %d nodes, run %.3f s, D %s texels error %.3g units, "
      "residual max %.3g\n",
      r.simulation->body.nodes, r.stage(Stage::Simulation)->seconds,
      std::to_string(r.residual.texels).c_str(), r.texture_error, r.residual.max);
}

// A simulation composed with another deformer is refused, naming the field.
TEST(Simulation, ComposedIsRefused) {
  const std::string m = scene_error(
      R"([{"type": "twist", "axis": "y", "angle_deg": 30}, {"type": "simulation", "ks": 3e4}])");
  EXPECT_NE(m.find("boxes[0].deformer[1].type"), std::string::npos) << m;
  EXPECT_NE(m.find("cannot be composed"), std::string::npos) << m;
}

}  // namespace
}  // namespace raywarp
