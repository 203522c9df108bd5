#include "studies/stiffness.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <random>
#include <sstream>
#include <thread>

#include "base/atomic_file.h"
#include "base/error.h"
#include "library/mesh.h"
#include "library/winding.h"
#include "physics/integrators.h"
#include "physics/models.h"
#include "physics/spectrum.h"
#include "studies/chart.h"
#include "studies/stiffness_images.h"

namespace raywarp {

const char* const kStiffnessCsvHeader =
    "section,model,tets,nodes,springs,integrator,ks,h,h_omega,iterations,quantity,value,note";

namespace {

namespace fs = std::filesystem;
using namespace physics;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::string fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

// ---------------------------------------------------------------------------------------------
// Models

struct Model {
  std::string name;
  MassSpring rest;  // ks 1, pinned, at rest
  long tets = 0;
  int axis = 2;        // the pins are the lowest layer along this axis
  double length = 1;   // the model's extent along `axis`
  long max_steps = 0;  // the longest stability run it may take (steps)
  std::string note;    // how it was made
};

void pin_lowest(MassSpring& s, int axis, double depth) {
  double lo = std::numeric_limits<double>::infinity();
  for (int i = 0; i < s.nodes(); ++i) lo = std::min(lo, s.position(i)[axis]);
  for (int i = 0; i < s.nodes(); ++i) {
    if (s.position(i)[axis] <= lo + depth) s.pin(i);
  }
}

Model make_model(std::string name, const TetMesh& mesh, int axis, double pin_depth, long max_steps,
                 std::string note) {
  Model m;
  m.name = std::move(name);
  m.rest = mass_spring(mesh, 1.0, 1.0);
  m.tets = static_cast<long>(mesh.tets.size());
  m.axis = axis;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto& p : mesh.nodes) {
    lo = std::min(lo, p[axis]);
    hi = std::max(hi, p[axis]);
  }
  m.length = hi - lo;
  pin_lowest(m.rest, axis, pin_depth);
  m.max_steps = max_steps;
  m.note = std::move(note);
  return m;
}

fs::path find_example(const fs::path& given, const fs::path& example) {
  if (!given.empty()) return given;
  if (fs::exists(example)) return example;
  throw Error("study --stiffness: " + example.generic_string() +
              " not found; run it from the repository root");
}

// The bunny's inside (generalised winding number > 0.5) sampled `voxels` samples along its
// longest side, in voxel units (spacing 1).
Grid3<std::uint8_t> bunny_mask(const fs::path& path, int voxels) {
  Mesh mesh = load_mesh(path.string());
  Eigen::Vector3d lo = mesh.V.colwise().minCoeff().transpose();
  Eigen::Vector3d hi = mesh.V.colwise().maxCoeff().transpose();
  const double voxel = (hi - lo).maxCoeff() / voxels;
  Eigen::Vector3i dims = (((hi - lo) / voxel).array().ceil().cast<int>() + 2).matrix();
  WindingNumber wn(mesh);
  Grid3<std::uint8_t> mask(Eigen::Vector3d::Zero(), 1.0, dims, 0);
  for (int k = 0; k < dims.z(); ++k) {
    for (int j = 0; j < dims.y(); ++j) {
      for (int i = 0; i < dims.x(); ++i) {
        Eigen::Vector3d p = lo + voxel * Eigen::Vector3d(i - 0.5, j - 0.5, k - 0.5);
        mask.at(i, j, k) = wn(p) > 0.5 ? 1 : 0;
      }
    }
  }
  return mask;
}

MassSpring with_ks(const MassSpring& rest, double ks) {
  MassSpring s = rest;
  for (Spring& sp : s.springs) sp.ks = ks;
  return s;
}

// The starting state: a smooth bend across the pinned axis plus a little noise on every free
// node (fixed seed), from rest.
MassSpring perturbed(const Model& m, double ks, double bend = 0.01) {
  MassSpring s = with_ks(m.rest, ks);
  double lo = std::numeric_limits<double>::infinity();
  for (int i = 0; i < s.nodes(); ++i) lo = std::min(lo, s.position(i)[m.axis]);
  std::mt19937 gen(7u);
  const int across = (m.axis + 1) % 3;
  for (int i = 0; i < s.nodes(); ++i) {
    if (s.is_pinned(i)) continue;
    double t = (s.position(i)[m.axis] - lo) / m.length;
    s.x[3 * i + across] += bend * t * t;
    for (int c = 0; c < 3; ++c) s.x[3 * i + c] += 1e-6 * (gen() / 4294967296.0 - 0.5);
  }
  return s;
}

// ---------------------------------------------------------------------------------------------
// Integrators

const std::vector<std::string> kIntegrators = {"explicit Euler", "Verlet", "velocity Verlet",
                                               "implicit Euler", "local/global"};

std::unique_ptr<Integrator> make_integrator(const std::string& name) {
  if (name == "explicit Euler") return std::make_unique<ExplicitEuler>();
  if (name == "Verlet") return std::make_unique<Verlet>();
  if (name == "velocity Verlet") return std::make_unique<VelocityVerlet>();
  if (name == "implicit Euler") return std::make_unique<ImplicitEuler>();
  return std::make_unique<LocalGlobal>();
}

struct Run {
  bool stable = true;
  long steps = 0;  // steps taken
  double e0 = 0, e_end = 0, e_max = 0;
  double seconds = 0;
  int max_iterations = 0;  // per step (CG or local/global)
  std::string why;
};

// `steps` steps of h from `start`; unstable at the first non-finite value or total energy above
// 1.05 E0. Position Verlet's energy uses the centred velocity (x_{n+1} - x_{n-1}) / 2h at x_n (its
// own v' = (x' - x)/h is a half-step velocity whose energy overshoots by up to a factor 1 + ωh/2
// on a stable orbit).
Run run(const MassSpring& start, const std::string& integrator, double h, long steps) {
  MassSpring s = start;
  std::unique_ptr<Integrator> integ = make_integrator(integrator);
  const bool centred = integrator == "Verlet";
  Run r;
  r.e0 = s.energy().total();
  r.e_max = r.e_end = r.e0;
  Vector x_before = s.x, x_now = s.x, v_c;
  auto t0 = Clock::now();
  for (long n = 0; n < steps; ++n) {
    StepResult q = integ->step(s, h);
    if (!q.ok()) {
      r.stable = false;
      r.why = q.message;
      break;
    }
    r.max_iterations = std::max(r.max_iterations, q.iterations);
    r.steps = n + 1;
    double e;
    if (centred) {
      if (n == 0) {  // no x_{-1}: the first centred energy is at x_1
        x_before = x_now;
        x_now = s.x;
        continue;
      }
      v_c = (s.x - x_before) / (2 * h);
      for (int i = 0; i < s.nodes(); ++i) {
        if (s.is_pinned(i)) v_c.segment<3>(3 * i).setZero();
      }
      e = s.energy(x_now, v_c).total();
      x_before.swap(x_now);
      x_now = s.x;
    } else {
      e = s.energy().total();
    }
    r.e_end = e;
    r.e_max = std::max(r.e_max, e);
    if (!std::isfinite(e) || e > 1.05 * r.e0) {
      r.stable = false;
      r.why = "energy " + fmt("%.4g", e / r.e0) + " E0 at step " + std::to_string(n);
      break;
    }
  }
  r.seconds = seconds_since(t0);
  return r;
}

struct Search {
  double step = 0;
  std::string bound;  // "": found to the tolerance; "<": unstable at the smallest step tried;
                      // ">=": stable at the largest step allowed
  int runs = 0;
  Run at;  // the run at `step` (the largest stable one found)
  double seconds = 0;
};

// The largest stable step, by expanding from `guess` by `factor` to a bracket [stable, unstable]
// and bisecting (geometric mean) until hi / lo <= 1 + tol. Steps below h_min or above h_max are
// not tried.
Search largest_stable(const std::function<Run(double)>& try_step, double guess, double factor,
                      double h_min, double h_max, double tol) {
  Search out;
  auto t0 = Clock::now();
  guess = std::clamp(guess, h_min, h_max);
  auto attempt = [&](double h) {
    out.runs += 1;
    return try_step(h);
  };
  double lo = 0, hi = 0;
  Run at_lo;
  Run r = attempt(guess);
  if (r.stable) {
    lo = guess;
    at_lo = r;
    for (;;) {
      if (lo >= h_max) {
        out.step = lo;
        out.bound = ">=";
        out.at = at_lo;
        out.seconds = seconds_since(t0);
        return out;
      }
      double h = std::min(h_max, lo * factor);
      Run q = attempt(h);
      if (!q.stable) {
        hi = h;
        break;
      }
      lo = h;
      at_lo = q;
    }
  } else {
    hi = guess;
    for (;;) {
      if (hi <= h_min) {
        out.step = h_min;
        out.bound = "<";
        out.seconds = seconds_since(t0);
        return out;
      }
      double h = std::max(h_min, hi / factor);
      Run q = attempt(h);
      if (q.stable) {
        lo = h;
        at_lo = q;
        break;
      }
      hi = h;
    }
  }
  while (hi / lo > 1 + tol) {
    double mid = std::sqrt(lo * hi);
    Run q = attempt(mid);
    if (q.stable) {
      lo = mid;
      at_lo = q;
    } else {
      hi = mid;
    }
  }
  out.step = lo;
  out.at = at_lo;
  out.seconds = seconds_since(t0);
  return out;
}

// ---------------------------------------------------------------------------------------------
// Output

struct Row {
  std::string section, model;
  long tets = 0, nodes = 0, springs = 0;
  std::string integrator;
  double ks = NAN, h = NAN, h_omega = NAN;
  long iterations = -1;
  std::string quantity;
  double value = NAN;
  std::string note;
};

std::string num(double v) {
  if (std::isnan(v)) return "";
  return fmt("%.10g", v);
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

struct Study {
  StiffnessOptions options;
  std::ostream& progress;
  std::vector<Row> rows;
  Clock::time_point t0 = Clock::now();

  void add(Row r) { rows.push_back(std::move(r)); }
  void say(const std::string& line) {
    progress << "stiffness [" << fmt("%.0f", seconds_since(t0)) << " s] " << line << "\n";
    progress.flush();
  }
  Row row(const std::string& section, const Model& m, const std::string& integrator = "") const {
    Row r;
    r.section = section;
    r.model = m.name;
    r.tets = m.tets;
    r.nodes = m.rest.nodes();
    r.springs = static_cast<long>(m.rest.springs.size());
    r.integrator = integrator;
    return r;
  }
};

}  // namespace

void run_stiffness_study(const StiffnessOptions& options, std::ostream& progress) {
  if (options.out.empty()) {
    throw Error(
        "study --stiffness: --out DIR: required (where stiffness.csv, the charts and "
        "report.md go)");
  }
  if (fs::exists(options.out) && !fs::is_directory(options.out)) {
    throw Error("study --stiffness: --out " + options.out.string() + ": not a folder");
  }
  fs::create_directories(options.out);
  Study st{options, progress, {}, Clock::now()};
  const bool quick = options.quick;
  const double sim_seconds = quick ? 0.1 : 1.0;  // a stability run: max(T, min_steps) steps
  const long min_steps = quick ? 100 : 1000;
  const double tol = quick ? 0.05 : 0.01;

  // Models.
  std::vector<Model> models;
  models.push_back(make_model("bar", bar(2, 1, 7), 2, 0.5, quick ? 20000 : 400000,
                              "bar(2, 1, 7): 2 x 1 x 7 unit cubes, pinned at z = 0"));
  if (!quick) {
    fs::path bunny_path = find_example(options.bunny, "examples/meshes/bunny.ply");
    TetMesh bunny = tetrahedralize(bunny_mask(bunny_path, 16));
    models.push_back(make_model("bunny", bunny, 1, 0.5, 60000,
                                bunny_path.filename().string() +
                                    ": winding-number mask, 16 samples along its longest side, "
                                    "pinned on its lowest layer (y)"));
    TetMesh blob = tetrahedralize(ellipsoid_mask(Eigen::Vector3d(33, 14, 15.3)));
    models.push_back(make_model("blob", blob, 2, 1.5, 3000,
                                "ellipsoid_mask((33, 14, 15.3)): a foot-sized blob, the nodes "
                                "within 1.5 of its lowest point pinned"));
  }
  const Model& bar_model = models.front();  // the vector is complete: the reference stays valid
  for (const Model& m : models) {
    st.say(m.name + ": " + std::to_string(m.tets) + " tets, " + std::to_string(m.rest.nodes()) +
           " nodes, " + std::to_string(m.rest.springs.size()) + " springs");
  }

  std::vector<double> ks_list;
  if (quick) {
    ks_list = {100, 10000};
  } else {
    for (int k = 0; k <= 10; ++k) ks_list.push_back(std::pow(10.0, 1 + 0.5 * k));
  }

  // ω_max per model and ks (Lanczos).
  std::map<std::pair<std::string, double>, OmegaMax> omegas;
  for (const Model& m : models) {
    for (double ks : ks_list) {
      OmegaMax w = omega_max(with_ks(m.rest, ks));
      omegas[{m.name, ks}] = w;
      Row r = st.row("stability", m);
      r.ks = ks;
      r.quantity = "omega_max";
      r.value = w.omega;
      r.iterations = w.iterations;
      r.note = w.converged ? "" : "not converged";
      st.add(r);
      r.quantity = "predicted_step";
      r.value = verlet_step_limit(w);
      r.note = "2/omega_max";
      st.add(r);
    }
    st.say(m.name + ": omega_max " + fmt("%.4g", omegas[{m.name, ks_list.front()}].omega) +
           " rad/s at ks " + fmt("%g", ks_list.front()) + " (" +
           std::to_string(omegas[{m.name, ks_list.front()}].iterations) + " Lanczos steps)");
  }

  // Stability.
  const double implicit_cap = quick ? 0.02 : 0.05;  // the largest step tried for the implicit ones
  for (const Model& m : models) {
    const bool big = m.name == "blob";
    std::map<std::string, double> last_found;  // explicit Euler's guess from the previous ks
    for (double ks : ks_list) {
      if (big && ks != ks_list[5] && ks != ks_list[6]) continue;  // ks 3162 and 1e4 only
      const OmegaMax& w = omegas[{m.name, ks}];
      const MassSpring start = perturbed(m, ks);
      const double predicted = verlet_step_limit(w);
      for (const std::string& integ : kIntegrators) {
        const bool implicit = integ == "implicit Euler" || integ == "local/global";
        if (big && implicit) continue;  // replaced by the fixed-step runs below
        if (m.name == "bunny" && integ == "implicit Euler" && std::fmod(std::log10(ks), 1.0) != 0)
          continue;  // decades only: its long runs dominate the study's time
        const double h_min = sim_seconds / m.max_steps;
        auto try_step = [&](double h) {
          long steps = std::max(min_steps, static_cast<long>(std::ceil(sim_seconds / h)));
          return run(start, integ, h, steps);
        };
        Search s;
        if (integ == "Verlet" || integ == "velocity Verlet") {
          // From 0.9 of the prediction up in steps of 5 %, so the search does not start on it.
          s = largest_stable(try_step, 0.9 * predicted, 1.05, h_min, 10.0, tol);
        } else if (integ == "explicit Euler") {
          double guess = last_found.count(integ) ? last_found[integ] : 0.05 * predicted;
          s = largest_stable(try_step, guess, 2.0, h_min, predicted, tol);
          // Its limit falls about as 1/ks (h ω² bounded): the next ks (√10 more) starts there.
          if (s.bound.empty()) last_found[integ] = s.step / std::sqrt(10.0);
        } else {
          s = largest_stable(try_step, implicit_cap, 2.0, h_min, implicit_cap, tol);
        }
        Row r = st.row("stability", m, integ);
        r.ks = ks;
        r.h = s.step;
        r.h_omega = s.step * w.omega;
        r.quantity = "largest_stable_step";
        r.value = s.step;
        r.note = s.bound == "<"    ? "unstable at every step tried (>= this)"
                 : s.bound == ">=" ? "stable at the largest step tried (this)"
                                   : "";
        r.iterations = s.runs;
        st.add(r);
        if (s.bound != "<") {
          r.quantity = "energy_drift";  // (E_end - E0) / E0 over the run at that step
          r.value = (s.at.e_end - s.at.e0) / s.at.e0;
          r.note = std::to_string(s.at.steps) + " steps";
          st.add(r);
          r.quantity = "energy_max";
          r.value = s.at.e_max / s.at.e0;
          st.add(r);
        }
        r.quantity = "search_seconds";
        r.value = s.seconds;
        r.note = std::to_string(s.runs) + " runs";
        st.add(r);
        st.say(m.name + ", ks " + fmt("%g", ks) + ", " + integ + ": largest stable step " +
               (s.bound.empty() ? "" : s.bound + " ") + fmt("%.4g", s.step) + " s (2/omega_max " +
               fmt("%.4g", predicted) + " s; " + std::to_string(s.runs) + " runs, " +
               fmt("%.1f", s.seconds) + " s)");
      }
    }
  }

  // The big model's implicit integrators: fixed-step runs at h = 0.01 s (1 s, 100 steps) instead
  // of a search (a search's 1000-step runs would take minutes each).
  for (const Model& m : models) {
    if (m.name != "blob") continue;
    for (const std::string integ : {"implicit Euler", "local/global"}) {
      for (double ks : {3e4}) {  // Tejada & Ertl's claim; ks 1e6 would add two minutes
        Run q = run(perturbed(m, ks), integ, 0.01, 100);
        Row r = st.row("stability", m, integ);
        r.ks = ks;
        r.h = 0.01;
        r.h_omega = 0.01 * omega_max(with_ks(m.rest, ks)).omega;
        r.quantity = "stable_at_h";
        r.value = q.stable ? 1 : 0;
        r.note = "100 steps (1 s)" + (q.stable ? std::string() : ": " + q.why);
        st.add(r);
        st.say(m.name + ", ks " + fmt("%g", ks) + ", " + integ +
               ": h = 0.01 s for 1 s: " + (q.stable ? "stable" : "unstable (" + q.why + ")") +
               ", " + fmt("%.1f", 1000 * q.seconds / std::max(1L, q.steps)) + " ms/step");
      }
    }
  }

  // Amplitude per period on one linear oscillator (m = 1, ks = 1, so ω = 1), against hω.
  const std::vector<double> hws =
      quick ? std::vector<double>{0.1, 1.0}
            : std::vector<double>{0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 1.5, 1.9};
  std::map<std::string, std::vector<std::pair<double, double>>> amp_measured, amp_theory;
  for (double hw : hws) {
    const double steps_per_period = 2 * std::numbers::pi / hw;
    for (const std::string& integ : kIntegrators) {
      double per_step = integ == "explicit Euler" ? std::sqrt(1 + hw * hw)
                        : (integ == "implicit Euler" || integ == "local/global")
                            ? 1 / std::sqrt(1 + hw * hw)
                            : 1.0;
      const double theory = std::pow(per_step, steps_per_period);
      // Enough periods to see the change, not so many that it leaves the double range.
      int periods = 20;
      if (theory != 1)
        periods = std::clamp(static_cast<int>(12 / std::abs(std::log(theory))), 2, 20);
      const long window = static_cast<long>(std::ceil(2 * steps_per_period));
      const long steps = static_cast<long>(std::ceil(periods * steps_per_period)) + window;
      MassSpring s;
      s.add_node(Eigen::Vector3d::Zero(), 1.0);
      s.add_node(Eigen::Vector3d(1.01, 0, 0), 1.0);
      s.add_spring(0, 1, 1.0, 0, 1.0);
      s.pin(0);
      std::unique_ptr<Integrator> in = make_integrator(integ);
      double first = 0, last = 0;
      for (long n = 0; n < steps; ++n) {
        const double u = std::abs(s.position(1).x() - 1.0);
        if (n <= window) first = std::max(first, u);
        if (n >= steps - window) last = std::max(last, u);
        if (!in->step(s, hw).ok()) break;
      }
      const double periods_between = (steps - window) / steps_per_period;
      const double factor = std::pow(last / first, 1 / periods_between);
      Row r;
      r.section = "amplitude";
      r.model = "oscillator";
      r.nodes = 2;
      r.springs = 1;
      r.integrator = integ;
      r.ks = 1;
      r.h = hw;
      r.h_omega = hw;
      r.quantity = "amplitude_per_period";
      r.value = factor;
      st.add(r);
      r.quantity = "theory_amplitude_per_period";
      r.value = theory;
      st.add(r);
      amp_measured[integ].push_back({hw, factor});
    }
  }
  for (const std::string& integ : kIntegrators) {
    for (int k = 0; k <= 60; ++k) {
      double hw = std::pow(10.0, -2 + k * (std::log10(1.95) + 2) / 60);
      double per_step = integ == "explicit Euler" ? std::sqrt(1 + hw * hw)
                        : (integ == "implicit Euler" || integ == "local/global")
                            ? 1 / std::sqrt(1 + hw * hw)
                            : 1.0;
      amp_theory[integ].push_back({hw, std::pow(per_step, 2 * std::numbers::pi / hw)});
    }
  }
  st.say("amplitude per period: " + std::to_string(hws.size()) + " values of h omega");

  // CG iterations against h ω_max, and local/global against the converged implicit step.
  std::map<std::string, std::vector<std::pair<double, double>>> cg_points, lg_points;
  for (const Model& m : models) {
    if (m.name == "blob") continue;
    const double ks = 3e4;
    const double w = omega_max(with_ks(m.rest, ks)).omega;
    const MassSpring start = perturbed(m, ks);
    for (int k = 0; k <= (quick ? 2 : 8); ++k) {
      const double hw = std::pow(10.0, -1 + 0.5 * k);
      MassSpring s = start;
      ImplicitEuler ie;
      long its = 0;
      const int steps = 5;
      for (int n = 0; n < steps; ++n) its += ie.step(s, hw / w).iterations;
      Row r = st.row("cg", m, "implicit Euler");
      r.ks = ks;
      r.h = hw / w;
      r.h_omega = hw;
      r.quantity = "cg_iterations_per_step";
      r.value = double(its) / steps;
      st.add(r);
      cg_points[m.name].push_back({hw, r.value});
    }
    // One step of h = 0.01 from a larger bend (0.2), so that the springs turn.
    const double h = 0.01;
    const MassSpring bent = perturbed(m, ks, 0.2);
    MassSpring exact = bent;
    ImplicitEuler ie;
    ie.tolerance = 1e-13;
    ie.max_iterations = 20000;
    ie.newton_iterations = 50;
    ie.newton_tolerance = 1e-14;
    StepResult q = ie.step(exact, h);
    const double scale = (exact.x - bent.x).cwiseAbs().maxCoeff();
    for (int k : {1, 2, 3, 5, 10, 20, 50, 100, 200, 500, 1000}) {
      if (quick && k > 50) break;
      MassSpring s = bent;
      LocalGlobal lg;
      lg.iterations = k;
      lg.step(s, h);
      Row r = st.row("local_global", m, "local/global");
      r.ks = ks;
      r.h = h;
      r.h_omega = h * w;
      r.iterations = k;
      r.quantity = "error_vs_converged_implicit";
      r.value = (s.x - exact.x).cwiseAbs().maxCoeff() / scale;
      r.note = "max |x - x_IE| / max |x_IE - x_n|; IE " + std::to_string(q.newton_iterations) +
               " Newton its";
      st.add(r);
      lg_points[m.name].push_back({double(k), r.value});
    }
    st.say(m.name + ": CG iterations and local/global error done");
  }

  // Speed: ms per step, median of timed steps, ks 3e4; explicit ones at half of 2/ω_max,
  // implicit ones at h = 0.01. The grid model of Mosegaard & Sørensen's size is timed too.
  std::vector<Model> timed = models;
  if (!quick) {
    GridModel g = grid_model(ellipsoid_mask(Eigen::Vector3d(28, 13, 13)), 1.0, 1.0);
    Model gm;
    gm.name = "grid";
    gm.rest = g.system;
    gm.axis = 2;
    pin_lowest(gm.rest, 2, 1.5);
    timed.push_back(gm);
  }
  std::map<std::string, double> speed;  // "model/integrator" -> ms
  for (const Model& m : timed) {
    const double ks = 3e4;
    MassSpring start = with_ks(m.rest, ks);
    const double w = omega_max(start).omega;
    for (const std::string& integ : kIntegrators) {
      const bool implicit = integ == "implicit Euler" || integ == "local/global";
      const double h = implicit ? 0.01 : 1 / w;
      const bool big = m.rest.nodes() > 10000;
      const int steps = big ? (implicit ? 4 : 20) : 50;
      MassSpring s = perturbed(m, ks);
      std::unique_ptr<Integrator> in = make_integrator(integ);
      if (auto* lg = dynamic_cast<LocalGlobal*>(in.get())) {
        auto t0 = Clock::now();
        lg->prepare(s, h);
        Row r = st.row("speed", m, integ);
        r.ks = ks;
        r.h = h;
        r.quantity = "factorisation_ms";
        r.value = 1000 * seconds_since(t0);
        r.note = std::to_string(lg->factor_nonzeros()) + " nonzeros in L";
        st.add(r);
      }
      std::vector<double> ms;
      for (int n = 0; n < steps + 1; ++n) {
        auto t0 = Clock::now();
        in->step(s, h);
        if (n > 0) ms.push_back(1000 * seconds_since(t0));
      }
      std::sort(ms.begin(), ms.end());
      Row r = st.row("speed", m, integ);
      r.ks = ks;
      r.h = h;
      r.h_omega = h * w;
      r.quantity = "ms_per_step";
      r.value = ms[ms.size() / 2];
      r.note = "median of " + std::to_string(steps) + " steps, " +
               std::to_string(std::thread::hardware_concurrency()) + " hardware threads";
      st.add(r);
      speed[m.name + "/" + integ] = r.value;
    }
    st.say(m.name + ": speed done");
  }

  // Tejada & Ertl's claims on the bar: explicit stable only to h = 0.001 at ks = 3000; implicit
  // stable at h = 0.01 with ks > 30000.
  struct Claim {
    std::string text;
    bool holds;
  };
  std::vector<Claim> claims;
  const OmegaMax w3000 = omega_max(with_ks(bar_model.rest, 3000));
  const MassSpring bar3000 = perturbed(bar_model, 3000);
  std::map<std::string, std::pair<bool, bool>> explicit_at;  // h = 0.001, 0.002
  for (const std::string integ : {"explicit Euler", "Verlet", "velocity Verlet"}) {
    const long steps = quick ? 100 : 1000;
    bool a = run(bar3000, integ, 0.001, steps).stable;
    bool b = run(bar3000, integ, 0.002, std::max(steps, quick ? 100L : 500L)).stable;
    explicit_at[integ] = {a, b};
    Row r = st.row("replay", bar_model, integ);
    r.ks = 3000;
    r.h = 0.001;
    r.quantity = "stable_at_h";
    r.value = a;
    st.add(r);
    r.h = 0.002;
    r.value = b;
    st.add(r);
  }
  std::map<double, bool> implicit_at;
  for (double ks : {3e4, 1e5, 1e6, 1e7}) {
    bool ok = run(perturbed(bar_model, ks), "implicit Euler", 0.01, quick ? 100 : 1000).stable;
    implicit_at[ks] = ok;
    Row r = st.row("replay", bar_model, "implicit Euler");
    r.ks = ks;
    r.h = 0.01;
    r.quantity = "stable_at_h";
    r.value = ok;
    st.add(r);
  }
  // The density at which 2/ω_max would be 0.001 s at ks = 3000 (ω_max ∝ 1/√density).
  const double density_for_claim = std::pow(w3000.omega * 0.001 / 2, 2);
  st.say("replayed Tejada & Ertl's claims on the bar");

  // Images against ks: the two routes on one simulation scene's final states.
  StiffnessImageOptions image_options;
  image_options.scene = find_example(options.scene, "examples/bunny_simulation.json");
  image_options.out = options.out;
  image_options.ks =
      quick ? std::vector<double>{3e4} : std::vector<double>{1e3, 3e3, 1e4, 3e4, 1e5, 3e5, 1e6};
  image_options.size = quick ? 128 : 256;
  image_options.timing_size = quick ? 128 : 512;
  image_options.frames = quick ? 1 : 5;
  const std::string images_md = run_stiffness_images(image_options, progress);

  // stiffness.csv
  {
    std::ostringstream csv;
    csv << kStiffnessCsvHeader << "\n";
    for (const Row& r : st.rows) {
      csv << csv_field(r.section) << "," << csv_field(r.model) << "," << r.tets << "," << r.nodes
          << "," << r.springs << "," << csv_field(r.integrator) << "," << num(r.ks) << ","
          << num(r.h) << "," << num(r.h_omega) << ","
          << (r.iterations >= 0 ? std::to_string(r.iterations) : "") << "," << csv_field(r.quantity)
          << "," << num(r.value) << "," << csv_field(r.note) << "\n";
    }
    write_file_atomic((options.out / "stiffness.csv").string(), csv.str());
  }

  // Charts.
  {
    chart::Chart c;
    c.title = "Largest stable step against ks (measured; 2/omega_max predicted)";
    for (const Model& m : models) {
      chart::Panel p;
      p.title = m.name + " (" + std::to_string(m.tets) + " tets)";
      p.x_label = "ks (force / unit)";
      p.y_label = "largest stable step (s)";
      std::map<std::string, chart::Series> series;
      for (const Row& r : st.rows) {
        if (r.section != "stability" || r.model != m.name) continue;
        if (r.quantity == "largest_stable_step" && r.note.empty()) {
          series[r.integrator].name = r.integrator;
          series[r.integrator].x.push_back(r.ks);
          series[r.integrator].y.push_back(r.value);
        } else if (r.quantity == "predicted_step") {
          series["~"].name = "2/omega_max (Lanczos)";
          series["~"].x.push_back(r.ks);
          series["~"].y.push_back(r.value);
        }
      }
      for (auto& [k, v] : series) p.series.push_back(v);
      c.panels.push_back(p);
    }
    chart::write_svg((options.out / "stability.svg").string(), c);
  }
  {
    chart::Chart c;
    c.title = "Amplitude factor per period against h omega (one linear oscillator)";
    chart::Panel p;
    p.title = "measured (large points) and theory (small points)";
    p.x_label = "h omega";
    p.y_label = "amplitude factor per period";
    for (const std::string& integ : kIntegrators) {
      chart::Series s{integ, {}, {}}, t{"theory: " + integ, {}, {}};
      for (auto [x, y] : amp_measured[integ]) {
        s.x.push_back(x);
        s.y.push_back(y);
      }
      for (auto [x, y] : amp_theory[integ]) {
        t.x.push_back(x);
        t.y.push_back(y);
      }
      p.series.push_back(s);
      p.series.push_back(t);
    }
    c.panels.push_back(p);
    c.columns = 1;
    chart::write_svg((options.out / "amplitude.svg").string(), c);
  }
  {
    chart::Chart c;
    c.title = "Implicit Euler's CG iterations and local/global's error";
    chart::Panel p;
    p.title = "CG iterations per step (ks 3e4)";
    p.x_label = "h omega_max";
    p.y_label = "CG iterations per step";
    for (auto& [name, pts] : cg_points) {
      chart::Series s{name, {}, {}};
      for (auto [x, y] : pts) {
        s.x.push_back(x);
        s.y.push_back(y);
      }
      p.series.push_back(s);
    }
    chart::Panel q;
    q.title = "local/global against converged implicit Euler (h 0.01, ks 3e4)";
    q.x_label = "local/global iterations";
    q.y_label = "max |x - x_IE| / max |x_IE - x_n|";
    q.y_floor = 1e-16;
    for (auto& [name, pts] : lg_points) {
      chart::Series s{name, {}, {}};
      for (auto [x, y] : pts) {
        s.x.push_back(x);
        s.y.push_back(y);
      }
      q.series.push_back(s);
    }
    c.panels = {p, q};
    chart::write_svg((options.out / "solvers.svg").string(), c);
  }

  // report.md
  const double total = seconds_since(st.t0);
  std::ostringstream md;
  md << "# Stiffness study\n\n"
     << "Written by `raywarp study --stiffness" << (quick ? " --quick" : "") << " --out "
     << options.out.generic_string() << "` in " << fmt("%.0f", total) << " s on "
     << std::thread::hardware_concurrency()
     << " hardware threads. Figures: `stiffness.csv` (one row per figure), `stability.svg`, "
        "`amplitude.svg`, `solvers.svg`, `images.csv`, `images.svg`, `images/`.\n\n"
     << "Models (voxel units: spacing 1, density 1, an interior node weighs 1; no gravity, no "
        "damping; start: a bend of 0.01 (t²) across the pinned axis plus 1e-6 noise, at rest):\n\n";
  for (const Model& m : models) {
    md << "- **" << m.name << "**: " << m.tets << " tets, " << m.rest.nodes() << " nodes, "
       << m.rest.springs.size() << " springs, total mass " << fmt("%.6g", m.rest.mass.sum())
       << ", node masses " << fmt("%.4g", m.rest.mass.minCoeff()) << " to "
       << fmt("%.4g", m.rest.mass.maxCoeff()) << "; " << m.note << ".\n";
  }
  md << "\n## Largest stable step\n\n"
     << "Stable: over max(" << fmt("%g", sim_seconds) << " s, " << min_steps
     << " steps) no non-finite value and total energy <= 1.05 E0 (position Verlet's energy with "
        "the centred velocity). Found by bisection to "
     << fmt("%g", 100 * tol)
     << " %. `<` h: unstable down to the smallest step whose run fits the model's step budget; "
        "`>=` h: stable at the largest step tried.\n\n";
  for (const Model& m : models) {
    md << "### " << m.name << "\n\n| ks | 2/ω_max (s) |";
    for (const std::string& i : kIntegrators) md << " " << i << " |";
    md << "\n| ---: | ---: |";
    for (size_t k = 0; k < kIntegrators.size(); ++k) md << " ---: |";
    md << "\n";
    for (double ks : ks_list) {
      md << "| " << fmt("%g", ks) << " | " << fmt("%.4g", verlet_step_limit(omegas[{m.name, ks}]))
         << " |";
      for (const std::string& integ : kIntegrators) {
        std::string cell = "-";
        for (const Row& r : st.rows) {
          if (r.section == "stability" && r.model == m.name && r.integrator == integ &&
              r.ks == ks && r.quantity == "largest_stable_step") {
            cell = (r.note.rfind("unstable", 0) == 0 ? "< "
                    : r.note.rfind("stable", 0) == 0 ? ">= "
                                                     : "") +
                   fmt("%.4g", r.value);
          }
        }
        md << " " << cell << " |";
      }
      md << "\n";
    }
    md << "\n";
  }
  md << "Explicit Euler is unstable on an undamped oscillator at every step (energy × (1 + ω²h²) "
        "per step): its figures are where the growth over the run stays under 5 %, not a "
        "stability limit.\n\n";
  md << "## Speed (ms per step, median; ks 3e4)\n\n| model | integrator | ms/step |\n| --- | --- | "
        "---: |\n";
  for (auto& [k, v] : speed) {
    auto slash = k.find('/');
    md << "| " << k.substr(0, slash) << " | " << k.substr(slash + 1) << " | " << fmt("%.3g", v)
       << " |\n";
  }
  md << "\n## The seeds' figures beside ours\n\n"
     << "| claim | seed | ours |\n| --- | --- | --- |\n"
     << "| grid of 20,000 nodes, one step | Mosegaard & Sørensen: 2.22 ms (GeForce 6800) | "
     << (speed.count("grid/Verlet") ? fmt("%.3g", speed["grid/Verlet"]) + " ms (Verlet, " +
                                          std::to_string(timed.back().rest.nodes()) + " nodes)"
                                    : "not run (quick)")
     << " |\n"
     << "| Foot, 156,612 tets, explicit Euler step | Tejada & Ertl: 4.5 ms (GeForce 7800) | "
     << (speed.count("blob/explicit Euler") ? fmt("%.3g", speed["blob/explicit Euler"]) + " ms"
                                            : "not run (quick)")
     << " |\n"
     << "| Foot, implicit Euler step | Tejada & Ertl: 83 ms | "
     << (speed.count("blob/implicit Euler") ? fmt("%.3g", speed["blob/implicit Euler"]) + " ms"
                                            : "not run (quick)")
     << " |\n\n";
  md << "## Tejada & Ertl's stability claims replayed on the bar\n\n"
     << "Our bar: " << bar_model.tets << " tets (theirs: 80), density 1, unit cubes (node masses "
     << fmt("%.4g", bar_model.rest.mass.minCoeff()) << " to "
     << fmt("%.4g", bar_model.rest.mass.maxCoeff()) << ", total "
     << fmt("%.4g", bar_model.rest.mass.sum())
     << "). At ks = 3000, ω_max = " << fmt("%.4g", w3000.omega)
     << " rad/s, so 2/ω_max = " << fmt("%.4g", 2 / w3000.omega) << " s.\n\n";
  md << "- *Explicit methods stable only up to h = 0.001 s at ks = 3000*: on our bar, at h = "
        "0.001 s: ";
  for (auto& [integ, ab] : explicit_at) {
    md << integ << " " << (ab.first ? "stable" : "unstable") << ", ";
  }
  md << "and at h = 0.002 s: ";
  for (auto& [integ, ab] : explicit_at) {
    md << integ << " " << (ab.second ? "stable" : "unstable") << ", ";
  }
  md << "so the Verlet limit of our bar is " << fmt("%.3g", 2 / w3000.omega / 0.001)
     << " times theirs. The limit scales as √(m / ks): it would be 0.001 s at a density of "
     << fmt("%.3g", density_for_claim)
     << " (node masses that much lighter), which is what their masses must have been if their "
        "bar had our geometry; the paper gives no masses.\n";
  md << "- *Implicit Euler stable at h = 0.01 s with ks > 30000*: on our bar, implicit Euler at h "
        "= 0.01 s over 1000 steps: ";
  for (auto& [ks, ok] : implicit_at)
    md << "ks " << fmt("%g", ks) << " " << (ok ? "stable" : "unstable") << "; ";
  md << "it holds (implicit Euler only loses energy on the linearised system, by 1/(1 + ω²h²) per "
        "step and mode).\n";
  md << "\n" << images_md;
  write_file_atomic((options.out / "report.md").string(), md.str());
  st.say("wrote " + (options.out / "stiffness.csv").string() + ", the charts and report.md in " +
         fmt("%.0f", total) + " s");
}

}  // namespace raywarp
