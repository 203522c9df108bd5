#include "library/surface_mapping.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <string>

#include "base/error.h"
#include "base/parallel.h"
#include "library/triangle_bvh.h"

namespace raywarp {

namespace {

// Vertices per task of the parallel loops.
constexpr long kBlock = 1024;

template <class Body>
void for_each_vertex(long count, const Body& body) {
  parallel_for((count + kBlock - 1) / kBlock, [&](long block) {
    const long end = std::min(count, (block + 1) * kBlock);
    for (long i = block * kBlock; i < end; ++i) body(i);
  });
}

// Faces of cells given as node lists, each face `Corners` nodes in the cell's outward order:
// those used by exactly one cell, in cell order then face order. `what` names the cells.
template <size_t Corners>
std::vector<std::array<int, Corners>> single_faces(
    const std::vector<std::array<int, Corners>>& faces, const char* what, int faces_per_cell) {
  struct Entry {
    std::array<int, Corners> key;
    size_t order;
  };
  std::vector<Entry> entries(faces.size());
  for (size_t f = 0; f < faces.size(); ++f) {
    entries[f].key = faces[f];
    std::sort(entries[f].key.begin(), entries[f].key.end());
    entries[f].order = f;
  }
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    return a.key != b.key ? a.key < b.key : a.order < b.order;
  });
  std::vector<size_t> single;
  for (size_t i = 0; i < entries.size();) {
    size_t j = i + 1;
    while (j < entries.size() && entries[j].key == entries[i].key) ++j;
    if (j - i == 1) single.push_back(entries[i].order);
    if (j - i > 2)
      throw Error(std::string(what) + " " + std::to_string(entries[i].order / faces_per_cell) +
                  ": a face shared by " + std::to_string(j - i) +
                  " cells (a boundary needs a manifold mesh: at most 2)");
    i = j;
  }
  std::sort(single.begin(), single.end());
  std::vector<std::array<int, Corners>> out;
  out.reserve(single.size());
  for (size_t f : single) out.push_back(faces[f]);
  return out;
}

template <size_t N>
void check_cell(const std::array<int, N>& cell, size_t index, const char* what) {
  for (size_t a = 0; a < N; ++a) {
    if (cell[a] < 0)
      throw Error(std::string(what) + " " + std::to_string(index) + ": node index " +
                  std::to_string(cell[a]) + " < 0");
    for (size_t b = a + 1; b < N; ++b)
      if (cell[a] == cell[b])
        throw Error(std::string(what) + " " + std::to_string(index) + ": node " +
                    std::to_string(cell[a]) + " appears twice");
  }
}

// The threshold below which the interpolated normal is unusable (see the header).
constexpr double kParallelTolerance = 1e-6;

// The frame of triangle (p1, p2, p3) at weights (u, v), eq. 6 (and eq. 8 when n1 is non-null).
SurfaceFrame frame_of(const Eigen::Vector3d& p1, const Eigen::Vector3d& p2,
                      const Eigen::Vector3d& p3, double u, double v, const Eigen::Vector3d* n1,
                      const Eigen::Vector3d* n2, const Eigen::Vector3d* n3) {
  SurfaceFrame f;
  const Eigen::Vector3d e1 = p2 - p1, e2 = p3 - p1;
  f.reference = p1 + u * e1 + v * e2;
  // Explicit divisions, so that a zero-length vector gives NaN, as GLSL's normalize does.
  f.T = e1 / e1.norm();
  const Eigen::Vector3d bt = e2 / e2.norm();
  const Eigen::Vector3d n = f.T.cross(bt);
  f.N = n / n.norm();
  f.B = f.N.cross(f.T);
  if (n1) {
    const Eigen::Vector3d nc = (1.0 - u - v) * *n1 + u * *n2 + v * *n3;
    const Eigen::Vector3d bc = nc.cross(f.T);
    const double length = nc.norm(), b_length = bc.norm();
    if (b_length > kParallelTolerance * length) {
      f.N = nc / length;
      f.B = bc / b_length;
      f.T = f.B.cross(f.N);
    }
  }
  return f;
}

void check_nodes(const SurfaceBinding& binding, const std::vector<Eigen::Vector3d>& nodes,
                 const char* which) {
  if (static_cast<long>(nodes.size()) != binding.node_count)
    throw Error(std::string("surface mapping: ") + which + " has " + std::to_string(nodes.size()) +
                " nodes, the binding was made for " + std::to_string(binding.node_count));
}

}  // namespace

std::vector<NodeTriangle> boundary_triangles(const std::vector<std::array<int, 4>>& tets) {
  std::vector<NodeTriangle> faces;
  faces.reserve(tets.size() * 4);
  for (size_t t = 0; t < tets.size(); ++t) {
    check_cell(tets[t], t, "tet");
    const auto [a, b, c, d] = tets[t];
    faces.push_back({b, c, d});
    faces.push_back({a, d, c});
    faces.push_back({a, b, d});
    faces.push_back({a, c, b});
  }
  return single_faces(faces, "tet", 4);
}

std::vector<LatticeCell> lattice_cells(const std::vector<Eigen::Vector3i>& samples) {
  std::map<std::array<int, 3>, int> node_at;
  for (size_t i = 0; i < samples.size(); ++i) {
    const std::array<int, 3> key{samples[i].x(), samples[i].y(), samples[i].z()};
    if (!node_at.emplace(key, static_cast<int>(i)).second)
      throw Error("lattice_cells: nodes " + std::to_string(node_at[key]) + " and " +
                  std::to_string(i) + " share the sample (" + std::to_string(key[0]) + ", " +
                  std::to_string(key[1]) + ", " + std::to_string(key[2]) + ")");
  }
  std::vector<LatticeCell> cells;
  for (const Eigen::Vector3i& s : samples) {
    LatticeCell cell;
    bool complete = true;
    for (int k = 0; k < 8 && complete; ++k) {
      auto found = node_at.find({s.x() + (k & 1), s.y() + ((k >> 1) & 1), s.z() + ((k >> 2) & 1)});
      if (found == node_at.end())
        complete = false;
      else
        cell[k] = found->second;
    }
    if (complete) cells.push_back(cell);
  }
  return cells;
}

std::vector<NodeTriangle> grid_boundary_triangles(const std::vector<LatticeCell>& cells) {
  // Outward corner cycles of the faces -x, +x, -y, +y, -z, +z of a right-handed cell.
  static constexpr int kFaces[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                                       {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  std::vector<std::array<int, 4>> quads;
  quads.reserve(cells.size() * 6);
  for (size_t c = 0; c < cells.size(); ++c) {
    check_cell(cells[c], c, "cell");
    for (const auto& face : kFaces)
      quads.push_back({cells[c][face[0]], cells[c][face[1]], cells[c][face[2]], cells[c][face[3]]});
  }
  std::vector<NodeTriangle> triangles;
  for (const std::array<int, 4>& q : single_faces(quads, "cell", 6)) {
    const int first = static_cast<int>(std::min_element(q.begin(), q.end()) - q.begin());
    const int a = q[first], b = q[(first + 1) % 4], c = q[(first + 2) % 4], d = q[(first + 3) % 4];
    triangles.push_back({a, b, c});
    triangles.push_back({a, c, d});
  }
  return triangles;
}

std::vector<Eigen::Vector3d> node_normals(const std::vector<Eigen::Vector3d>& nodes,
                                          const std::vector<NodeTriangle>& triangles) {
  std::vector<Eigen::Vector3d> normals(nodes.size(), Eigen::Vector3d::Zero());
  for (const NodeTriangle& t : triangles) {
    const Eigen::Vector3d n = (nodes[t[1]] - nodes[t[0]]).cross(nodes[t[2]] - nodes[t[0]]);
    for (int c : t) normals[c] += n;
  }
  for (Eigen::Vector3d& n : normals) {
    const double length = n.norm();
    if (length > 0.0) n /= length;
  }
  return normals;
}

const char* basis_name(SurfaceBasis basis) {
  return basis == SurfaceBasis::Interpolated ? "interpolated" : "triangle";
}

SurfaceBinding bind_surface(const Mesh& mesh, const std::vector<Eigen::Vector3d>& rest_nodes,
                            const std::vector<NodeTriangle>& triangles, SurfaceBasis basis,
                            BindStats* stats, const std::vector<char>* moves) {
  const auto start = std::chrono::steady_clock::now();
  const long n = static_cast<long>(mesh.V.rows());
  if (n == 0) throw Error("surface mapping: the detailed mesh has no vertices");
  if (moves && static_cast<long>(moves->size()) != n)
    throw Error("surface mapping: " + std::to_string(moves->size()) +
                " vertex flags for a mesh of " + std::to_string(n) + " vertices");
  if (triangles.empty()) throw Error("surface mapping: the coarse surface has no triangles");
  const int node_count = static_cast<int>(rest_nodes.size());
  for (size_t t = 0; t < triangles.size(); ++t)
    for (int c : triangles[t])
      if (c < 0 || c >= node_count)
        throw Error("surface mapping: coarse triangle " + std::to_string(t) + " names node " +
                    std::to_string(c) + " of " + std::to_string(node_count));

  // The usable triangles (non-zero area), the tree over them, and the triangles at each node.
  std::vector<int> usable;
  std::vector<Triangle3d> corners;
  Eigen::AlignedBox3d bounds;
  for (size_t t = 0; t < triangles.size(); ++t) {
    const Eigen::Vector3d& p1 = rest_nodes[triangles[t][0]];
    const Eigen::Vector3d e1 = rest_nodes[triangles[t][1]] - p1;
    const Eigen::Vector3d e2 = rest_nodes[triangles[t][2]] - p1;
    if (!(e1.cross(e2).norm() > 1e-12 * std::max(e1.squaredNorm(), e2.squaredNorm()))) continue;
    usable.push_back(static_cast<int>(t));
    corners.push_back({p1, rest_nodes[triangles[t][1]], rest_nodes[triangles[t][2]]});
    for (const Eigen::Vector3d& p : corners.back()) bounds.extend(p);
  }
  if (usable.empty()) throw Error("surface mapping: every coarse triangle has zero area at rest");
  const TriangleBvh bvh(corners);
  std::vector<int> incident_start(node_count + 1, 0), incident;
  for (int k : usable)
    for (int c : triangles[k]) ++incident_start[c + 1];
  for (int i = 0; i < node_count; ++i) incident_start[i + 1] += incident_start[i];
  incident.resize(incident_start[node_count]);
  {
    std::vector<int> fill(incident_start.begin(), incident_start.end() - 1);
    for (int k : usable)
      for (int c : triangles[k]) incident[fill[c]++] = k;  // ascending triangle index per node
  }
  const double tie_tolerance = 1e-9 * bounds.diagonal().norm();
  const std::vector<Eigen::Vector3d> rest_normals = basis == SurfaceBasis::Interpolated
                                                        ? node_normals(rest_nodes, triangles)
                                                        : std::vector<Eigen::Vector3d>{};
  const auto vertex_normal = vertex_normals(mesh);

  SurfaceBinding b;
  b.basis = basis;
  b.node_count = node_count;
  b.triangles = triangles;
  b.triangle.resize(n);
  b.weights.resize(n);
  b.offset.resize(n);
  b.normal.resize(n);
  std::vector<double> distance(n);
  std::vector<char> tied(n, 0), outside(n, 0);

  // The weights (u, v) of the projection of p on triangle t's plane.
  auto project = [&](const Eigen::Vector3d& p, int t) {
    const Eigen::Vector3d& p1 = rest_nodes[triangles[t][0]];
    const Eigen::Vector3d e1 = rest_nodes[triangles[t][1]] - p1;
    const Eigen::Vector3d e2 = rest_nodes[triangles[t][2]] - p1;
    const Eigen::Vector3d q = p - p1;
    const double d11 = e1.dot(e1), d12 = e1.dot(e2), d22 = e2.dot(e2);
    const double b1 = e1.dot(q), b2 = e2.dot(q);
    const double den = d11 * d22 - d12 * d12;
    return Eigen::Vector2d((d22 * b1 - d12 * b2) / den, (d11 * b2 - d12 * b1) / den);
  };
  auto least_weight = [](const Eigen::Vector2d& w) {
    return std::min({1.0 - w.x() - w.y(), w.x(), w.y()});
  };

  for_each_vertex(n, [&](long i) {
    const Eigen::Vector3d p = mesh.V.row(i).transpose();
    if (moves && !(*moves)[i]) {
      b.triangle[i] = -1;
      b.weights[i].setZero();
      b.offset[i] = p;
      b.normal[i] = vertex_normal.row(i).transpose();
      return;
    }
    const TriangleBvh::Nearest nearest = bvh.nearest(p);
    const int first = usable[nearest.triangle];
    int best = first;
    Eigen::Vector2d best_w = project(p, first);
    double best_score = least_weight(best_w), best_distance = nearest.distance;
    bool tie = false;
    for (int c : triangles[first])
      for (int j = incident_start[c]; j < incident_start[c + 1]; ++j) {
        const int t = incident[j];
        if (t == first) continue;
        const NodeTriangle& tri = triangles[t];
        const double d = (p - closest_point_on_triangle(p, rest_nodes[tri[0]], rest_nodes[tri[1]],
                                                        rest_nodes[tri[2]]))
                             .norm();
        if (!(d <= nearest.distance + tie_tolerance)) continue;
        tie = true;
        const Eigen::Vector2d w = project(p, t);
        const double score = least_weight(w);
        if (score > best_score || (score == best_score && t < best)) {
          best = t;
          best_w = w;
          best_score = score;
          best_distance = d;
        }
      }
    tied[i] = tie;
    outside[i] = best_score < 0.0;
    distance[i] = best_distance;

    const NodeTriangle& tri = triangles[best];
    const bool interpolated = basis == SurfaceBasis::Interpolated;
    const SurfaceFrame f =
        frame_of(rest_nodes[tri[0]], rest_nodes[tri[1]], rest_nodes[tri[2]], best_w.x(), best_w.y(),
                 interpolated ? &rest_normals[tri[0]] : nullptr,
                 interpolated ? &rest_normals[tri[1]] : nullptr,
                 interpolated ? &rest_normals[tri[2]] : nullptr);
    // The offset from the reference point as deform() will compute it, so the rest shape comes
    // back to rounding.
    const Eigen::Vector3d o = p - f.reference;
    const Eigen::Vector3d nv = vertex_normal.row(i).transpose();
    b.triangle[i] = best;
    b.weights[i] = best_w;
    b.offset[i] = Eigen::Vector3d(o.dot(f.T), o.dot(f.N), o.dot(f.B));
    b.normal[i] = Eigen::Vector3d(nv.dot(f.T), nv.dot(f.N), nv.dot(f.B));
  });

  if (stats) {
    *stats = BindStats{};
    double sum = 0.0;
    for (long i = 0; i < n; ++i) {
      if (b.triangle[i] < 0) {
        ++stats->fixed;
        continue;
      }
      stats->max_distance = std::max(stats->max_distance, distance[i]);
      sum += distance[i];
      stats->ties += tied[i];
      stats->outside += outside[i];
    }
    stats->mean_distance = n > stats->fixed ? sum / double(n - stats->fixed) : 0.0;
    stats->degenerate_triangles = static_cast<long>(triangles.size() - usable.size());
    stats->seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  return b;
}

SurfaceFrame surface_frame(const SurfaceBinding& binding, size_t vertex,
                           const std::vector<Eigen::Vector3d>& nodes,
                           const std::vector<Eigen::Vector3d>& normals) {
  const NodeTriangle& t = binding.triangles[binding.triangle[vertex]];
  const Eigen::Vector2d& w = binding.weights[vertex];
  if (binding.basis == SurfaceBasis::Interpolated)
    return frame_of(nodes[t[0]], nodes[t[1]], nodes[t[2]], w.x(), w.y(), &normals[t[0]],
                    &normals[t[1]], &normals[t[2]]);
  return frame_of(nodes[t[0]], nodes[t[1]], nodes[t[2]], w.x(), w.y(), nullptr, nullptr, nullptr);
}

std::vector<Eigen::Vector3d> deform(const SurfaceBinding& binding,
                                    const std::vector<Eigen::Vector3d>& rest_nodes,
                                    const std::vector<Eigen::Vector3d>& deformed_nodes) {
  check_nodes(binding, rest_nodes, "the rest shape");
  return deform(binding, deformed_nodes);
}

std::vector<Eigen::Vector3d> deform(const SurfaceBinding& binding,
                                    const std::vector<Eigen::Vector3d>& deformed_nodes) {
  check_nodes(binding, deformed_nodes, "the deformed shape");
  const std::vector<Eigen::Vector3d> normals = binding.basis == SurfaceBasis::Interpolated
                                                   ? node_normals(deformed_nodes, binding.triangles)
                                                   : std::vector<Eigen::Vector3d>{};
  std::vector<Eigen::Vector3d> out(binding.size());
  for_each_vertex(static_cast<long>(binding.size()), [&](long i) {
    if (binding.triangle[i] < 0) {
      out[i] = binding.offset[i];
      return;
    }
    const SurfaceFrame f = surface_frame(binding, i, deformed_nodes, normals);
    const Eigen::Vector3d& o = binding.offset[i];
    out[i] = f.reference + o.x() * f.T + o.y() * f.N + o.z() * f.B;
  });
  return out;
}

std::vector<Eigen::Vector3d> deform_normals(const SurfaceBinding& binding,
                                            const std::vector<Eigen::Vector3d>& deformed_nodes) {
  check_nodes(binding, deformed_nodes, "the deformed shape");
  const std::vector<Eigen::Vector3d> normals = binding.basis == SurfaceBasis::Interpolated
                                                   ? node_normals(deformed_nodes, binding.triangles)
                                                   : std::vector<Eigen::Vector3d>{};
  std::vector<Eigen::Vector3d> out(binding.size());
  for_each_vertex(static_cast<long>(binding.size()), [&](long i) {
    Eigen::Vector3d n = binding.normal[i];
    if (binding.triangle[i] >= 0) {
      const SurfaceFrame f = surface_frame(binding, i, deformed_nodes, normals);
      const Eigen::Vector3d& c = binding.normal[i];
      n = c.x() * f.T + c.y() * f.N + c.z() * f.B;
    }
    const double length = n.norm();
    out[i] = length > 0.0 ? Eigen::Vector3d(n / length) : n;
  });
  return out;
}

Mesh deform_mesh(const SurfaceBinding& binding, const Mesh& mesh,
                 const std::vector<Eigen::Vector3d>& deformed_nodes) {
  if (static_cast<size_t>(mesh.V.rows()) != binding.size())
    throw Error("surface mapping: the mesh has " + std::to_string(mesh.V.rows()) +
                " vertices, the binding " + std::to_string(binding.size()));
  const std::vector<Eigen::Vector3d> v = deform(binding, deformed_nodes);
  Mesh out = mesh;
  for (size_t i = 0; i < v.size(); ++i) out.V.row(static_cast<Eigen::Index>(i)) = v[i].transpose();
  return out;
}

BodySurface simulation_body_surface(const SimulationBody& body,
                                    const std::vector<Eigen::Vector3d>& state, const Box& box,
                                    const Mesh& mesh) {
  if (state.size() != body.rest.size())
    throw Error("surface mapping: a state of " + std::to_string(state.size()) +
                " nodes for a body of " + std::to_string(body.rest.size()));
  BodySurface s;
  for (size_t n = 0; n < body.rest.size(); ++n) {
    s.rest.push_back(box.to_object(body.rest[n]));
    s.moved.push_back(box.to_object(state[n]));
  }
  s.triangles = body.model == SimModel::tets ? boundary_triangles(body.tets)
                                             : grid_boundary_triangles(lattice_cells(body.sample));
  s.moves.resize(static_cast<size_t>(mesh.V.rows()));
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    s.moves[i] = box.contains(mesh.V.row(i).transpose()) ? 1 : 0;
  return s;
}

}  // namespace raywarp
