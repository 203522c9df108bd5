// The signed distance grid of a mesh over a box (see implicit.h): unsigned narrow-band distances
// from OpenVDB, the sign from the generalised winding number. The only file that includes
// OpenVDB: its headers take ~30 s to compile.
#include "library/implicit.h"

#include <openvdb/openvdb.h>
#include <openvdb/tools/MeshToVolume.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "library/error.h"
#include "library/winding.h"

namespace raywarp {
namespace {

constexpr double kMiB = 1024.0 * 1024.0;

std::string format_number(double x) {
  std::ostringstream s;
  s.precision(6);
  s << x;
  return s.str();
}

void check_spec(const ImplicitSpec& spec) {
  if (spec.resolution < 1) {
    throw Error("implicit.resolution = " + std::to_string(spec.resolution) + ": must be >= 1");
  }
  if (!(spec.band_voxels >= 1.0) || !std::isfinite(spec.band_voxels)) {
    throw Error("implicit.band_voxels = " + format_number(spec.band_voxels) +
                ": must be finite and >= 1 (the sign flood fill needs one voxel of band)");
  }
  if (!(spec.margin_voxels >= 0.0) || !std::isfinite(spec.margin_voxels)) {
    throw Error("implicit.margin_voxels = " + format_number(spec.margin_voxels) +
                ": must be finite and >= 0");
  }
}

// Cubic texels of side 2 max(half_extents) / resolution, so that the box's longest side spans
// `resolution` texels, over the box grown by the margin on every side, centred on the box
// (the local origin) and rounded up to whole texels as make_grid_over does. Only the shape:
// the caller checks the memory before allocating.
struct GridShape {
  Eigen::Vector3d origin;
  double spacing;
  Eigen::Vector3i dims;
  double texels() const { return double(dims.x()) * dims.y() * dims.z(); }
};

GridShape grid_shape(const Box& box, const ImplicitSpec& spec) {
  GridShape shape;
  shape.spacing = 2.0 * box.half_extents.maxCoeff() / spec.resolution;
  const Eigen::Vector3d extent =
      2.0 * (box.half_extents.array() + spec.margin_voxels * shape.spacing).matrix();
  for (int a = 0; a < 3; ++a) {
    shape.dims[a] = std::max(1, static_cast<int>(std::ceil(extent[a] / shape.spacing - 1e-9)));
  }
  shape.origin = -0.5 * shape.spacing * shape.dims.cast<double>();
  return shape;
}

void check_memory(const GridShape& shape, const ImplicitSpec& spec, size_t budget_bytes) {
  const double bytes = shape.texels() * sizeof(float);
  if (bytes > double(budget_bytes)) {
    throw Error("implicit.resolution = " + std::to_string(spec.resolution) +
                ": the distance grid would take " + format_number(bytes / kMiB) + " MiB (" +
                std::to_string(shape.dims.x()) + " x " + std::to_string(shape.dims.y()) + " x " +
                std::to_string(shape.dims.z()) + " texels), over the budget of " +
                format_number(double(budget_bytes) / kMiB) + " MiB");
  }
  // The sign flood fill indexes texels with 32 bits.
  if (shape.texels() >= double(std::numeric_limits<uint32_t>::max())) {
    throw Error("implicit.resolution = " + std::to_string(spec.resolution) + ": " +
                format_number(shape.texels()) + " texels, allowed < 2^32");
  }
}

// OpenVDB's interrupter interface, forwarding the main thread's percentages to `progress` as
// stage "distance". The voxelizer polls wasInterrupted() (no percentage) from worker threads:
// those calls only read the flag, so `progress` is called from one thread at a time.
class DistanceInterrupter {
 public:
  explicit DistanceInterrupter(const Progress& progress) : progress_(progress) {}
  void start(const char* = nullptr) {}
  void end() {}
  bool wasInterrupted(int percent = -1) {
    if (percent >= 0 && progress_ && !cancelled_.load()) {
      if (!progress_("distance", std::clamp(percent, 0, 100) / 100.0)) cancelled_ = true;
    }
    return cancelled_.load();
  }
  bool cancelled() const { return cancelled_.load(); }

 private:
  const Progress& progress_;
  std::atomic<bool> cancelled_{false};
};

void report(const Progress& progress, const char* stage, double fraction) {
  if (progress && !progress(stage, fraction)) throw Error("distance grid bake cancelled");
}

// Mesh vertices in the box's local frame, as OpenVDB's single-precision world-space points.
std::vector<openvdb::Vec3s> local_points(const Mesh& mesh, const Box& box) {
  std::vector<openvdb::Vec3s> points(static_cast<size_t>(mesh.V.rows()));
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v) {
    const Eigen::Vector3d q = box.to_local(mesh.V.row(v).transpose());
    points[v] = openvdb::Vec3s(float(q.x()), float(q.y()), float(q.z()));
  }
  return points;
}

// Triangles whose bounds overlap `region`: only those can be within the band of a texel.
std::vector<openvdb::Vec3I> triangles_near(const Mesh& mesh,
                                           const std::vector<openvdb::Vec3s>& points,
                                           const Eigen::AlignedBox3d& region) {
  std::vector<openvdb::Vec3I> triangles;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    Eigen::AlignedBox3d bounds;
    for (int c = 0; c < 3; ++c) {
      const openvdb::Vec3s& p = points[mesh.F(f, c)];
      bounds.extend(Eigen::Vector3d(p.x(), p.y(), p.z()));
    }
    if (bounds.intersects(region)) {
      triangles.emplace_back(mesh.F(f, 0), mesh.F(f, 1), mesh.F(f, 2));
    }
  }
  return triangles;
}

// Unsigned narrow-band distances read back at every texel; `band` marks the texels OpenVDB
// computed (its active voxels), the rest read `background`.
void unsigned_distances(const Mesh& mesh, const Box& box, const ImplicitSpec& spec,
                        const Progress& progress, Grid3<float>& grid, std::vector<uint8_t>& band,
                        float background) {
  std::fill(grid.data.begin(), grid.data.end(), background);
  band.assign(grid.size(), 0);
  const std::vector<openvdb::Vec3s> points = local_points(mesh, box);
  const double reach = (spec.band_voxels + 1.0) * grid.spacing;
  const Eigen::AlignedBox3d region(grid.origin - Eigen::Vector3d::Constant(reach),
                                   grid.upper() + Eigen::Vector3d::Constant(reach));
  const std::vector<openvdb::Vec3I> triangles = triangles_near(mesh, points, region);
  if (triangles.empty()) return;

  openvdb::initialize();
  // Index space: VDB voxel (i, j, k) sits at translation + (i, j, k) * spacing, our texel
  // centre at origin + (i + 0.5, j + 0.5, k + 0.5) * spacing, so the same (i, j, k) is the same
  // point.
  openvdb::math::Transform::Ptr transform =
      openvdb::math::Transform::createLinearTransform(grid.spacing);
  const Eigen::Vector3d first_centre = grid.texel_centre(0, 0, 0);
  transform->postTranslate(openvdb::Vec3d(first_centre.x(), first_centre.y(), first_centre.z()));

  DistanceInterrupter interrupter(progress);
  const std::vector<openvdb::Vec4I> no_quads;
  openvdb::FloatGrid::Ptr vdb = openvdb::tools::meshToUnsignedDistanceField<openvdb::FloatGrid>(
      interrupter, *transform, points, triangles, no_quads, float(spec.band_voxels));
  if (interrupter.cancelled()) throw Error("distance grid bake cancelled");

  for (auto it = vdb->cbeginValueOn(); it; ++it) {
    if (!it.isVoxelValue()) continue;  // a band of a few voxels has no active tiles
    const openvdb::Coord ijk = it.getCoord();
    if (ijk.x() < 0 || ijk.y() < 0 || ijk.z() < 0 || ijk.x() >= grid.dims.x() ||
        ijk.y() >= grid.dims.y() || ijk.z() >= grid.dims.z()) {
      continue;
    }
    const size_t index = grid.index(ijk.x(), ijk.y(), ijk.z());
    grid.data[index] = std::min(std::abs(*it), background);
    band[index] = 1;
  }
}

// Inside (+1) or outside (-1) of every band texel, w > 1/2 being inside.
void sign_band(const WindingNumber& winding, const Box& box, const Grid3<float>& grid,
               const std::vector<uint8_t>& band, const Progress& progress,
               std::vector<int8_t>& sign) {
  std::vector<uint32_t> texels;
  for (size_t t = 0; t < band.size(); ++t) {
    if (band[t]) texels.push_back(static_cast<uint32_t>(t));
  }
  const int nx = grid.dims.x(), ny = grid.dims.y();
  // Batches between progress reports; each batch runs in parallel.
  const size_t batch = std::max<size_t>(1 << 16, texels.size() / 50);
  for (size_t begin = 0; begin < texels.size(); begin += batch) {
    report(progress, "sign", double(begin) / double(texels.size()));
    const size_t end = std::min(texels.size(), begin + batch);
    tbb::parallel_for(tbb::blocked_range<size_t>(begin, end), [&](const auto& range) {
      for (size_t n = range.begin(); n != range.end(); ++n) {
        const uint32_t t = texels[n];
        const int i = int(t % nx), j = int((t / nx) % ny), k = int(t / (size_t(nx) * ny));
        sign[t] = winding(box.to_object(grid.texel_centre(i, j, k))) > 0.5 ? 1 : -1;
      }
    });
  }
}

// Propagates the sign from the band through the 6-connected texels beyond it (breadth first,
// so each takes the sign of its nearest band texel in steps); a region the band does not reach
// takes the winding number at one of its texels.
void sign_beyond_band(const WindingNumber& winding, const Box& box, const Grid3<float>& grid,
                      std::vector<int8_t>& sign) {
  const int nx = grid.dims.x(), ny = grid.dims.y(), nz = grid.dims.z();
  std::vector<uint32_t> queue;
  queue.reserve(grid.size());
  for (size_t t = 0; t < sign.size(); ++t) {
    if (sign[t] != 0) queue.push_back(static_cast<uint32_t>(t));
  }
  auto flood = [&](size_t head) {
    for (; head < queue.size(); ++head) {
      const uint32_t t = queue[head];
      const int i = int(t % nx), j = int((t / nx) % ny), k = int(t / (size_t(nx) * ny));
      const int neighbours[6][3] = {{i - 1, j, k}, {i + 1, j, k}, {i, j - 1, k},
                                    {i, j + 1, k}, {i, j, k - 1}, {i, j, k + 1}};
      for (const auto& n : neighbours) {
        if (n[0] < 0 || n[1] < 0 || n[2] < 0 || n[0] >= nx || n[1] >= ny || n[2] >= nz) continue;
        const size_t u = grid.index(n[0], n[1], n[2]);
        if (sign[u] == 0) {
          sign[u] = sign[t];
          queue.push_back(static_cast<uint32_t>(u));
        }
      }
    }
  };
  flood(0);
  for (size_t t = 0; t < sign.size(); ++t) {
    if (sign[t] != 0) continue;
    const int i = int(t % nx), j = int((t / nx) % ny), k = int(t / (size_t(nx) * ny));
    sign[t] = winding(box.to_object(grid.texel_centre(i, j, k))) > 0.5 ? 1 : -1;
    const size_t head = queue.size();
    queue.push_back(static_cast<uint32_t>(t));
    flood(head);
  }
}

}  // namespace

DistanceGrid bake_distance_grid(const Mesh& mesh, const Box& box, const ImplicitSpec& spec,
                                size_t memory_budget_bytes, const Progress& progress) {
  const auto start = std::chrono::steady_clock::now();
  check_spec(spec);
  const GridShape shape = grid_shape(box, spec);
  check_memory(shape, spec, memory_budget_bytes);

  DistanceGrid result;
  result.grid = Grid3<float>(shape.origin, shape.spacing, shape.dims);
  result.band_voxels = spec.band_voxels;
  // OpenVDB's background for a band of half width w voxels of side s is w * s.
  result.background = float(spec.band_voxels * shape.spacing);
  result.sign_method = "generalised winding number (Barill et al. 2018)";
  Grid3<float>& grid = result.grid;

  report(progress, "distance", 0.0);
  std::vector<uint8_t> band;
  unsigned_distances(mesh, box, spec, progress, grid, band, result.background);
  report(progress, "distance", 1.0);

  // The whole mesh decides inside, also its parts beyond the box: a hole or a cut there must
  // not turn the inside out. Queries go to object space, where the mesh is.
  const WindingNumber winding(mesh);
  std::vector<int8_t> sign(grid.size(), 0);
  sign_band(winding, box, grid, band, progress, sign);
  sign_beyond_band(winding, box, grid, sign);
  report(progress, "sign", 1.0);

  long active = 0;
  for (size_t t = 0; t < grid.size(); ++t) {
    grid.data[t] *= float(sign[t]);  // raywarp's sign: f > 0 inside
    active += band[t];
    if (!std::isfinite(grid.data[t])) {
      throw std::logic_error("bake_distance_grid: texel " + std::to_string(t) + " is not finite");
    }
  }
  result.active_voxels = active;
  result.bake_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace raywarp
