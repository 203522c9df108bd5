// The depth-map cube (see depth_cube.h): baked by rasterising the mesh's triangles into the
// texel grid of each axis on the CPU.
#include "library/depth_cube.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

#include "base/error.h"
#include "base/parallel.h"
#include "library/winding.h"

namespace raywarp {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// The other two axes of `axis`, increasing.
void face_axes(int axis, int& u, int& v) {
  u = axis == 0 ? 1 : 0;
  v = axis == 2 ? 1 : 2;
}

// Per texel of an axis's grid: the nearest hit inside the box seen from each of the axis's two
// faces, whether it faces that face (the ray enters the mesh there), and the signed crossings
// before each face (+1 entering, -1 leaving, counted along that face's inward direction).
struct AxisHits {
  std::vector<float> near_lo, near_hi;  // depth from the -axis / +axis face; infinity: none
  std::vector<char> enters_lo, enters_hi;
  std::vector<int> winding_lo, winding_hi;
  explicit AxisHits(size_t texels)
      : near_lo(texels, std::numeric_limits<float>::infinity()),
        near_hi(texels, std::numeric_limits<float>::infinity()),
        enters_lo(texels, 0),
        enters_hi(texels, 0),
        winding_lo(texels, 0),
        winding_hi(texels, 0) {}
};

// 2D edge function of the edge a -> b at p: > 0 left of the edge. Evaluated with the endpoints
// in a fixed (lexicographic) order and negated for the other direction, so that the two triangles
// sharing an edge get exactly opposite values at every point and no ray slips between them.
double edge_function(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& p) {
  const bool swap = b.x() < a.x() || (b.x() == a.x() && b.y() < a.y());
  const Eigen::Vector2d& s = swap ? b : a;
  const Eigen::Vector2d& e = swap ? a : b;
  const double w = (e.x() - s.x()) * (p.y() - s.y()) - (e.y() - s.y()) * (p.x() - s.x());
  return swap ? -w : w;
}

// Top-left rule for a counter-clockwise triangle (v up): a point on the edge a -> b counts when
// the edge is a left edge (going down) or a top edge (horizontal, going left).
bool owns_edge(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d d = b - a;
  return d.y() < 0.0 || (d.y() == 0.0 && d.x() < 0.0);
}

// Triangle f of the mesh (vertices in the box's local frame) projected onto the texel grid of
// `axis` (texel centres origin + (i + 0.5) spacing along the face's u and v), counter-clockwise
// in (u, v), with the texel centres within its bounds: columns [i0, i1], rows [j0, j1].
struct Projection {
  const Eigen::Vector3d* q[3];
  Eigen::Vector2d p[3];
  bool normal_up = false;  // the normal along +axis: a ray along +axis (from the -axis face) leaves
  int i0 = 0, i1 = -1, j0 = 0, j1 = -1;
};

// False when the triangle is edge-on or covers no texel centre's bounds.
bool project(const std::vector<Eigen::Vector3d>& local, const Mesh& mesh, Eigen::Index f, int axis,
             const DepthMap& grid, Projection& pr) {
  const int ua = grid.u_axis, va = grid.v_axis;
  const double s = grid.spacing;
  // The 3D normal's component along `axis` has the sign of the projected signed area (u, v) for
  // axes x and z, and the opposite sign for y ((x, z) is a left-handed pair about y).
  const double handedness = axis == 1 ? -1.0 : 1.0;
  const Eigen::Vector3d** q = pr.q;
  Eigen::Vector2d* p = pr.p;
  for (int c = 0; c < 3; ++c) q[c] = &local[mesh.F(f, c)];
  for (int c = 0; c < 3; ++c) p[c] = Eigen::Vector2d((*q[c])[ua], (*q[c])[va]);
  double area = edge_function(p[0], p[1], p[2]);
  if (area == 0.0 || !std::isfinite(area)) return false;  // edge-on: the rays graze it
  pr.normal_up = handedness * area > 0.0;
  if (area < 0.0) {  // counter-clockwise in (u, v)
    std::swap(p[1], p[2]);
    std::swap(q[1], q[2]);
  }
  const double umin = std::min({p[0].x(), p[1].x(), p[2].x()});
  const double umax = std::max({p[0].x(), p[1].x(), p[2].x()});
  const double vmin = std::min({p[0].y(), p[1].y(), p[2].y()});
  const double vmax = std::max({p[0].y(), p[1].y(), p[2].y()});
  // The texel centres within the triangle's bounds, clamped to the grid in double (a far
  // triangle's index would not fit an int).
  auto first = [&](double lo, double origin, int n) {
    return static_cast<int>(std::clamp(std::ceil((lo - origin) / s - 0.5), 0.0, double(n)));
  };
  auto last = [&](double hi, double origin, int n) {
    return static_cast<int>(std::clamp(std::floor((hi - origin) / s - 0.5), -1.0, n - 1.0));
  };
  pr.i0 = first(umin, grid.origin.x(), grid.nu);
  pr.i1 = last(umax, grid.origin.x(), grid.nu);
  pr.j0 = first(vmin, grid.origin.y(), grid.nv);
  pr.j1 = last(vmax, grid.origin.y(), grid.nv);
  return pr.i0 <= pr.i1 && pr.j0 <= pr.j1;
}

// Rasterises the triangles faces[0, count) of the mesh, in that order, into rows [row0, row1] of
// the texel grid of `axis`; `hits` holds those rows (texel (i, j) at (j - row0) nu + i).
void rasterise_rows(const std::vector<Eigen::Vector3d>& local, const Mesh& mesh, int axis,
                    const Eigen::Vector3d& h, const DepthMap& grid, const int* faces, size_t count,
                    int row0, int row1, AxisHits& hits) {
  const double s = grid.spacing;
  for (size_t n = 0; n < count; ++n) {
    Projection pr;
    if (!project(local, mesh, faces[n], axis, grid, pr)) continue;
    const Eigen::Vector3d* const* q = pr.q;
    const Eigen::Vector2d* p = pr.p;
    const bool normal_up = pr.normal_up;
    const int j0 = std::max(pr.j0, row0), j1 = std::min(pr.j1, row1);
    const bool own[3] = {owns_edge(p[1], p[2]), owns_edge(p[2], p[0]), owns_edge(p[0], p[1])};
    for (int j = j0; j <= j1; ++j)
      for (int i = pr.i0; i <= pr.i1; ++i) {
        const Eigen::Vector2d c(grid.origin.x() + (i + 0.5) * s, grid.origin.y() + (j + 0.5) * s);
        // w[k]: the edge opposite vertex k, i.e. vertex k's barycentric weight times the area.
        const double w[3] = {edge_function(p[1], p[2], c), edge_function(p[2], p[0], c),
                             edge_function(p[0], p[1], c)};
        bool inside = true;
        for (int k = 0; k < 3; ++k) inside = inside && (w[k] > 0.0 || (w[k] == 0.0 && own[k]));
        if (!inside) continue;
        const double x = (w[0] * (*q[0])[axis] + w[1] * (*q[1])[axis] + w[2] * (*q[2])[axis]) /
                         (w[0] + w[1] + w[2]);
        const size_t t = static_cast<size_t>(j - row0) * grid.nu + i;
        const float depth_lo = static_cast<float>(x + h[axis]),
                    depth_hi = static_cast<float>(h[axis] - x);
        // From the -axis face the ray runs along +axis: it enters where the normal points down.
        if (depth_lo < 0.0f) {
          hits.winding_lo[t] += normal_up ? -1 : 1;
        } else if (depth_hi < 0.0f) {
          hits.winding_hi[t] += normal_up ? 1 : -1;
        } else {
          if (depth_lo < hits.near_lo[t]) {
            hits.near_lo[t] = depth_lo;
            hits.enters_lo[t] = !normal_up;
          }
          if (depth_hi < hits.near_hi[t]) {
            hits.near_hi[t] = depth_hi;
            hits.enters_hi[t] = normal_up;
          }
        }
      }
  }
}

// The bake's parallel loops work on bands of texel rows of one axis's grid, with about
// kBandTexels texels and kBandTriangles triangles a band (one index of the loop each), so that
// an index takes well under the 50 ms between polls (base/interrupt.h).
constexpr long kBandTexels = long(1) << 17;
constexpr long kBandTriangles = long(1) << 14;
// Triangles, or texels left for the winding number, per index of the other loops.
constexpr long kChunk = long(1) << 12;
long chunks(long n, long chunk) { return (n + chunk - 1) / chunk; }

// The bands of each axis: rows [b rows, min((b + 1) rows, nv)) for b in [0, count).
struct Bands {
  int rows[3] = {1, 1, 1};
  int count[3] = {1, 1, 1};
  int total() const { return count[0] + count[1] + count[2]; }
  // Band `index` of all axes in order (axis 0's first) as (axis, band of the axis).
  std::pair<int, int> of(int index) const {
    int a = 0;
    while (index >= count[a]) index -= count[a++];
    return {a, index};
  }
};

Bands bands_of(const DepthCube& cube, long triangles) {
  Bands b;
  for (int a = 0; a < 3; ++a) {
    const DepthMap& m = cube.maps[2 * a];
    const long want =
        std::max(chunks(long(m.nu) * m.nv, kBandTexels), chunks(triangles, kBandTriangles));
    const int count = static_cast<int>(std::clamp(want, 1L, long(m.nv)));
    b.rows[a] = (m.nv + count - 1) / count;
    b.count[a] = (m.nv + b.rows[a] - 1) / b.rows[a];
  }
  return b;
}

}  // namespace

double DepthMap::sample(double u, double v) const {
  const double x = std::clamp((u - origin.x()) / spacing - 0.5, 0.0, double(nu - 1));
  const double y = std::clamp((v - origin.y()) / spacing - 0.5, 0.0, double(nv - 1));
  const int i0 = std::min(static_cast<int>(x), nu - 1), j0 = std::min(static_cast<int>(y), nv - 1);
  const int i1 = std::min(i0 + 1, nu - 1), j1 = std::min(j0 + 1, nv - 1);
  const double wx = x - i0, wy = y - j0;
  const double lo = at(i0, j0) * (1.0 - wx) + at(i1, j0) * wx;
  const double hi = at(i0, j1) * (1.0 - wx) + at(i1, j1) * wx;
  return lo * (1.0 - wy) + hi * wy;
}

double DepthMap::distance_from_face(const Eigen::Vector3d& p) const {
  return half_extent - side * p[axis];
}

DepthCube::Layers DepthCube::layers() const {
  Layers l;
  l.width = l.height = 1;
  for (const DepthMap& m : maps)
    l.width = std::max(l.width, m.nu), l.height = std::max(l.height, m.nv);
  return l;
}

std::vector<float> DepthCube::layer_texels() const {
  const Layers l = layers();
  const size_t slice = static_cast<size_t>(l.width) * l.height;
  std::vector<float> texels(slice * Layers::kDepth);
  for (int k = 0; k < Layers::kDepth; ++k) {
    const DepthMap& m = maps[std::min(k, 5)];
    if (m.depth.size() != static_cast<size_t>(m.nu) * m.nv)
      throw Error("depth cube: map " + std::to_string(k) + " holds no " + std::to_string(m.nu) +
                  "x" + std::to_string(m.nv) + " texels");
    for (int j = 0; j < l.height; ++j)
      for (int i = 0; i < l.width; ++i)
        texels[k * slice + static_cast<size_t>(j) * l.width + i] =
            m.at(std::min(i, m.nu - 1), std::min(j, m.nv - 1));
  }
  return texels;
}

void DepthCube::set_depths_from_layers(const std::vector<float>& texels) {
  const Layers l = layers();
  const size_t slice = static_cast<size_t>(l.width) * l.height;
  if (texels.size() != slice * Layers::kDepth)
    throw Error("depth cube: " + std::to_string(texels.size()) + " texels, not " +
                std::to_string(l.width) + "x" + std::to_string(l.height) + "x" +
                std::to_string(Layers::kDepth));
  for (int k = 0; k < 6; ++k) {
    DepthMap& m = maps[k];
    m.depth.resize(static_cast<size_t>(m.nu) * m.nv);
    for (int j = 0; j < m.nv; ++j)
      for (int i = 0; i < m.nu; ++i)
        m.depth[static_cast<size_t>(j) * m.nu + i] =
            texels[k * slice + static_cast<size_t>(j) * l.width + i];
  }
}

std::uint64_t DepthCube::texture_bytes(int bytes_per_texel) const {
  const Layers l = layers();
  return std::uint64_t(l.width) * std::uint64_t(l.height) * Layers::kDepth * bytes_per_texel;
}

long DepthCube::map_texels() const {
  long n = 0;
  for (const DepthMap& m : maps) n += long(m.nu) * m.nv;
  return n;
}

Eigen::Vector3i depth_cube_dims(const Eigen::Vector3d& half_extents, int resolution) {
  const double spacing = 2.0 * half_extents.maxCoeff() / resolution;
  Eigen::Vector3i n;
  for (int a = 0; a < 3; ++a)
    n[a] = std::max(1, static_cast<int>(std::ceil(2.0 * half_extents[a] / spacing - 1e-9)));
  return n;
}

std::uint64_t depth_cube_bytes(const Eigen::Vector3d& half_extents, int resolution) {
  const Eigen::Vector3i n = depth_cube_dims(half_extents, resolution);
  // 8 slices of (largest u count) x (largest v count) (DepthCube::layers); u is x or y, v y or z.
  const std::uint64_t w = std::max(n.x(), n.y()), h = std::max(n.y(), n.z());
  return w * h * DepthCube::Layers::kDepth * sizeof(float);
}

DepthCube depth_cube_layout(const Eigen::Vector3d& h, int resolution) {
  if (resolution < 1 || resolution > 65536)
    throw Error("implicit.resolution = " + std::to_string(resolution) +
                ": a depth cube needs a resolution in [1, 65536]");
  DepthCube cube;
  cube.half_extents = h;
  cube.spacing = 2.0 * h.maxCoeff() / resolution;
  cube.far_depth = static_cast<float>(kFarDepthBoxes * 2.0 * h.maxCoeff());
  const Eigen::Vector3i n = depth_cube_dims(h, resolution);
  for (int k = 0; k < 6; ++k) {
    DepthMap& m = cube.maps[k];
    m.axis = k / 2;
    m.side = k % 2 ? 1 : -1;
    face_axes(m.axis, m.u_axis, m.v_axis);
    m.half_extent = h[m.axis];
    m.spacing = cube.spacing;
    m.nu = n[m.u_axis];
    m.nv = n[m.v_axis];
    m.origin = -0.5 * cube.spacing * Eigen::Vector2d(m.nu, m.nv);
    m.depth.assign(static_cast<size_t>(m.nu) * m.nv, cube.far_depth);
  }
  return cube;
}

DepthCube bake_depth_cube(const Mesh& mesh, const Box& box, int resolution,
                          Interrupter* interrupter) {
  const auto start = std::chrono::steady_clock::now();
  raywarp::poll(interrupter, "depth cube", 0.0);
  DepthCube cube = depth_cube_layout(box.half_extents, resolution);
  const Eigen::Vector3d& h = box.half_extents;

  std::vector<Eigen::Vector3d> local(static_cast<size_t>(mesh.V.rows()));
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    local[i] = box.to_local(mesh.V.row(i).transpose());

  // Each triangle goes to the bands of rows it covers, per axis, in mesh order (a texel then
  // meets its triangles in the same order whatever the bands).
  const long triangles = static_cast<long>(mesh.F.rows());
  const Bands bands = bands_of(cube, triangles);
  std::vector<std::array<int, 6>> spans(static_cast<size_t>(triangles));  // per axis: bands
  parallel_for(chunks(triangles, kChunk), [&](long chunk) {
    raywarp::poll(interrupter);
    for (long f = chunk * kChunk; f < std::min(triangles, (chunk + 1) * kChunk); ++f)
      for (int a = 0; a < 3; ++a) {
        Projection pr;
        int& b0 = spans[f][2 * a];
        int& b1 = spans[f][2 * a + 1];
        b0 = 0;
        b1 = -1;
        if (project(local, mesh, f, a, cube.maps[2 * a], pr)) {
          b0 = pr.j0 / bands.rows[a];
          b1 = pr.j1 / bands.rows[a];
        }
      }
  });
  std::vector<int> faces[3];          // per axis: the triangles of band 0, then band 1, ...
  std::vector<size_t> band_start[3];  // per axis: where each band's triangles start in faces
  parallel_for(3, [&](long a) {
    raywarp::poll(interrupter);
    std::vector<size_t>& at = band_start[a];
    at.assign(static_cast<size_t>(bands.count[a]) + 1, 0);
    for (const auto& span : spans)
      for (int b = span[2 * a]; b <= span[2 * a + 1]; ++b) ++at[b + 1];
    for (size_t b = 1; b < at.size(); ++b) at[b] += at[b - 1];
    faces[a].resize(at.back());
    std::vector<size_t> next(at.begin(), at.end() - 1);
    for (long f = 0; f < triangles; ++f)
      for (int b = spans[f][2 * a]; b <= spans[f][2 * a + 1]; ++b)
        faces[a][next[b]++] = static_cast<int>(f);
  });
  spans = {};

  // Where the ray starts inside the mesh the face is no surface of the mesh: -far_depth keeps
  // that face's vote inside all along the ray and its |f_k| out of the min (see depth_cube.h).
  const float inside_depth = -cube.far_depth;
  // Per band of an axis: rasterise, then fill its rows of the axis's two maps. Rays with no hit
  // inside the box whose crossings before the two faces disagree (an open mesh) are left for
  // the winding number. Each band writes only its own rows.
  std::vector<DepthCubeTexels> counts(static_cast<size_t>(bands.total()));
  std::vector<std::vector<size_t>> undecided(counts.size());
  parallel_for(
      bands.total(),
      [&](long index) {
        const auto [a, b] = bands.of(static_cast<int>(index));
        DepthMap& lo = cube.maps[2 * a];
        DepthMap& hi = cube.maps[2 * a + 1];
        const int row0 = b * bands.rows[a], row1 = std::min(row0 + bands.rows[a], lo.nv) - 1;
        AxisHits ah(static_cast<size_t>(row1 - row0 + 1) * lo.nu);
        rasterise_rows(local, mesh, a, h, lo, faces[a].data() + band_start[a][b],
                       band_start[a][b + 1] - band_start[a][b], row0, row1, ah);
        DepthCubeTexels& c = counts[index];
        const size_t first = static_cast<size_t>(row0) * lo.nu;
        for (size_t k = 0; k < ah.near_lo.size(); ++k) {
          const size_t t = first + k;
          if (std::isfinite(ah.near_lo[k])) {  // then also from the other face
            // The first surface point: where the ray enters the mesh; when it leaves the mesh
            // there, it started inside.
            lo.depth[t] = ah.enters_lo[k] ? ah.near_lo[k] : inside_depth;
            hi.depth[t] = ah.enters_hi[k] ? ah.near_hi[k] : inside_depth;
            c.surface += ah.enters_lo[k] + ah.enters_hi[k];
            c.inside += !ah.enters_lo[k] + !ah.enters_hi[k];
          } else if ((ah.winding_lo[k] > 0) != (ah.winding_hi[k] > 0)) {
            undecided[index].push_back(t);
          } else {  // no surface inside the box: the whole ray is inside or outside
            const bool inside = ah.winding_lo[k] > 0;
            lo.depth[t] = hi.depth[t] = inside ? inside_depth : cube.far_depth;
            (inside ? c.inside : c.empty) += 2;
          }
        }
      },
      interrupter, "depth cube");
  for (int index = 0; index < bands.total(); ++index) {
    cube.texels.surface += counts[index].surface;
    cube.texels.inside += counts[index].inside;
    cube.texels.empty += counts[index].empty;
  }

  // The undecided rays, by the winding number at their point on the -axis face.
  std::vector<std::pair<int, size_t>> open;  // (axis, texel)
  for (int index = 0; index < bands.total(); ++index)
    for (size_t t : undecided[index]) open.emplace_back(bands.of(index).first, t);
  if (!open.empty()) {
    const WindingNumber winding(mesh);  // built only if some ray needs it
    std::vector<char> inside(open.size());
    const long count = static_cast<long>(open.size());
    parallel_for(chunks(count, kChunk), [&](long chunk) {
      raywarp::poll(interrupter);
      for (long k = chunk * kChunk; k < std::min(count, (chunk + 1) * kChunk); ++k) {
        const auto [a, t] = open[k];
        const DepthMap& lo = cube.maps[2 * a];
        const int i = static_cast<int>(t % lo.nu), j = static_cast<int>(t / lo.nu);
        Eigen::Vector3d p = Eigen::Vector3d::Zero();
        p[a] = -h[a];
        p[lo.u_axis] = lo.origin.x() + (i + 0.5) * lo.spacing;
        p[lo.v_axis] = lo.origin.y() + (j + 0.5) * lo.spacing;
        inside[k] = winding(box.to_object(p)) > 0.5;
      }
    });
    for (size_t k = 0; k < open.size(); ++k) {
      const auto [a, t] = open[k];
      cube.maps[2 * a].depth[t] = cube.maps[2 * a + 1].depth[t] =
          inside[k] ? inside_depth : cube.far_depth;
      (inside[k] ? cube.texels.inside : cube.texels.empty) += 2;
      cube.texels.winding_fallbacks += 2;
    }
  }

  // Each map's silhouette dilated by a texel: an empty texel next to texels that see the surface
  // takes the deepest of their depths (see DepthCube::far_depth). By bands of rows.
  for (DepthMap& m : cube.maps) {
    const std::vector<float> original = m.depth;
    const int rows = bands.rows[m.axis];
    std::vector<long> dilated(static_cast<size_t>(bands.count[m.axis]), 0);
    parallel_for(bands.count[m.axis], [&](long band) {
      raywarp::poll(interrupter);
      const int j0 = static_cast<int>(band) * rows, j1 = std::min(j0 + rows, m.nv);
      for (int j = j0; j < j1; ++j)
        for (int i = 0; i < m.nu; ++i) {
          float& depth = m.depth[static_cast<size_t>(j) * m.nu + i];
          if (depth != cube.far_depth) continue;
          float deepest = -1.0f;
          for (int y = std::max(j - 1, 0); y <= std::min(j + 1, m.nv - 1); ++y)
            for (int x = std::max(i - 1, 0); x <= std::min(i + 1, m.nu - 1); ++x) {
              const float d = original[static_cast<size_t>(y) * m.nu + x];
              if (d >= 0.0f && d != cube.far_depth) deepest = std::max(deepest, d);
            }
          if (deepest < 0.0f) continue;
          depth = deepest;
          ++dilated[band];
        }
    });
    for (long d : dilated) cube.texels.dilated += d;
  }
  raywarp::poll(interrupter, "depth cube", 1.0);
  cube.bake_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return cube;
}

double depth_cube_value(const DepthCube& cube, const Eigen::Vector3d& p) {
  bool inside = true;
  double nearest = kInfinity;
  for (const DepthMap& m : cube.maps) {
    const double f = m.distance_from_face(p) - m.sample(p[m.u_axis], p[m.v_axis]);
    inside = inside && f > 0.0;
    nearest = std::min(nearest, std::abs(f));
  }
  return inside ? nearest : -nearest;
}

std::string describe(const DepthCube& cube) {
  const DepthCube::Layers layers = cube.layers();
  const std::string fallbacks =
      cube.texels.winding_fallbacks
          ? ", " + std::to_string(cube.texels.winding_fallbacks) + " by winding number (open mesh)"
          : std::string();
  char buf[320];
  std::snprintf(
      buf, sizeof buf,
      "depth cube: 6 maps (x %dx%d, y %dx%d, z %dx%d) in a %dx%dx8 texture, texel %.4g, "
      "%.2f MiB; texels: %ld surface, %ld inside, %ld empty (%ld of them dilated)%s (%.2f s)",
      cube.maps[0].nu, cube.maps[0].nv, cube.maps[2].nu, cube.maps[2].nv, cube.maps[4].nu,
      cube.maps[4].nv, layers.width, layers.height, cube.spacing,
      cube.texture_bytes() / double(1 << 20), cube.texels.surface, cube.texels.inside,
      cube.texels.empty, cube.texels.dilated, fallbacks.c_str(), cube.bake_seconds);
  return buf;
}

}  // namespace raywarp
