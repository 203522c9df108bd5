// raywarp_cylindrical_bench: texture memory against interpolation error, Cartesian textures
// against cylindrical ones (library/cylindrical.h), for the two fields a cylindrical mapping is
// meant for (docs/cylindrical.md#measured):
//   - a 720-degree twist about y: its deformation texture D, in the box of half extents
//     (1, 1.5, 1) of the registry's examples and in the bunny's twist box (examples/
//     bunny_twist.json, half extents (5.2, 2.895, 4));
//   - a groove about y (radius 0.6, width 0.5, the registry's example) in the first box: its
//     alpha map A.
// Each mapping is baked over a sweep of layouts (Cartesian: n texels along the longest side,
// cubic texels; cylindrical: angle x radius x height texels) and its error measured twice, in
// object units: as the bake measures it (deformation_texture_error with stride 1 or
// cylindrical_deformation_error; alpha_map_error or cylindrical_alpha_error within a band of 2
// voxels of the cut face), and over one set of seeded probe points for every layout, read as the
// ray caster reads the texture (D: p' = F(p) with p uniform in the box, |p' + D(p') - p|; A:
// points uniform in the box within the band, |A_read - A|). The probe sees what the bake measures
// leave out: D's cells at the twist's end faces (the angle's kink), and a band that a coarse A's
// cell centres all miss. Error targets are in voxels of a 128-voxel grid across the box's longest
// side (the automatic layouts' unit, library/scene.h); per target and mapping, the layout of
// least memory in the sweep that meets it: D by its bake measure, A by the larger of its two
// errors (the same quantity over the same band). Memory: texels x 16 bytes for D (RGBA32F), x 4
// for A (R32F). Bake times: medians of --runs bakes (measurements not included); errors are
// deterministic. Then the automatic layouts (a scene's "resolution": "auto") side by side.
//   raywarp_cylindrical_bench [--quick] [--runs N] [--sweep]
// --quick: Cartesian layouts up to n = 128 and one run; --sweep: every layout's figures, too.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "deformers/registry.h"
#include "library/cylindrical.h"
#include "library/deformation_bake.h"
#include "library/scene.h"

using namespace raywarp;

namespace {

constexpr int kVoxelsAcross = 128;                         // the voxel the targets count in
constexpr double kTargetVoxels[] = {0.5, 0.2, 0.1, 0.05};  // error targets, voxels
constexpr int kAxis = 1;                                   // y: the twist's and groove's axis
constexpr int kProbePoints = 200000;

// One baked layout.
struct Config {
  std::string mapping;  // "Cartesian", "cylindrical", ...
  std::string layout;   // "n = 64 (61x64x61)", "8x32x32"
  std::uint64_t bytes = 0;
  double measured = 0.0;  // the bake's own measure, object units
  double probe = 0.0;     // the largest over the probe points, object units
  double bake_ms = 0.0;   // median over the runs
  // The error a target is met by: D's own measure; A's, or the probe's where larger (the same
  // quantity over the same band, at points a coarse layout's cell centres may all miss).
  bool alpha = false;
  double error() const { return alpha ? std::max(measured, probe) : measured; }
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

std::string num(double x, const char* format) {
  char s[48];
  std::snprintf(s, sizeof s, format, x);
  return s;
}

std::string kib(std::uint64_t bytes) {
  const double k = double(bytes) / 1024.0;
  return num(k, k < 10 ? "%.2f" : (k < 100 ? "%.1f" : "%.0f"));
}

std::string dims_text(const Eigen::Vector3i& d) {
  return std::to_string(d[0]) + "x" + std::to_string(d[1]) + "x" + std::to_string(d[2]);
}

std::uint64_t texels(const Eigen::Vector3i& d) {
  return std::uint64_t(d[0]) * std::uint64_t(d[1]) * std::uint64_t(d[2]);
}

// Probe points for D: (p', p) with p uniform in the box (seeded) and p' = F(p).
using DeformationProbe = std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>>;
DeformationProbe deformation_probe(const Deformer& d, const Eigen::Vector3d& h) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  DeformationProbe out;
  for (int i = 0; i < kProbePoints; ++i) {
    const Eigen::Vector3d p = Eigen::Vector3d(u(rng), u(rng), u(rng)).cwiseProduct(h);
    out.emplace_back(d.forward(p), p);
  }
  return out;
}

// Probe points for A: uniform in the box (seeded), those within `band` of the cut face.
std::vector<Eigen::Vector3d> alpha_probe(const Deformer& d, const Eigen::Vector3d& h, double band) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::Vector3d> out;
  while (out.size() < size_t(kProbePoints)) {
    const Eigen::Vector3d p = Eigen::Vector3d(u(rng), u(rng), u(rng)).cwiseProduct(h);
    if (std::abs(d.alpha(p)) < band) out.push_back(p);
  }
  return out;
}

// The largest error over the probe points of a Cartesian D, a cylindrical D, a Cartesian A and a
// cylindrical A, each read as the ray caster reads it.
double probe_error(const DeformationProbe& probe, const DeformationTexture& t) {
  double worst = 0.0;
  for (const auto& [p_def, p] : probe)
    worst = std::max(worst, (p_def + t.grid.sample(p_def).head<3>() - p).norm());
  return worst;
}
double probe_cylindrical_error(const DeformationProbe& probe, const DeformationTexture& t) {
  double worst = 0.0;
  for (const auto& [p_def, p] : probe)
    worst = std::max(worst,
                     (p_def + cylindrical_displacement(t.grid, kAxis, p_def).head<3>() - p).norm());
  return worst;
}
double probe_error(const Deformer& d, const std::vector<Eigen::Vector3d>& probe,
                   const AlphaMap& m) {
  double worst = 0.0;
  for (const Eigen::Vector3d& p : probe)
    worst = std::max(worst, std::abs(m.grid.sample(p).value() - d.alpha(p)));
  return worst;
}
double probe_cylindrical_error(const Deformer& d, const std::vector<Eigen::Vector3d>& probe,
                               const AlphaMap& m) {
  double worst = 0.0;
  for (const Eigen::Vector3d& p : probe)
    worst = std::max(worst, std::abs(cylindrical_alpha(m.grid, kAxis, p) - d.alpha(p)));
  return worst;
}

// Bakes `runs` times (bake() returns a texture with bake_seconds); the last bake, the median ms.
template <class Bake>
auto timed(int runs, Bake&& bake, double& ms) {
  std::vector<double> times;
  auto texture = bake();
  times.push_back(texture.bake_seconds * 1e3);
  for (int r = 1; r < runs; ++r) {
    texture = bake();
    times.push_back(texture.bake_seconds * 1e3);
  }
  ms = median(times);
  return texture;
}

std::vector<Config> cartesian_deformation(const Deformer& d, const Eigen::Vector3d& h,
                                          const DeformationProbe& probe,
                                          const std::vector<int>& resolutions, int runs) {
  std::vector<Config> out;
  for (int n : resolutions) {
    Config c;
    c.mapping = "Cartesian";
    const DeformationTexture t = timed(
        runs, [&] { return bake_deformation(d, h, n); }, c.bake_ms);
    c.layout = "n = " + std::to_string(n) + " (" + dims_text(t.grid.dims) + ")";
    c.bytes = texels(t.grid.dims) * sizeof(Eigen::Vector4f);
    c.measured = deformation_texture_error(d, t, 1);
    c.probe = probe_error(probe, t);
    out.push_back(c);
  }
  return out;
}

std::vector<Config> cylindrical_deformation(const Deformer& d, const Eigen::Vector3d& h,
                                            const CylindricalDomain& domain,
                                            const std::string& mapping,
                                            const DeformationProbe& probe,
                                            const std::vector<int>& angles,
                                            const std::vector<int>& counts, int runs) {
  std::vector<Config> out;
  for (int a : angles)
    for (int nr : counts)
      for (int nh : counts) {
        Config c;
        c.mapping = mapping;
        const Eigen::Vector3i n(a, nr, nh);
        const DeformationTexture t = timed(
            runs, [&] { return bake_cylindrical_deformation(d, kAxis, domain, n); }, c.bake_ms);
        c.layout = dims_text(n);
        c.bytes = texels(n) * sizeof(Eigen::Vector4f);
        c.measured = cylindrical_deformation_error(d, h, t, kAxis);
        c.probe = probe_cylindrical_error(probe, t);
        out.push_back(c);
      }
  return out;
}

std::vector<Config> cartesian_alpha(const Deformer& d, const Eigen::AlignedBox3d& region,
                                    double band, const std::vector<Eigen::Vector3d>& probe,
                                    const std::vector<int>& resolutions, int runs) {
  std::vector<Config> out;
  for (int n : resolutions) {
    Config c;
    c.mapping = "Cartesian";
    c.alpha = true;
    const AlphaMap m = timed(
        runs, [&] { return bake_alpha(d, region, n); }, c.bake_ms);
    c.layout = "n = " + std::to_string(n) + " (" + dims_text(m.grid.dims) + ")";
    c.bytes = texels(m.grid.dims) * sizeof(float);
    c.measured = alpha_map_error(d, m, band, 1);
    c.probe = probe_error(d, probe, m);
    out.push_back(c);
  }
  return out;
}

std::vector<Config> cylindrical_alpha_sweep(const Deformer& d, const CylindricalDomain& domain,
                                            double band, const std::vector<Eigen::Vector3d>& probe,
                                            const std::vector<int>& angles,
                                            const std::vector<int>& counts, int runs) {
  std::vector<Config> out;
  for (int a : angles)
    for (int nr : counts)
      for (int nh : counts) {
        Config c;
        c.mapping = "cylindrical";
        c.alpha = true;
        const Eigen::Vector3i n(a, nr, nh);
        const AlphaMap m = timed(
            runs, [&] { return bake_cylindrical_alpha(d, kAxis, domain, n); }, c.bake_ms);
        c.layout = dims_text(n);
        c.bytes = texels(n) * sizeof(float);
        c.measured = cylindrical_alpha_error(d, m, kAxis, band);
        c.probe = probe_cylindrical_error(d, probe, m);
        out.push_back(c);
      }
  return out;
}

// The layout of least memory whose error is at most `target` (ties: the smaller error), or null.
const Config* cheapest(const std::vector<Config>& sweep, double target) {
  const Config* best = nullptr;
  for (const Config& c : sweep)
    if (c.error() <= target &&
        (!best || c.bytes < best->bytes || (c.bytes == best->bytes && c.error() < best->error())))
      best = &c;
  return best;
}

// One case's table at equal error: per target, each mapping's cheapest layout (sweeps[0] is the
// Cartesian one, the reference of the memory ratio; where it has none, the ratio is a lower bound
// from its largest layout).
void print_equal_error(const std::string& title, double voxel,
                       const std::vector<std::vector<Config>>& sweeps) {
  std::printf(
      "\n%s\n\n| target, voxels | target | mapping | layout | KiB | bake measure | probe | "
      "bake ms | Cartesian / this, memory |\n"
      "| ---: | ---: | --- | --- | ---: | ---: | ---: | ---: | ---: |\n",
      title.c_str());
  std::uint64_t largest_cartesian = 0;
  for (const Config& c : sweeps[0]) largest_cartesian = std::max(largest_cartesian, c.bytes);
  for (double tv : kTargetVoxels) {
    const double target = tv * voxel;
    const Config* reference = cheapest(sweeps[0], target);
    for (const auto& sweep : sweeps) {
      const Config* c = cheapest(sweep, target);
      std::printf("| %s | %s | %s | ", num(tv, "%g").c_str(), num(target, "%.2e").c_str(),
                  sweep.front().mapping.c_str());
      if (!c) {
        std::printf("none in the sweep | | | | | |\n");
        continue;
      }
      const std::string ratio =
          reference ? num(double(reference->bytes) / double(c->bytes), "%.0f")
                    : "> " + num(double(largest_cartesian) / double(c->bytes), "%.0f");
      std::printf("%s | %s | %s | %s | %s | %s |\n", c->layout.c_str(), kib(c->bytes).c_str(),
                  num(c->measured, "%.2e").c_str(), num(c->probe, "%.2e").c_str(),
                  num(c->bake_ms, c->bake_ms < 10 ? "%.2f" : "%.0f").c_str(), ratio.c_str());
    }
  }
  std::fflush(stdout);
}

void print_sweep(const std::string& title, const std::vector<Config>& sweep) {
  std::printf(
      "\n%s Every layout, %s.\n\n| layout | KiB | bake measure | probe | bake ms |\n"
      "| --- | ---: | ---: | ---: | ---: |\n",
      title.c_str(), sweep.front().mapping.c_str());
  for (const Config& c : sweep)
    std::printf("| %s | %s | %s | %s | %s |\n", c.layout.c_str(), kib(c.bytes).c_str(),
                num(c.measured, "%.2e").c_str(), num(c.probe, "%.2e").c_str(),
                num(c.bake_ms, "%.2f").c_str());
  std::fflush(stdout);
}

std::unique_ptr<Deformer> twist(const Eigen::Vector3d& h, double angle_deg) {
  DeformerSpec s;
  s.type = "twist";
  s.axis = kAxis;
  s.angle_deg = angle_deg;
  return make_deformer(s, h);
}

std::unique_ptr<Deformer> groove(const Eigen::Vector3d& h, double radius, double width) {
  DeformerSpec s;
  s.type = "groove";
  s.axis = kAxis;
  s.radius = radius;
  s.opening = width;  // the registry keeps a groove's "width" in `opening`
  return make_deformer(s, h);
}

// One automatic layout's figures.
struct AutoRow {
  std::string label, mapping, layout;
  std::uint64_t bytes = 0;
  double target = 0.0, error = 0.0, probe = 0.0, seconds = 0.0;
  int bakes = 0;
  bool budget_bound = false;
};

}  // namespace

int main(int argc, char** argv) {
  int runs = 3;
  bool quick = false, sweep = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--runs" && i + 1 < argc) {
      runs = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--quick") {
      quick = true;
    } else if (a == "--sweep") {
      sweep = true;
    } else {
      std::cerr << "usage: raywarp_cylindrical_bench [--quick] [--runs N] [--sweep]\n";
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  if (quick) runs = 1;
  std::vector<int> cartesian = {16, 24, 32, 48, 64, 96, 128, 192, 256};
  if (quick) cartesian.resize(7);  // up to 128
  const std::vector<int> angles = {4, 8, 16};
  const std::vector<int> counts = {8, 16, 32, 64};
  const std::vector<int> alpha_counts = {8, 16, 32, 64, 128, 256, 512};
  std::vector<int> alpha_cartesian = cartesian;
  if (!quick) alpha_cartesian.push_back(384);  // A takes a quarter of D's bytes per texel
  const Eigen::Vector3i cylindrical_floor(kAutoCylindricalFloor[0], kAutoCylindricalFloor[1],
                                          kAutoCylindricalFloor[2]);
  const std::uint64_t d_budget = std::uint64_t(64) << 20, a_budget = std::uint64_t(16) << 20;

  std::string sweep_text;
  for (size_t i = 0; i < cartesian.size(); ++i)
    sweep_text += (i ? ", " : "") + std::to_string(cartesian[i]);
  std::printf(
      "Cartesian against cylindrical textures about y (library/cylindrical.h).\n"
      "Cartesian layouts: n texels along the longest side (cubic texels), n = %s%s;\n"
      "D over F(box) padded by a texel, A over the box. Cylindrical layouts: angle x radius x\n"
      "height texels, angle 4, 8, 16, radius and height 8, 16, 32, 64 (A: up to 512); over the\n"
      "box (the radius of its corners, its height) or, for D, over F(box) grown by 2 voxels along\n"
      "each axis, as a scene's bake lays it (\"scene's domain\").\n"
      "Errors, object units. Bake measure: the bake's own, at cell centres (D: the preimage's\n"
      "distance over cells of valid texels; A: |A_read - A| within 2 voxels of the cut face).\n"
      "Probe: the largest over %d seeded points read as the ray caster reads them (D: |p' +\n"
      "D(p') - p| at p' = F(p), p uniform in the box, end faces included; A: |A_read - A| at\n"
      "points of the box within 2 voxels of the cut face). A target is met by D's bake measure,\n"
      "by the larger of A's two. A voxel: the box's longest side / %d. Memory: texels x 16 B\n"
      "(D, RGBA32F) or x 4 B (A, R32F). Bake ms: the median of %d bakes on this machine, noisy;\n"
      "the errors are deterministic.\n",
      sweep_text.c_str(), quick ? "" : " (A: and 384)", kProbePoints, kVoxelsAcross, runs);
  std::fflush(stdout);

  try {
    {  // Warm up the thread pool so that the first timed bake is not the slowest.
      const Eigen::Vector3d h(1, 1.5, 1);
      bake_deformation(*twist(h, 720), h, 32);
    }
    std::vector<AutoRow> autos;

    // Case 1: a 720-degree twist, D.
    for (const Eigen::Vector3d& h : {Eigen::Vector3d(1, 1.5, 1), Eigen::Vector3d(5.2, 2.895, 4)}) {
      const auto d = twist(h, 720);
      const double voxel = 2.0 * h.maxCoeff() / kVoxelsAcross;
      const std::string extents =
          "(" + num(h[0], "%g") + ", " + num(h[1], "%g") + ", " + num(h[2], "%g") + ")";
      const std::string label = "twist, h " + extents;
      const std::string title = "Twist by 720 degrees about y, box half extents " + extents +
                                ", D; voxel " + num(voxel, "%.4g") + ".";
      const CylindricalDomain box_domain = cylindrical_domain(Eigen::AlignedBox3d(-h, h), kAxis);
      const CylindricalDomain scene_domain =
          cylindrical_domain(deformed_bounds(*d, h, 2.0 * voxel), kAxis, h);
      const DeformationProbe probe = deformation_probe(*d, h);
      const std::vector<std::vector<Config>> sweeps = {
          cartesian_deformation(*d, h, probe, cartesian, runs),
          cylindrical_deformation(*d, h, box_domain, "cylindrical", probe, angles, counts, runs),
          cylindrical_deformation(*d, h, scene_domain, "cylindrical, scene's domain", probe, angles,
                                  counts, runs)};
      print_equal_error(title, voxel, sweeps);
      if (sweep)
        for (const auto& s : sweeps) print_sweep(title, s);

      const double target = kAutoErrorVoxels * voxel;
      const AutoDeformation a =
          bake_deformation_auto(*d, h, target, d_budget, kAutoFloorResolution, false);
      autos.push_back({label, "Cartesian", dims_text(a.texture.grid.dims),
                       texels(a.texture.grid.dims) * 16, target, a.error,
                       probe_error(probe, a.texture), a.texture.bake_seconds, a.choice.bakes,
                       a.choice.budget_bound});
      for (const auto& [mapping, domain] :
           {std::make_pair("cylindrical", box_domain),
            std::make_pair("cylindrical, scene's domain", scene_domain)}) {
        const AutoDeformation c = bake_cylindrical_deformation_auto(*d, h, kAxis, domain, target,
                                                                    d_budget, cylindrical_floor);
        autos.push_back({label, mapping, dims_text(c.texture.grid.dims),
                         texels(c.texture.grid.dims) * 16, target, c.error,
                         probe_cylindrical_error(probe, c.texture), c.texture.bake_seconds,
                         c.choice.bakes, c.choice.budget_bound});
      }
    }

    // Case 2: a groove, A.
    {
      const Eigen::Vector3d h(1, 1.5, 1);
      const auto d = groove(h, 0.6, 0.5);
      const double voxel = 2.0 * h.maxCoeff() / kVoxelsAcross;
      const double band = kAlphaBandVoxels * voxel;
      const std::string title =
          "Groove about y, radius 0.6, width 0.5, box half extents (1, 1.5, 1), A; voxel " +
          num(voxel, "%.4g") + ", band " + num(band, "%.4g") + ".";
      const std::string label = "groove, h (1, 1.5, 1)";
      const Eigen::AlignedBox3d region(-h, h);
      const CylindricalDomain domain = cylindrical_domain(region, kAxis);
      const std::vector<Eigen::Vector3d> probe = alpha_probe(*d, h, band);
      const std::vector<std::vector<Config>> sweeps = {
          cartesian_alpha(*d, region, band, probe, alpha_cartesian, runs),
          cylindrical_alpha_sweep(*d, domain, band, probe, angles, alpha_counts, runs)};
      print_equal_error(title, voxel, sweeps);
      if (sweep)
        for (const auto& s : sweeps) print_sweep(title, s);

      const double target = kAutoErrorVoxels * voxel;
      const AutoAlpha a =
          bake_alpha_auto(*d, region, target, band, a_budget, kAutoAlphaFloorResolution);
      autos.push_back({label, "Cartesian", dims_text(a.map.grid.dims), texels(a.map.grid.dims) * 4,
                       target, a.error, probe_error(*d, probe, a.map), a.map.bake_seconds,
                       a.choice.bakes, a.choice.budget_bound});
      const AutoAlpha c =
          bake_cylindrical_alpha_auto(*d, kAxis, domain, target, band, a_budget, cylindrical_floor);
      autos.push_back({label, "cylindrical", dims_text(c.map.grid.dims),
                       texels(c.map.grid.dims) * 4, target, c.error,
                       probe_cylindrical_error(*d, probe, c.map), c.map.bake_seconds,
                       c.choice.bakes, c.choice.budget_bound});
    }

    std::printf(
        "\nAutomatic layouts: target %g voxel, budget 64 MiB (D) or 16 MiB (A), floors n = %d "
        "(D) or %d (A), cylindrical %dx%dx%d; bake measure: what the layout aimed at; ms: all "
        "bakes and measurements.\n\n"
        "| case | mapping | layout | KiB | target | bake measure | probe | bakes | ms |\n"
        "| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |\n",
        kAutoErrorVoxels, kAutoFloorResolution, kAutoAlphaFloorResolution, cylindrical_floor[0],
        cylindrical_floor[1], cylindrical_floor[2]);
    for (const AutoRow& r : autos)
      std::printf("| %s | %s | %s%s | %s | %s | %s | %s | %d | %s |\n", r.label.c_str(),
                  r.mapping.c_str(), r.layout.c_str(), r.budget_bound ? " (budget)" : "",
                  kib(r.bytes).c_str(), num(r.target, "%.2e").c_str(), num(r.error, "%.2e").c_str(),
                  num(r.probe, "%.2e").c_str(), r.bakes, num(r.seconds * 1e3, "%.1f").c_str());
  } catch (const std::exception& e) {
    std::cerr << "raywarp_cylindrical_bench: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
