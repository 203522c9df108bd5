// Mass-spring step times (docs/physics.md#speed): milliseconds per step, the median of --steps
// timed steps after two warm-up steps, for each integrator on two models:
//   grid  Mosegaard & Sørensen's 18-neighbour grid of an ellipsoid blob, 19,721 nodes (their
//         heart: 20,000 nodes);
//   tets  the Kuhn tetrahedra of an ellipsoid blob, 155,712 tets (Tejada & Ertl's "Foot":
//         156,612).
// Spacing 1, density 1 (interior node mass 1), ks = 3e4, no damping, the nodes of the two lowest
// sample layers pinned, gravity 9.81 along -z, from rest. Explicit integrators step h = 5e-4 s
// (a quarter of 2/ω_max), implicit Euler and local/global (10 iterations) h = 0.01 s.
// Local/global's factorisation is timed apart (LocalGlobal::prepare). Each model and integrator
// runs once on one thread and once on all (TBB's default), and the two final states must be
// identical bytes. Usage: raywarp_physics_bench [--steps N] [--model grid|tets|all] [--integrator
// NAME]
#include <tbb/global_control.h>
#include <tbb/info.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "physics/integrators.h"
#include "physics/mass_spring.h"
#include "physics/models.h"

using namespace raywarp::physics;

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

// Pins the nodes whose z is within 1.5 spacings of the lowest node's.
void pin_bottom(MassSpring& s) {
  double zmin = 1e300;
  for (int i = 0; i < s.nodes(); ++i) zmin = std::min(zmin, s.position(i).z());
  for (int i = 0; i < s.nodes(); ++i) {
    if (s.position(i).z() <= zmin + 1.5) s.pin(i);
  }
  s.gravity = Eigen::Vector3d(0, 0, -9.81);
}

struct Timing {
  double median_ms = 0, prepare_ms = 0, mean_iterations = 0;
  std::vector<double> state;  // final x then v
  bool ok = true;
  std::string message;
};

Timing time_steps(const MassSpring& start, Integrator& integ, double h, int steps) {
  MassSpring s = start;
  Timing t;
  if (auto* lg = dynamic_cast<LocalGlobal*>(&integ)) {
    auto t0 = Clock::now();
    lg->prepare(s, h);
    t.prepare_ms = ms_since(t0);
  }
  std::vector<double> ms;
  long iterations = 0;
  for (int n = 0; n < steps + 2; ++n) {
    auto t0 = Clock::now();
    StepResult r = integ.step(s, h);
    double dt = ms_since(t0);
    if (!r.ok()) {
      t.ok = false;
      t.message = r.message;
      break;
    }
    if (n >= 2) {
      ms.push_back(dt);
      iterations += r.iterations;
    }
  }
  t.median_ms = median(ms);
  t.mean_iterations = ms.empty() ? 0 : double(iterations) / ms.size();
  t.state.assign(s.x.data(), s.x.data() + s.x.size());
  t.state.insert(t.state.end(), s.v.data(), s.v.data() + s.v.size());
  return t;
}

std::unique_ptr<Integrator> make(const std::string& name) {
  if (name == "explicit-euler") return std::make_unique<ExplicitEuler>();
  if (name == "verlet") return std::make_unique<Verlet>();
  if (name == "velocity-verlet") return std::make_unique<VelocityVerlet>();
  if (name == "implicit-euler") return std::make_unique<ImplicitEuler>();
  if (name == "local-global") return std::make_unique<LocalGlobal>();
  return nullptr;
}

}  // namespace

int main(int argc, char** argv) {
  int steps = 20;
  std::string model = "all", only;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--steps" && i + 1 < argc) {
      steps = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--model" && i + 1 < argc) {
      model = argv[++i];
    } else if (a == "--integrator" && i + 1 < argc) {
      only = argv[++i];
    } else {
      std::cerr << "usage: raywarp_physics_bench [--steps N] [--model grid|tets|all] "
                   "[--integrator explicit-euler|verlet|velocity-verlet|implicit-euler|"
                   "local-global]\n";
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  if ((model != "all" && model != "grid" && model != "tets") || (!only.empty() && !make(only))) {
    std::cerr << "raywarp_physics_bench: unknown --model or --integrator\n";
    return 2;
  }
  const int threads = tbb::info::default_concurrency();
  struct Model {
    std::string name;
    MassSpring system;
    long tets = 0;
  };
  std::vector<Model> models;
  const double ks = 3e4;
  if (model != "tets") {
    GridModel g = grid_model(ellipsoid_mask(Eigen::Vector3d(28, 13, 13)), 1.0, ks);
    pin_bottom(g.system);
    models.push_back({"grid", std::move(g.system), 0});
  }
  if (model != "grid") {
    TetMesh m = tetrahedralize(ellipsoid_mask(Eigen::Vector3d(33, 14, 15.3)));
    MassSpring s = mass_spring(m, 1.0, ks);
    pin_bottom(s);
    models.push_back({"tets", std::move(s), static_cast<long>(m.tets.size())});
  }
  std::printf("threads: 1 and %d (TBB default); %d timed steps, median\n\n", threads, steps);
  std::printf(
      "| model | nodes | springs | tets | integrator | h (s) | ms/step, 1 thread | ms/step, %d "
      "threads | speed-up | iterations/step | factorisation ms (1 / %d threads) | same bytes |\n"
      "| --- | ---: | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | --- |\n",
      threads, threads);
  bool all_same = true;
  for (const Model& m : models) {
    for (const std::string name :
         {"explicit-euler", "verlet", "velocity-verlet", "implicit-euler", "local-global"}) {
      if (!only.empty() && name != only) continue;
      const bool implicit = name == "implicit-euler" || name == "local-global";
      const double h = implicit ? 0.01 : 5e-4;
      const int n = implicit ? std::max(1, steps / 4) : steps;
      Timing one, all;
      {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        auto integ = make(name);
        one = time_steps(m.system, *integ, h, n);
      }
      {
        auto integ = make(name);
        all = time_steps(m.system, *integ, h, n);
      }
      const bool same =
          one.state.size() == all.state.size() &&
          std::memcmp(one.state.data(), all.state.data(), one.state.size() * sizeof(double)) == 0;
      all_same = all_same && same;
      char fact[64] = "";
      if (name == "local-global") {
        std::snprintf(fact, sizeof fact, "%.1f / %.1f", one.prepare_ms, all.prepare_ms);
      }
      std::printf("| %s | %d | %zu | %ld | %s | %g | %.3f | %.3f | %.2f | %.1f | %s | %s |%s\n",
                  m.name.c_str(), m.system.nodes(), m.system.springs.size(), m.tets, name.c_str(),
                  h, one.median_ms, all.median_ms, one.median_ms / all.median_ms,
                  all.mean_iterations, fact, same ? "yes" : "NO",
                  one.ok && all.ok ? "" : (" " + one.message + all.message).c_str());
      std::fflush(stdout);
    }
  }
  return all_same ? 0 : 1;
}
