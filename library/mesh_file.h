// Reading a mesh file into memory and checking it before a parser trusts it. assimp reads
// element counts and indices as the file states them: a binary PLY cut short makes it read past
// the body and hand faces with indices of garbage to its post-processing, which crashes. The
// checks here walk the body of every PLY, OBJ, STL and OFF file first: element counts against the
// bytes there are, face indices against the vertex count, coordinates finite and within float
// range. Every error names the file and the element, row or vertex.
#pragma once
#include <array>
#include <cstddef>
#include <string>
#include <vector>

namespace raywarp {

// The largest mesh file raywarp reads (after xz decompression): the file is held in memory whole
// while assimp reads it.
constexpr size_t kMaxMeshFileBytes = size_t(2) << 30;

struct MeshFileBytes {
  std::string bytes;
  std::string format;  // the lower-case extension that names the format: "ply", "obj", "stl", ...
};

// Reads `path` whole; NAME.EXT.xz is decompressed (the format is then EXT). Throws Error naming
// the file when it cannot be read, is not valid xz, or is larger than kMaxMeshFileBytes.
MeshFileBytes read_mesh_file(const std::string& path);

// True for the formats check_mesh_bytes walks (ply, obj, stl, off).
bool mesh_format_is_checked(const std::string& format);

// Walks a PLY, OBJ, STL or OFF file's body and throws Error (naming `path`) on the first
// inconsistency; other formats pass unchecked. Allocates nothing in proportion to the counts a
// header declares.
void check_mesh_bytes(const std::string& bytes, const std::string& format, const std::string& path);

// Vertices and polygons as a file lists them: polygon i has sizes[i] corners, the next ones of
// `corners` (indices into `vertices`).
struct PolygonSoup {
  std::vector<std::array<double, 3>> vertices;
  std::vector<int> corners;
  std::vector<int> sizes;
};

// Reads a PLY file (ASCII or binary, either byte order) with the walk of check_mesh_bytes: x, y, z
// of element vertex, and the vertex_indices (or vertex_index) lists of element face; every other
// element and property is read past. raywarp reads PLY itself: assimp's PLY reader reads past
// its buffer on some malformed binary files. Throws Error naming the file and the element.
PolygonSoup read_ply(const std::string& bytes, const std::string& path);

}  // namespace raywarp
