#include "library/sheets.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

#include "base/parallel.h"
#include "library/triangle_bvh.h"

namespace raywarp {

std::vector<int> sheet_faces(const Mesh& mesh, const WindingNumber& winding, const Box& box,
                             const Grid3<float>& grid, double offset, Interrupter* interrupter,
                             double* area_share) {
  const long faces = static_cast<long>(mesh.F.rows());
  // Connected parts (faces sharing vertices), and which of them have an open edge.
  std::vector<int> parent(static_cast<size_t>(mesh.V.rows()));
  for (size_t v = 0; v < parent.size(); ++v) parent[v] = static_cast<int>(v);
  auto root = [&](int v) {
    while (parent[static_cast<size_t>(v)] != v)
      v = parent[static_cast<size_t>(v)] =
          parent[static_cast<size_t>(parent[static_cast<size_t>(v)])];
    return v;
  };
  for (long f = 0; f < faces; ++f)
    for (int c = 1; c < 3; ++c) {
      const int a = root(mesh.F(f, 0)), b = root(mesh.F(f, c));
      if (a != b) parent[static_cast<size_t>(std::max(a, b))] = std::min(a, b);
    }
  std::vector<char> open_part(parent.size(), 0);
  for_each_edge_use(mesh, [&](int u, int, int uses) {
    if (uses == 1) open_part[static_cast<size_t>(root(u))] = 1;
  });
  std::vector<int> part(static_cast<size_t>(faces));
  for (long f = 0; f < faces; ++f) part[static_cast<size_t>(f)] = root(mesh.F(f, 0));

  const Eigen::Vector3d lo = grid.origin, hi = grid.upper();
  std::vector<char> sheet(static_cast<size_t>(faces), 0);
  parallel_for(
      faces,
      [&](long f) {
        Eigen::Vector3d a = box.to_local(mesh.vertex(int(f), 0));
        Eigen::Vector3d b = box.to_local(mesh.vertex(int(f), 1));
        Eigen::Vector3d c = box.to_local(mesh.vertex(int(f), 2));
        const Eigen::Vector3d fmin = a.cwiseMin(b).cwiseMin(c), fmax = a.cwiseMax(b).cwiseMax(c);
        if ((fmax.array() < lo.array()).any() || (fmin.array() > hi.array()).any()) return;
        const Eigen::Vector3d n = (b - a).cross(c - a);
        if (!(n.norm() > 0.0)) return;
        // On a closed part the signed grid settles most faces first: a face with the solid
        // behind it there is in the signed field, and only the rest pay for the winding number.
        // Not on an open one: behind a sheet w is about 1/2, and where the other parts' winding
        // numbers push it past 1/2 the grid has a slab of inside a voxel thick behind the sheet
        // that this test would take for a solid.
        const Eigen::Vector3d mid = (a + b + c) / 3.0, step = offset * n.normalized();
        if (!open_part[static_cast<size_t>(part[static_cast<size_t>(f)])] &&
            grid.sample(mid - step).value() > 0.0 && grid.sample(mid + step).value() < 0.0) {
          sheet[static_cast<size_t>(f)] = 2;
          return;
        }
        const Eigen::Vector3d centroid =
            mesh.vertex(int(f), 0) + mesh.vertex(int(f), 1) + mesh.vertex(int(f), 2);
        const Eigen::Vector3d normal = box.direction_to_object(n.normalized());
        const Eigen::Vector3d p = centroid / 3.0;
        const double behind = winding(p - offset * normal), front = winding(p + offset * normal);
        // 1: a sheet face; 2: in the region, in the signed field (or hidden inside a solid).
        // Across any face w jumps by about 1: from 1 to 0 where the face bounds a solid, from
        // about +1/2 to -1/2 across a sheet, whose two sides are then equally outside.
        sheet[static_cast<size_t>(f)] = behind + front < 0.5 ? 1 : 2;
      },
      interrupter, "sheets");
  // Per connected part: a part most of whose faces in the region are sheets is a sheet (a card,
  // a cloth, an eyelid); a part mostly in the signed field (a scan with holes, whose faces near a
  // hole's rim have no inside either) keeps its signed field alone, so that no shell bridges its
  // holes.
  std::vector<long> sheets(parent.size(), 0), in_region(parent.size(), 0);
  for (long f = 0; f < faces; ++f) {
    const size_t r = static_cast<size_t>(part[static_cast<size_t>(f)]);
    sheets[r] += sheet[static_cast<size_t>(f)] == 1;
    in_region[r] += sheet[static_cast<size_t>(f)] != 0;
  }
  std::vector<int> out;
  double area = 0.0, sheet_area = 0.0;
  for (long f = 0; f < faces; ++f) {
    const size_t r = static_cast<size_t>(part[static_cast<size_t>(f)]);
    const bool in = sheet[static_cast<size_t>(f)] == 1 && 2 * sheets[r] >= in_region[r];
    if (in) out.push_back(static_cast<int>(f));
    if (area_share && sheet[static_cast<size_t>(f)] != 0) {
      const double a = 0.5 * (mesh.vertex(int(f), 1) - mesh.vertex(int(f), 0))
                                 .cross(mesh.vertex(int(f), 2) - mesh.vertex(int(f), 0))
                                 .norm();
      area += a;
      if (in) sheet_area += a;
    }
  }
  if (area_share) *area_share = area > 0.0 ? sheet_area / area : 0.0;
  return out;
}

namespace {

// The point of segment [a, b] nearest to p.
Eigen::Vector3d closest_point_on_segment(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                         const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  if (!(len2 > 0.0)) return a;
  return a + std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) * ab;
}

// Texel centres origin + (i + 1/2) spacing within [lo, hi] on each axis, clamped in double first
// (a vertex far away must not overflow the conversion); empty where hi < lo.
void texel_range(const Grid3<float>& grid, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                 Eigen::Vector3i& first, Eigen::Vector3i& last) {
  for (int k = 0; k < 3; ++k) {
    const double f = std::ceil((lo[k] - grid.origin[k]) / grid.spacing[k] - 0.5);
    const double l = std::floor((hi[k] - grid.origin[k]) / grid.spacing[k] - 0.5);
    first[k] = int(std::clamp(f, 0.0, double(grid.dims[k])));
    last[k] = int(std::clamp(l, -1.0, double(grid.dims[k] - 1)));
  }
}

}  // namespace

std::vector<std::array<int, 2>> sheet_open_edges(const Mesh& mesh, const std::vector<int>& faces) {
  auto key = [](int u, int w) {
    return (std::uint64_t(std::min(u, w)) << 32) | std::uint32_t(std::max(u, w));
  };
  std::vector<std::uint64_t> boundary;
  for_each_edge_use(mesh, [&](int u, int w, int uses) {
    if (uses == 1) boundary.push_back(key(u, w));
  });
  std::sort(boundary.begin(), boundary.end());
  std::vector<std::array<int, 2>> open;
  for (const int f : faces)
    for (int c = 0; c < 3; ++c) {
      const int u = mesh.F(f, c), w = mesh.F(f, (c + 1) % 3);
      if (u != w && std::binary_search(boundary.begin(), boundary.end(), key(u, w)))
        open.push_back({u, w});
    }
  return open;
}

void add_sheet_shells(const Mesh& mesh, const std::vector<int>& faces, const Box& box, double half,
                      Grid3<float>& grid, Interrupter* interrupter) {
  if (faces.empty()) return;
  const double reach = half + 2.0 * grid.voxel();
  struct Part {
    Eigen::Vector3d a, b, c;
    Eigen::Vector3i lo, hi;  // texel range within reach
  };
  std::vector<Part> local(faces.size());
  for (size_t i = 0; i < faces.size(); ++i) {
    Part& f = local[i];
    f.a = box.to_local(mesh.vertex(faces[i], 0));
    f.b = box.to_local(mesh.vertex(faces[i], 1));
    f.c = box.to_local(mesh.vertex(faces[i], 2));
    const Eigen::Vector3d lo = f.a.cwiseMin(f.b).cwiseMin(f.c).array() - reach;
    const Eigen::Vector3d hi = f.a.cwiseMax(f.b).cwiseMax(f.c).array() + reach;
    texel_range(grid, lo, hi, f.lo, f.hi);
  }
  const std::vector<std::array<int, 2>> open = sheet_open_edges(mesh, faces);
  std::vector<Part> edges(open.size());
  for (size_t i = 0; i < open.size(); ++i) {
    Part& e = edges[i];
    e.a = box.to_local(mesh.V.row(open[i][0]).transpose());
    e.b = box.to_local(mesh.V.row(open[i][1]).transpose());
    texel_range(grid, e.a.cwiseMin(e.b).array() - reach, e.a.cwiseMax(e.b).array() + reach, e.lo,
                e.hi);
  }
  const double far = std::numeric_limits<double>::infinity();
  parallel_for(
      grid.dims.z(),
      [&](long slice) {
        const int k = int(slice);
        const size_t nx = size_t(grid.dims.x()), ny = size_t(grid.dims.y());
        // Per texel of the slice: the distance to the sheet faces, and to their open edges.
        std::vector<double> to_sheet(nx * ny, far), to_edge(nx * ny, far);
        auto nearest = [&](const std::vector<Part>& parts, std::vector<double>& out, bool face) {
          for (const Part& f : parts) {
            if (k < f.lo.z() || k > f.hi.z()) continue;
            for (int j = f.lo.y(); j <= f.hi.y(); ++j)
              for (int i = f.lo.x(); i <= f.hi.x(); ++i) {
                const Eigen::Vector3d p = grid.texel_centre(i, j, k);
                const Eigen::Vector3d q = face ? closest_point_on_triangle(p, f.a, f.b, f.c)
                                               : closest_point_on_segment(p, f.a, f.b);
                double& d = out[size_t(j) * nx + size_t(i)];
                d = std::min(d, (q - p).norm());
              }
          }
        };
        nearest(local, to_sheet, true);
        nearest(edges, to_edge, false);
        // Where the nearest point of the sheet is on an open edge (the two distances agree), p
        // lies beyond the sheet's end: the shell stops there with a flat end in the plane through
        // the edge across the sheet, not a round one half a shell beyond it, so the sheet's
        // outline stays where the edge is.
        const double same = 1e-9 * grid.voxel();
        for (size_t j = 0; j < ny; ++j)
          for (size_t i = 0; i < nx; ++i) {
            const double d = to_sheet[j * nx + i];
            if (!(d <= reach)) continue;
            const double e = to_edge[j * nx + i];
            const double shell = std::min(half - d, e > d + same ? e : -e);
            float& v = grid.at(int(i), int(j), k);
            v = std::max(v, static_cast<float>(shell));
          }
      },
      interrupter, "sheets");
}

}  // namespace raywarp
