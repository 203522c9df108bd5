// The signed distance grid of a mesh over a box (see implicit.h): the narrow band from OpenVDB,
// its distances measured exactly, the sign from the generalised winding number. The only file
// that includes OpenVDB: its headers take ~30 s to compile.
#include "library/implicit.h"

#include <openvdb/openvdb.h>
#include <openvdb/tools/MeshToVolume.h>

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

#include "base/error.h"
#include "base/parallel.h"
#include "library/depth_cube.h"
#include "library/sheets.h"
#include "library/thickness.h"
#include "library/triangle_bvh.h"
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
  // Texel indices are 32-bit (the queues of the band growth and the sign flood fill).
  if (shape.texels() >= double(std::numeric_limits<uint32_t>::max())) {
    throw Error("implicit.resolution = " + std::to_string(spec.resolution) + ": " +
                format_number(shape.texels()) + " texels, allowed < 2^32");
  }
}

// Share of the "distance" stage spent in OpenVDB; the exact pass takes the rest.
constexpr double kVdbShare = 0.7;

// OpenVDB's interrupter interface over raywarp's: the voxelizer polls wasInterrupted() from
// worker threads, with a percentage from the main thread.
class VdbInterrupter {
 public:
  explicit VdbInterrupter(Interrupter* interrupter) : interrupter_(interrupter) {}
  void start(const char* = nullptr) {}
  void end() {}
  bool wasInterrupted(int percent = -1) {
    if (!interrupter_) return false;
    try {
      if (percent >= 0)
        interrupter_->poll("distance", kVdbShare * std::clamp(percent, 0, 100) / 100.0);
      else
        interrupter_->poll();
    } catch (const Cancelled&) {
      return true;
    }
    return false;
  }

 private:
  Interrupter* interrupter_;
};

// Texels per index of the parallel loops: enough work to pay for a poll, far under 50 ms.
constexpr size_t kChunk = 1024;
long chunks(size_t n) { return static_cast<long>((n + kChunk - 1) / kChunk); }

// The triangles that can be within the band of a texel (their bounds overlap the grid grown by
// the band and a voxel), in the box's local frame.
struct NearTriangles {
  std::vector<openvdb::Vec3s> points;  // every mesh vertex, single precision, for OpenVDB
  std::vector<openvdb::Vec3I> indices;
  std::vector<Triangle3d> corners;  // double precision, for the exact distances
};

NearTriangles triangles_near(const Mesh& mesh, const Box& box, const Eigen::AlignedBox3d& region) {
  NearTriangles near;
  std::vector<Eigen::Vector3d> local(static_cast<size_t>(mesh.V.rows()));
  near.points.resize(local.size());
  for (size_t v = 0; v < local.size(); ++v) {
    local[v] = box.to_local(mesh.V.row(static_cast<Eigen::Index>(v)).transpose());
    near.points[v] = openvdb::Vec3s(float(local[v].x()), float(local[v].y()), float(local[v].z()));
  }
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    Eigen::AlignedBox3d bounds;
    for (int c = 0; c < 3; ++c) bounds.extend(local[mesh.F(f, c)]);
    if (!bounds.intersects(region)) continue;
    near.indices.emplace_back(mesh.F(f, 0), mesh.F(f, 1), mesh.F(f, 2));
    near.corners.push_back({local[mesh.F(f, 0)], local[mesh.F(f, 1)], local[mesh.F(f, 2)]});
  }
  return near;
}

enum TexelState : uint8_t { kUnvisited = 0, kQueued, kBeyond, kBand };

// Centre of texel `t` (Grid3's storage index, x fastest).
Eigen::Vector3d centre_of(const Grid3<float>& grid, uint32_t t) {
  const uint32_t nx = grid.dims.x(), ny = grid.dims.y();
  return grid.texel_centre(int(t % nx), int(t / nx % ny), int(t / nx / ny));
}

// Calls fn(u) for the storage index u of each of the 6 face neighbours of texel t in the grid.
template <class Fn>
void for_each_face_neighbour(const Grid3<float>& grid, uint32_t t, Fn fn) {
  const uint32_t nx = grid.dims.x(), ny = grid.dims.y(), nz = grid.dims.z();
  const uint32_t i = t % nx, j = t / nx % ny, k = t / nx / ny;
  if (i > 0) fn(t - 1);
  if (i + 1 < nx) fn(t + 1);
  if (j > 0) fn(t - nx);
  if (j + 1 < ny) fn(t + nx);
  if (k > 0) fn(t - nx * ny);
  if (k + 1 < nz) fn(t + nx * ny);
}

// Unsigned distances: band texels (nearer than `background` to a triangle) get their exact
// distance, the others `background`. OpenVDB's narrow band says which texels to look at, but
// only its values under 1.5 voxels are exact: its voxelizer measures each triangle exactly at
// the voxels within Chebyshev distance 1.5 of it (the 26-neighbours of the voxels it crosses),
// while its band expansion beyond measures to a triangle near the nearest one, up to ~0.9 voxel
// too far (OpenVDB 10), and drops texels that this pushes past the band. So its values from
// 1.5 voxels on are measured again exactly (they bound the search), and the band grows from
// there through 6-neighbours while they are nearer than `background`. That finds every band
// texel: from a texel, a step along the largest component towards its nearest surface point
// does not increase the distance, down to the texels at the surface, which OpenVDB has.
void unsigned_distances(const Mesh& mesh, const Box& box, const ImplicitSpec& spec,
                        Interrupter* interrupter, Grid3<float>& grid, std::vector<uint8_t>& state,
                        float background) {
  std::fill(grid.data.begin(), grid.data.end(), background);
  state.assign(grid.size(), kUnvisited);
  const double reach = (spec.band_voxels + 1.0) * grid.voxel();
  const Eigen::AlignedBox3d region(grid.origin - Eigen::Vector3d::Constant(reach),
                                   grid.upper() + Eigen::Vector3d::Constant(reach));
  NearTriangles near = triangles_near(mesh, box, region);
  if (near.indices.empty()) return;

  openvdb::initialize();
  // Index space: VDB voxel (i, j, k) sits at translation + (i, j, k) * spacing, our texel
  // centre at origin + (i + 0.5, j + 0.5, k + 0.5) * spacing, so the same (i, j, k) is the same
  // point.
  openvdb::math::Transform::Ptr transform =
      openvdb::math::Transform::createLinearTransform(grid.voxel());
  const Eigen::Vector3d first_centre = grid.texel_centre(0, 0, 0);
  transform->postTranslate(openvdb::Vec3d(first_centre.x(), first_centre.y(), first_centre.z()));
  VdbInterrupter vdb_interrupter(interrupter);
  const std::vector<openvdb::Vec4I> no_quads;
  openvdb::FloatGrid::Ptr vdb = openvdb::tools::meshToUnsignedDistanceField<openvdb::FloatGrid>(
      vdb_interrupter, *transform, near.points, near.indices, no_quads, float(spec.band_voxels));
  raywarp::poll(interrupter);  // OpenVDB returns early when cancelled

  // OpenVDB's value is the distance to some triangle, in single precision from single-precision
  // points: padded by rounding (~1e-7 of coordinates ~resolution voxels), it bounds the search.
  const float exact_below = float(1.5 * grid.voxel());
  std::vector<uint32_t> wave, next;
  // Queues the unvisited face neighbours of band texel t.
  auto grow = [&](uint32_t t) {
    for_each_face_neighbour(grid, t, [&](uint32_t u) {
      if (state[u] == kUnvisited) {
        state[u] = kQueued;
        next.push_back(u);
      }
    });
  };
  for (auto it = vdb->cbeginValueOn(); it; ++it) {
    const openvdb::Coord ijk = it.getCoord();
    if (!it.isVoxelValue() || ijk.x() < 0 || ijk.y() < 0 || ijk.z() < 0 ||
        ijk.x() >= grid.dims.x() || ijk.y() >= grid.dims.y() || ijk.z() >= grid.dims.z()) {
      continue;  // a band of a few voxels has no active tiles; texels outside the grid
    }
    const size_t t = grid.index(ijk.x(), ijk.y(), ijk.z());
    const float value = std::abs(*it);
    if (value < exact_below) {
      grid.data[t] = value;
      state[t] = kBand;
      continue;
    }
    state[t] = kQueued;
    grid.data[t] = std::min(background, float(value * (1.0 + 1e-5) + 1e-3 * grid.voxel()));
    wave.push_back(static_cast<uint32_t>(t));
  }
  // The growth starts from every band texel, also the exact ones.
  for (size_t t = 0; t < state.size(); ++t) {
    if (state[t] == kBand) grow(static_cast<uint32_t>(t));
  }
  near.points.clear();
  near.indices.clear();

  wave.insert(wave.end(), next.begin(), next.end());
  next.clear();

  // The exact distances, searched only within the bound (a narrow band needs no farther one).
  const TriangleBvh tree(std::move(near.corners));
  std::vector<float> distance;
  size_t measured = 0;
  const size_t expected = wave.size();  // for progress; the growth adds a little
  while (!wave.empty()) {
    raywarp::poll(
        interrupter, "distance",
        kVdbShare + (1.0 - kVdbShare) * std::min(1.0, double(measured) / double(expected)));
    distance.resize(wave.size());
    parallel_for(
        chunks(wave.size()),
        [&](long chunk) {
          for (size_t n = chunk * kChunk; n < std::min(wave.size(), (chunk + 1) * kChunk); ++n) {
            const uint32_t t = wave[n];
            const Eigen::Vector3d q = centre_of(grid, t);
            distance[n] = float(tree.nearest_distance(q, grid.data[t]));
          }
        },
        interrupter, "distance");
    measured += wave.size();
    for (size_t n = 0; n < wave.size(); ++n) {
      const uint32_t t = wave[n];
      if (distance[n] < background) {
        state[t] = kBand;
        grid.data[t] = distance[n];
        grow(t);
      } else {
        state[t] = kBeyond;
        grid.data[t] = background;
      }
    }
    wave.swap(next);
    next.clear();
  }
}

// Inside (+1) or outside (-1) of every band texel, w > 1/2 being inside.
void sign_band(const WindingNumber& winding, const Box& box, const Grid3<float>& grid,
               const std::vector<uint8_t>& state, Interrupter* interrupter,
               std::vector<int8_t>& sign) {
  std::vector<uint32_t> texels;
  for (size_t t = 0; t < state.size(); ++t) {
    if (state[t] == kBand) texels.push_back(static_cast<uint32_t>(t));
  }
  parallel_for(
      chunks(texels.size()),
      [&](long chunk) {
        for (size_t n = chunk * kChunk; n < std::min(texels.size(), (chunk + 1) * kChunk); ++n) {
          const uint32_t t = texels[n];
          sign[t] = winding(box.to_object(centre_of(grid, t))) > 0.5 ? 1 : -1;
        }
      },
      interrupter, "sign");
}

// Propagates the sign from the band through the 6-connected texels beyond it (breadth first,
// so each takes the sign of its nearest band texel in steps); a region the band does not reach
// takes the winding number at one of its texels.
void sign_beyond_band(const WindingNumber& winding, const Box& box, const Grid3<float>& grid,
                      std::vector<int8_t>& sign, Interrupter* interrupter) {
  std::vector<uint32_t> queue;
  queue.reserve(grid.size());
  for (size_t t = 0; t < sign.size(); ++t) {
    if (sign[t] != 0) queue.push_back(static_cast<uint32_t>(t));
  }
  auto flood = [&](size_t head) {
    for (; head < queue.size(); ++head) {
      if (head % (kChunk * 64) == 0) raywarp::poll(interrupter);
      const uint32_t t = queue[head];
      for_each_face_neighbour(grid, t, [&](uint32_t u) {
        if (sign[u] == 0) {
          sign[u] = sign[t];
          queue.push_back(u);
        }
      });
    }
  };
  flood(0);
  for (size_t t = 0; t < sign.size(); ++t) {
    if (sign[t] != 0) continue;
    raywarp::poll(interrupter);
    sign[t] = winding(box.to_object(centre_of(grid, uint32_t(t)))) > 0.5 ? 1 : -1;
    const size_t head = queue.size();
    queue.push_back(static_cast<uint32_t>(t));
    flood(head);
  }
}

}  // namespace

std::uint64_t distance_grid_bytes(const Box& box, const ImplicitSpec& spec) {
  return static_cast<std::uint64_t>(grid_shape(box, spec).texels()) * sizeof(float);
}

namespace {

constexpr int kMaxResolution = 1024, kStep = 8;

std::uint64_t budget_bytes(const ImplicitSpec& spec) {
  return static_cast<std::uint64_t>(spec.max_mib * double(1 << 20));
}

// `resolution`, lowered in steps of kStep until the implicit of `spec` over `box` fits its
// max_mib.
int within_budget(const Box& box, const ImplicitSpec& spec, int resolution) {
  ImplicitSpec s = spec;
  auto bytes = [&](int r) {
    s.resolution = r;
    return spec.type == "depth_cube" ? depth_cube_bytes(box.half_extents, r)
                                     : distance_grid_bytes(box, s);
  };
  while (resolution > kStep && bytes(resolution) > budget_bytes(spec)) resolution -= kStep;
  return resolution;
}

}  // namespace

ImplicitChoice choose_implicit_resolution(const Mesh& mesh, const Box& box,
                                          const ImplicitSpec& spec, Interrupter* interrupter) {
  ImplicitChoice c;
  c.resolution = spec.resolution;
  if (spec.resolution != kAutoResolution) return c;
  c.automatic = true;
  const ThicknessProbe probe = probe_thickness(mesh, box, 2048, interrupter);
  c.samples = probe.samples;
  c.hits = probe.hits;
  c.limbs = probe.limbs;
  c.feature = probe.quantile(kFeatureQuantile);
  const double longest = 2.0 * box.half_extents.maxCoeff();
  c.wanted = kAutoImplicitFloorResolution;
  if (c.feature > 0.0) {
    const double voxels = std::ceil(kFeatureVoxels * longest / c.feature / kStep) * kStep;
    c.wanted =
        int(std::clamp(voxels, double(kAutoImplicitFloorResolution), double(kMaxResolution)));
  }
  c.budget_bytes = budget_bytes(spec);
  c.resolution = within_budget(box, spec, c.wanted);
  c.budget_bound = c.resolution < c.wanted;
  return c;
}

int sheet_resolution(const Box& box, const ImplicitSpec& spec) {
  return within_budget(box, spec, kSheetAutoResolution);
}

DistanceGrid bake_distance_grid(const Mesh& mesh, const Box& box, const ImplicitSpec& spec,
                                size_t memory_budget_bytes, Interrupter* interrupter) {
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

  raywarp::poll(interrupter, "distance", 0.0);
  std::vector<uint8_t> state;
  unsigned_distances(mesh, box, spec, interrupter, grid, state, result.background);
  raywarp::poll(interrupter, "distance", 1.0);

  // The whole mesh decides inside, also its parts beyond the box: a hole or a cut there must
  // not turn the inside out. Queries go to object space, where the mesh is.
  const WindingNumber winding(mesh);
  std::vector<int8_t> sign(grid.size(), 0);
  sign_band(winding, box, grid, state, interrupter, sign);
  sign_beyond_band(winding, box, grid, sign, interrupter);
  raywarp::poll(interrupter, "sign", 1.0);

  long active = 0;
  for (size_t t = 0; t < grid.size(); ++t) {
    grid.data[t] *= float(sign[t]);  // raywarp's sign: f > 0 inside
    active += state[t] == kBand;
    if (!std::isfinite(grid.data[t])) {
      throw std::logic_error("bake_distance_grid: texel " + std::to_string(t) + " is not finite");
    }
  }
  result.active_voxels = active;

  // Faces the winding number leaves outside on both sides (sheets, cards, fins, closed parts
  // thinner than a voxel) have no surface in the signed field: each becomes a thin shell.
  const double voxel = grid.voxel();
  const std::vector<int> sheets =
      sheet_faces(mesh, winding, box, grid, 0.5 * voxel, interrupter, &result.sheet_area_share);
  result.sheet_faces = static_cast<long>(sheets.size());
  result.sheet_half_thickness = sheets.empty() ? 0.0 : kSheetHalfVoxels * voxel;
  add_sheet_shells(mesh, sheets, box, result.sheet_half_thickness, grid, interrupter);
  result.bake_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace raywarp
