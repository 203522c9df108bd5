#include "library/sheets.h"

#include <algorithm>
#include <cmath>

#include "base/parallel.h"
#include "library/triangle_bvh.h"

namespace raywarp {

std::vector<int> sheet_faces(const Mesh& mesh, const WindingNumber& winding, const Box& box,
                             const Grid3<float>& grid, double offset, Interrupter* interrupter) {
  const long faces = static_cast<long>(mesh.F.rows());
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
        // The signed grid first: a face with the solid behind it there is in the signed field
        // (nearly every face of a closed part), and only the rest pay for the winding number.
        const Eigen::Vector3d mid = (a + b + c) / 3.0, step = offset * n.normalized();
        if (grid.sample(mid - step).value() > 0.0 && grid.sample(mid + step).value() < 0.0) {
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
  // Per connected part (faces sharing vertices): a part most of whose faces in the region are
  // sheets is a sheet (a card, a cloth, an eyelid); a part mostly in the signed field (a scan with
  // holes, whose faces near a hole's rim have no inside either) keeps its signed field alone, so
  // that no shell bridges its holes.
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
  std::vector<long> sheets(parent.size(), 0), in_region(parent.size(), 0);
  for (long f = 0; f < faces; ++f) {
    const size_t r = static_cast<size_t>(root(mesh.F(f, 0)));
    sheets[r] += sheet[static_cast<size_t>(f)] == 1;
    in_region[r] += sheet[static_cast<size_t>(f)] != 0;
  }
  std::vector<int> out;
  for (long f = 0; f < faces; ++f) {
    const size_t r = static_cast<size_t>(root(mesh.F(f, 0)));
    if (sheet[static_cast<size_t>(f)] == 1 && 2 * sheets[r] >= in_region[r])
      out.push_back(static_cast<int>(f));
  }
  return out;
}

void add_sheet_shells(const Mesh& mesh, const std::vector<int>& faces, const Box& box, double half,
                      Grid3<float>& grid, Interrupter* interrupter) {
  if (faces.empty()) return;
  const double reach = half + 2.0 * grid.voxel();
  struct Face {
    Eigen::Vector3d a, b, c;
    Eigen::Vector3i lo, hi;  // texel range within reach
  };
  std::vector<Face> local(faces.size());
  for (size_t i = 0; i < faces.size(); ++i) {
    Face& f = local[i];
    f.a = box.to_local(mesh.vertex(faces[i], 0));
    f.b = box.to_local(mesh.vertex(faces[i], 1));
    f.c = box.to_local(mesh.vertex(faces[i], 2));
    const Eigen::Vector3d lo = f.a.cwiseMin(f.b).cwiseMin(f.c).array() - reach;
    const Eigen::Vector3d hi = f.a.cwiseMax(f.b).cwiseMax(f.c).array() + reach;
    for (int k = 0; k < 3; ++k) {
      // Texel centres origin + (i + 1/2) spacing within [lo, hi], clamped in double first (a
      // vertex far away must not overflow the conversion).
      const double first = std::ceil((lo[k] - grid.origin[k]) / grid.spacing[k] - 0.5);
      const double last = std::floor((hi[k] - grid.origin[k]) / grid.spacing[k] - 0.5);
      f.lo[k] = int(std::clamp(first, 0.0, double(grid.dims[k])));
      f.hi[k] = int(std::clamp(last, -1.0, double(grid.dims[k] - 1)));
    }
  }
  parallel_for(
      grid.dims.z(),
      [&](long slice) {
        const int k = int(slice);
        for (const Face& f : local) {
          if (k < f.lo.z() || k > f.hi.z()) continue;
          for (int j = f.lo.y(); j <= f.hi.y(); ++j)
            for (int i = f.lo.x(); i <= f.hi.x(); ++i) {
              const Eigen::Vector3d p = grid.texel_centre(i, j, k);
              const double d = (closest_point_on_triangle(p, f.a, f.b, f.c) - p).norm();
              float& v = grid.at(i, j, k);
              v = std::max(v, static_cast<float>(half - d));
            }
        }
      },
      interrupter, "sheets");
}

}  // namespace raywarp
