// raywarp_from_mesh_bench: the bake of a from_mesh box on a large mesh (docs/from_mesh.md#cost
// of-a-large-target): time per stage and peak memory, medians over runs (not a test).
//   raywarp_from_mesh_bench [--mesh FILE] [--subdivide K] [--runs N] [--resolution CELLS]
// The mesh (default: the shipped armadillo, 26,002 vertices) is split K times (default 2: each
// triangle into four at its edge midpoints, 416,002 vertices) and written as a binary PLY; its
// deformed copy is the same vertices with those in a box over the mesh's upper half moved by
// raywarp's exact twist (90 degrees about y, the box's -y face held). A scene with a from_mesh box
// reading that copy (the deformer's defaults: a 48-cell lattice, pinned -y) is baked N times in a
// fresh session without the disk cache: the target read, the fit, the distance grid and the
// deformation texture, each with its seconds, and the process's peak resident memory during the
// bake (VmHWM, reset before each run) against the bake's budget (kMemoryBudgetBytes); then the
// same bake read back from a disk cache.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "base/error.h"
#include "library/bake.h"
#include "library/bake_cache.h"
#include "library/mesh.h"
#include "library/prepare.h"
#include "library/scene.h"

using namespace raywarp;
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Each triangle into four at its edges' midpoints (shared edges share their midpoint).
Mesh subdivide(const Mesh& m) {
  std::map<std::pair<int, int>, int> mid;
  std::vector<Eigen::Vector3d> v;
  v.reserve(static_cast<size_t>(m.V.rows()) * 4);
  for (long i = 0; i < m.V.rows(); ++i) v.push_back(m.V.row(i).transpose());
  auto midpoint = [&](int a, int b) {
    const auto key = std::minmax(a, b);
    auto it = mid.find(key);
    if (it != mid.end()) return it->second;
    v.push_back(0.5 * (v[static_cast<size_t>(a)] + v[static_cast<size_t>(b)]));
    const int index = static_cast<int>(v.size()) - 1;
    mid.emplace(key, index);
    return index;
  };
  std::vector<Eigen::Vector3i> f;
  f.reserve(static_cast<size_t>(m.F.rows()) * 4);
  for (long t = 0; t < m.F.rows(); ++t) {
    const int a = m.F(t, 0), b = m.F(t, 1), c = m.F(t, 2);
    const int ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
    f.emplace_back(a, ab, ca);
    f.emplace_back(ab, b, bc);
    f.emplace_back(ca, bc, c);
    f.emplace_back(ab, bc, ca);
  }
  Mesh out;
  out.V.resize(static_cast<long>(v.size()), 3);
  for (size_t i = 0; i < v.size(); ++i) out.V.row(static_cast<long>(i)) = v[i].transpose();
  out.F.resize(static_cast<long>(f.size()), 3);
  for (size_t i = 0; i < f.size(); ++i) out.F.row(static_cast<long>(i)) = f[i].transpose();
  return out;
}

void write_binary_ply(const fs::path& path, const Eigen::Matrix<double, -1, 3, 1>& V,
                      const Mesh& topology) {
  std::ofstream out(path, std::ios::binary);
  out << "ply\nformat binary_little_endian 1.0\nelement vertex " << V.rows()
      << "\nproperty float x\nproperty float y\nproperty float z\nelement face "
      << topology.F.rows() << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (long i = 0; i < V.rows(); ++i)
    for (int a = 0; a < 3; ++a) {
      const float x = static_cast<float>(V(i, a));
      out.write(reinterpret_cast<const char*>(&x), 4);
    }
  for (long t = 0; t < topology.F.rows(); ++t) {
    const unsigned char three = 3;
    out.write(reinterpret_cast<const char*>(&three), 1);
    for (int c = 0; c < 3; ++c) {
      const int index = topology.F(t, c);
      out.write(reinterpret_cast<const char*>(&index), 4);
    }
  }
  if (!out) throw Error(path.string() + ": cannot write");
}

// The process's peak resident memory since the last reset, bytes (VmHWM); -1 when unknown.
long long peak_rss() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stoll(line.substr(6)) * 1024;
  return -1;
}
long long current_rss() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stoll(line.substr(6)) * 1024;
  return -1;
}
void reset_peak_rss() { std::ofstream("/proc/self/clear_refs") << "5"; }

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

double mib(double bytes) { return bytes / (1024.0 * 1024.0); }

}  // namespace

int main(int argc, char** argv) {
  std::string mesh_file = std::string(RAYWARP_SOURCE_DIR) + "/examples/meshes/armadillo.ply.xz";
  int splits = 2, runs = 3, resolution = 48;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&] {
      if (i + 1 >= argc) throw Error(a + ": give a value");
      return std::string(argv[++i]);
    };
    try {
      if (a == "--mesh")
        mesh_file = value();
      else if (a == "--subdivide")
        splits = std::clamp(std::stoi(value()), 0, 4);
      else if (a == "--runs")
        runs = std::clamp(std::stoi(value()), 1, 50);
      else if (a == "--resolution")
        resolution = std::clamp(std::stoi(value()), 4, 256);
      else if (a == "--help" || a == "-h") {
        std::cout << "raywarp_from_mesh_bench [--mesh FILE] [--subdivide K (0-4, 2)] [--runs N "
                     "(3)] [--resolution CELLS (48)]\n";
        return 0;
      } else {
        std::cerr << "raywarp_from_mesh_bench: unknown option " << a << " (--help)\n";
        return 2;
      }
    } catch (const std::exception& e) {
      std::cerr << "raywarp_from_mesh_bench: " << a << ": " << e.what() << "\n";
      return 2;
    }
  }
  try {
    const fs::path dir = fs::temp_directory_path() /
                         ("raywarp_from_mesh_bench_" + std::to_string(std::random_device()()));
    fs::create_directories(dir);
    Mesh mesh = load_mesh(mesh_file);
    for (int k = 0; k < splits; ++k) mesh = subdivide(mesh);
    std::printf("mesh: %s split %d times: %ld vertices, %ld triangles\n", mesh_file.c_str(), splits,
                static_cast<long>(mesh.V.rows()), static_cast<long>(mesh.F.rows()));
    write_binary_ply(dir / "rest.ply", mesh.V, mesh);

    // The box over the upper half, 2 % of the diagonal wider than the mesh across.
    const Eigen::AlignedBox3d bounds = mesh_bounds(mesh);
    const Eigen::Vector3d lo = bounds.min(), hi = bounds.max();
    const double pad = 0.02 * bounds.diagonal().norm();
    const json box_min = {lo.x() - pad, 0.5 * (lo.y() + hi.y()), lo.z() - pad};
    const json box_max = {hi.x() + pad, hi.y() + pad, hi.z() + pad};
    auto scene_doc = [&](const json& deformer) {
      return json{{"mesh", "rest.ply"},
                  {"boxes", {{{"min", box_min}, {"max", box_max}, {"deformer", deformer}}}}};
    };
    const Scene twist_scene = load_scene_json(
        scene_doc({{"type", "twist"}, {"axis", "y"}, {"angle_deg", 90}}), dir / "twist.json");
    const BoxSpec& spec = twist_scene.boxes[0];
    const auto F = make_box_deformer(spec, "boxes[0]");
    Eigen::Matrix<double, -1, 3, 1> moved = mesh.V;
    long inside = 0;
    for (long i = 0; i < moved.rows(); ++i) {
      const Eigen::Vector3d local = spec.box.to_local(mesh.V.row(i).transpose());
      if (((local.cwiseAbs() - spec.box.half_extents).array() > 0.0).any()) continue;
      moved.row(i) = spec.box.to_object(F->forward(local)).transpose();
      ++inside;
    }
    write_binary_ply(dir / "target.ply", moved, mesh);
    std::printf("target: %ld vertices in the box moved by a 90-degree twist; files %.1f MiB each\n",
                inside, mib(static_cast<double>(fs::file_size(dir / "target.ply"))));
    const json doc = scene_doc({{"type", "from_mesh"},
                                {"target", "target.ply"},
                                {"resolution", resolution},
                                {"pins", {"-y"}}});
    std::ofstream(dir / "scene.json") << doc.dump(2);
    const Scene scene = load_scene((dir / "scene.json").string());

    std::vector<double> total, load, pairs_fit, grid, deformation, peak, absolute;
    FromMeshReport last;
    std::string deformation_layout;
    for (int r = 0; r < runs; ++r) {
      BakeSession session(nullptr);
      const long long before = current_rss();
      reset_peak_rss();
      const auto t0 = std::chrono::steady_clock::now();
      MeshPtr m = session.mesh(scene.mesh);
      const auto t1 = std::chrono::steady_clock::now();
      std::ostringstream log;
      const BakedBox baked = bake_logged(session, make_job(scene, 0, m), log, "");
      const auto t2 = std::chrono::steady_clock::now();
      const long long high = peak_rss();
      load.push_back(std::chrono::duration<double>(t1 - t0).count());
      total.push_back(std::chrono::duration<double>(t2 - t0).count());
      const BakeReport& rep = baked.report;
      if (rep.from_mesh) {
        last = *rep.from_mesh;
        pairs_fit.push_back(last.seconds);
      }
      if (const StageReport* s = rep.stage(Stage::DistanceGrid)) grid.push_back(s->seconds);
      if (const StageReport* s = rep.stage(Stage::Deformation)) {
        deformation.push_back(s->seconds);
        std::ostringstream d;
        d << s->resolution.x() << "x" << s->resolution.y() << "x" << s->resolution.z() << ", "
          << mib(static_cast<double>(s->bytes)) << " MiB";
        deformation_layout = d.str();
      }
      peak.push_back(static_cast<double>(high - before));
      absolute.push_back(static_cast<double>(high));
      std::printf("run %d: %.2f s, peak resident memory +%.0f MiB (%.0f MiB before)\n", r + 1,
                  total.back(), mib(peak.back()), mib(static_cast<double>(before)));
      std::fflush(stdout);
    }
    // The same bake again through a disk cache: stored once, then read (the fit, the distance
    // grid and the textures; the mesh is read again).
    double cached = 0.0;
    {
      BakeCache cache(dir / "cache");
      for (int pass = 0; pass < 2; ++pass) {
        BakeSession session(&cache);
        const auto t0 = std::chrono::steady_clock::now();
        std::ostringstream log;
        bake_logged(session, make_job(scene, 0, session.mesh(scene.mesh)), log, "");
        cached = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      }
    }
    std::printf(
        "\nfrom_mesh bake, %ld vertices (%ld pairs in the box), resolution %d, median of %d runs:\n"
        "  mesh read and prepared        %.2f s\n"
        "  target read and fitted        %.2f s  (fit |F(s) - t| max %.3g, rms %.3g units)\n"
        "  distance grid                 %.2f s\n"
        "  deformation texture           %.2f s  (%s)\n"
        "  whole bake                    %.2f s\n"
        "  whole bake from a disk cache  %.2f s\n"
        "  peak resident memory          +%.0f MiB over the process before the bake; the "
        "process's peak %.0f MiB (budget %.0f MiB)\n",
        static_cast<long>(mesh.V.rows()), last.pairs, resolution, runs, median(load),
        median(pairs_fit), last.fit_max_error, last.fit_rms_error, median(grid),
        median(deformation), deformation_layout.c_str(), median(total), cached, mib(median(peak)),
        mib(*std::max_element(absolute.begin(), absolute.end())),
        mib(static_cast<double>(kMemoryBudgetBytes)));
    fs::remove_all(dir);
  } catch (const Error& e) {
    std::cerr << "raywarp_from_mesh_bench: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
