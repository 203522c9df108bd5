#include "library/mesh_pairs.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <iterator>

#include "base/error.h"
#include "deformers/deformer.h"

namespace raywarp {

namespace {

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool is_mesh_name(const std::filesystem::path& name) {
  std::string ext = lower(name.extension().string());
  if (ext == ".xz") ext = lower(name.stem().extension().string());
  static const char* const kFormats[] = {".ply",  ".obj", ".stl", ".off",
                                         ".gltf", ".glb", ".fbx", ".dae"};
  return std::any_of(std::begin(kFormats), std::end(kFormats),
                     [&](const char* f) { return ext == f; });
}

// Natural order: runs of digits compare by value (then by length: "01" after "1"), the rest by
// byte.
bool natural_less(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const bool da = std::isdigit(static_cast<unsigned char>(a[i])) != 0;
    const bool db = std::isdigit(static_cast<unsigned char>(b[j])) != 0;
    if (da && db) {
      size_t ei = i, ej = j;
      while (ei < a.size() && std::isdigit(static_cast<unsigned char>(a[ei]))) ++ei;
      while (ej < b.size() && std::isdigit(static_cast<unsigned char>(b[ej]))) ++ej;
      size_t zi = i, zj = j;  // leading zeros
      while (zi + 1 < ei && a[zi] == '0') ++zi;
      while (zj + 1 < ej && b[zj] == '0') ++zj;
      if (ei - zi != ej - zj) return ei - zi < ej - zj;
      const int c = a.compare(zi, ei - zi, b, zj, ej - zj);
      if (c != 0) return c < 0;
      if (ei - i != ej - j) return ei - i < ej - j;
      i = ei;
      j = ej;
    } else {
      if (a[i] != b[j]) return static_cast<unsigned char>(a[i]) < static_cast<unsigned char>(b[j]);
      ++i;
      ++j;
    }
  }
  return a.size() - i < b.size() - j;
}

bool is_gltf(const std::string& file) {
  std::string ext = lower(std::filesystem::path(file).extension().string());
  return ext == ".gltf" || ext == ".glb";
}

}  // namespace

std::vector<std::string> sequence_files(const std::string& folder) {
  std::vector<std::string> names;
  std::error_code ec;
  std::filesystem::directory_iterator it(folder, ec), end;
  if (ec) throw Error(folder + ": cannot list the folder: " + ec.message());
  for (; it != end; it.increment(ec)) {
    if (ec) throw Error(folder + ": cannot list the folder: " + ec.message());
    const std::filesystem::path name = it->path().filename();
    if (name.string().empty() || name.string()[0] == '.' || !is_mesh_name(name)) continue;
    std::error_code fe;
    if (!it->is_regular_file(fe)) continue;
    names.push_back(name.string());
    if (names.size() > static_cast<size_t>(kMaxSequenceFrames))
      throw Error(folder + ": more than " + std::to_string(kMaxSequenceFrames) +
                  " mesh files: a sequence has at most that many frames");
  }
  if (names.empty())
    throw Error(folder +
                ": no mesh file (PLY, OBJ, STL, OFF, glTF, GLB, FBX, DAE) in the folder: a "
                "sequence folder holds the deformed copies, one file per frame");
  std::sort(names.begin(), names.end(), natural_less);
  std::vector<std::string> out;
  out.reserve(names.size());
  for (const std::string& n : names) out.push_back((std::filesystem::path(folder) / n).string());
  return out;
}

int sequence_frames(const std::string& target) {
  std::error_code ec;
  if (std::filesystem::is_directory(target, ec))
    return static_cast<int>(sequence_files(target).size());
  if (!is_gltf(target)) return 0;
  return load_file_vertices(target).morph_targets;
}

namespace {

// Frame `frame` of a sequence of `frames`: the frame before it, the one after and the blend.
struct FramePick {
  int a = 0, b = 0;
  double t = 0.0;
};

FramePick pick_frame(double frame, int frames, const std::string& what) {
  if (!std::isfinite(frame)) throw Error("frame: must be a finite number");
  const double f = std::max(frame, 0.0);
  if (f > frames - 1)
    throw Error("frame = " + shortest_text(frame) + ": past the sequence's last frame, " +
                std::to_string(frames - 1) + " (" + what + ")");
  FramePick p;
  p.a = static_cast<int>(std::floor(f));
  p.b = std::min(p.a + 1, frames - 1);
  p.t = f - p.a;
  return p;
}

}  // namespace

std::vector<std::string> deformed_copy_files(const std::string& target, double frame) {
  std::error_code ec;
  if (!std::filesystem::is_directory(target, ec)) return {target};
  const std::vector<std::string> files = sequence_files(target);
  const int n = static_cast<int>(files.size());
  const FramePick p = pick_frame(frame, n, std::to_string(n) + " copies in " + target);
  std::vector<std::string> out = {files[static_cast<size_t>(p.a)]};
  if (p.t > 0.0 && p.b != p.a) out.push_back(files[static_cast<size_t>(p.b)]);
  return out;
}

DeformedCopy read_deformed_copy(const std::string& target, int morph, double weight, double frame) {
  DeformedCopy out;
  std::error_code ec;
  const bool folder = std::filesystem::is_directory(target, ec);
  if (!folder && frame < 0.0) {
    out.vertices = load_file_vertices(target, morph, weight);
    out.files = {target};
    out.name = target;
    return out;
  }
  if (morph >= 0)
    throw Error("morph = " + std::to_string(morph) +
                ": a sequence's frame picks the copy; give one of frame and morph");
  std::vector<std::string> files;
  if (folder) {
    files = sequence_files(target);
    out.frames = static_cast<int>(files.size());
  } else {
    FileVertices base = load_file_vertices(target);
    out.frames = base.morph_targets;
    if (out.frames == 0)
      throw Error("frame = " + shortest_text(frame) + ": " + target +
                  " has no morph target; a sequence is a folder of copies or a glTF with morph "
                  "targets");
  }
  const auto describe_range = [&] {
    return folder ? std::to_string(out.frames) + " copies in " + target
                  : std::to_string(out.frames) + " morph targets in " + target;
  };
  const FramePick pick = pick_frame(frame, out.frames, describe_range());
  const int a = pick.a, b = pick.b;
  const double t = pick.t;
  auto read = [&](int k) {
    return folder ? load_file_vertices(files[static_cast<size_t>(k)])
                  : load_file_vertices(target, k, 1.0);
  };
  out.vertices = read(a);
  if (folder) out.files.push_back(files[static_cast<size_t>(a)]);
  if (t > 0.0 && b != a) {
    const FileVertices next = read(b);
    const std::string& name_b = folder ? files[static_cast<size_t>(b)] : target;
    if (next.positions.size() != out.vertices.positions.size())
      throw Error("frame = " + shortest_text(frame) + ": " + name_b + " has " +
                  std::to_string(next.positions.size()) + " vertices and the frame before it " +
                  std::to_string(out.vertices.positions.size()) +
                  ": every frame of a sequence keeps the mesh's vertices");
    for (size_t i = 0; i < next.positions.size(); ++i)
      out.vertices.positions[i] = (1.0 - t) * out.vertices.positions[i] + t * next.positions[i];
    if (folder) out.files.push_back(name_b);
  }
  if (!folder) out.files = {target};
  out.name = folder ? files[static_cast<size_t>(a)] : target;
  return out;
}

MeshPairs mesh_pairs(const std::string& mesh_file, const Mesh& mesh, const FileVertices& moved,
                     const std::string& target_file, const Box& box) {
  const FileVertices rest = load_file_vertices(mesh_file);
  if (rest.positions.size() != moved.positions.size())
    throw Error(target_file + ": " + std::to_string(moved.positions.size()) +
                " vertices, the scene's mesh " + mesh_file + " has " +
                std::to_string(rest.positions.size()) +
                ": a deformed copy keeps every vertex of the mesh, in the same order");
  const long n = static_cast<long>(mesh.V.rows());
  MeshPairs out;
  out.file_vertices = static_cast<long>(rest.positions.size());
  out.mesh_vertices = n;
  // Each joined vertex's copies in the target: their sum, count and spread.
  std::vector<Eigen::Vector3d> sum(static_cast<size_t>(n), Eigen::Vector3d::Zero());
  std::vector<Eigen::Vector3d> first(static_cast<size_t>(n), Eigen::Vector3d::Zero());
  std::vector<int> count(static_cast<size_t>(n), 0);
  std::vector<char> torn(static_cast<size_t>(n), 0);
  const double diagonal = 2.0 * box.half_extents.norm();
  const double tolerance = 1e-9 * std::max(diagonal, 1e-300);
  for (size_t r = 0; r < rest.joined.size(); ++r) {
    const int v = rest.joined[r];
    if (v < 0 || v >= n)
      throw Error(mesh_file + ": vertex " + std::to_string(r) +
                  " is not in the mesh as loaded (was it changed since?)");
    const Eigen::Vector3d& t = moved.positions[r];
    if (count[static_cast<size_t>(v)] == 0)
      first[static_cast<size_t>(v)] = t;
    else if ((t - first[static_cast<size_t>(v)]).norm() > tolerance)
      torn[static_cast<size_t>(v)] = 1;
    sum[static_cast<size_t>(v)] += t;
    ++count[static_cast<size_t>(v)];
  }
  // A stray vertex: one the copy moves farther than the box's diagonal from where its
  // neighbours' motion (the median of their displacements, per axis) puts it. No deformation a
  // box can hold stretches an edge that far; a vertex sent a million units away would fold the
  // whole fit. Refused, naming the vertex (the file's first copy of it) and the distance.
  std::vector<std::vector<int>> neighbours(static_cast<size_t>(n));
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = mesh.F(f, c), b = mesh.F(f, (c + 1) % 3);
      neighbours[static_cast<size_t>(a)].push_back(b);
      neighbours[static_cast<size_t>(b)].push_back(a);
    }
  auto displacement = [&](long v) -> Eigen::Vector3d {
    const size_t i = static_cast<size_t>(v);
    return count[i] ? Eigen::Vector3d(sum[i] / count[i] - mesh.V.row(v).transpose())
                    : Eigen::Vector3d::Zero();
  };
  auto file_index = [&](long v) {
    for (size_t r = 0; r < rest.joined.size(); ++r)
      if (rest.joined[r] == v) return static_cast<long>(r);
    return v;
  };
  for (long v = 0; v < n; ++v) {
    const size_t i = static_cast<size_t>(v);
    if (count[i] == 0 || neighbours[i].empty()) continue;
    const Eigen::Vector3d p = mesh.V.row(v).transpose();
    if (((box.to_local(p).cwiseAbs() - box.half_extents).array() > tolerance).any()) continue;
    std::vector<int>& around = neighbours[i];
    std::sort(around.begin(), around.end());
    around.erase(std::unique(around.begin(), around.end()), around.end());
    Eigen::Vector3d median;
    for (int a = 0; a < 3; ++a) {
      std::vector<double> x;
      for (int u : around) x.push_back(displacement(u)[a]);
      std::nth_element(x.begin(), x.begin() + x.size() / 2, x.end());
      median[a] = x[x.size() / 2];
    }
    const double off = (displacement(v) - median).norm();
    if (off > diagonal)
      throw Error(target_file + ": vertex " + std::to_string(file_index(v)) + " moves " +
                  shortest_text(off) + " units from where its " + std::to_string(around.size()) +
                  " neighbours' motion puts it, more than the box's diagonal (" +
                  shortest_text(diagonal) +
                  "): a stray vertex that no deformation in the box can hold; put it back in the "
                  "copy (the file's vertex order is the mesh's, from 0)");
  }
  for (long v = 0; v < n; ++v) {
    const size_t i = static_cast<size_t>(v);
    if (count[i] == 0) continue;
    const Eigen::Vector3d p = mesh.V.row(v).transpose();
    const Eigen::Vector3d t = sum[i] / count[i];
    const Eigen::Vector3d local = box.to_local(p);
    const bool inside = ((local.cwiseAbs() - box.half_extents).array() <= tolerance).all();
    const double move = (t - p).norm();
    if (!inside) {
      out.moved_outside += move > tolerance;
      continue;
    }
    out.torn += torn[i];
    out.largest_move = std::max(out.largest_move, move);
    out.sources.push_back(local);
    out.targets.push_back(box.to_local(t));
  }
  return out;
}

}  // namespace raywarp
