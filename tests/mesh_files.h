// Mesh files written by tests: a temporary folder, a PLY of a polygon soup, a glTF 2.0 with
// morph targets.
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "library/mesh_file.h"

namespace raywarp::testing {

// A fresh folder under the system's temporary folder, removed afterwards.
struct Folder {
  std::filesystem::path dir;
  Folder() {
    dir = std::filesystem::temp_directory_path() /
          ("raywarp_mesh_files_" + std::to_string(std::random_device()()));
    std::filesystem::create_directories(dir);
  }
  ~Folder() { std::filesystem::remove_all(dir); }
  std::filesystem::path path() const { return dir; }
};

inline void write_ply(const std::string& path, const PolygonSoup& soup) {
  std::ofstream out(path);
  out.precision(17);
  out << "ply\nformat ascii 1.0\nelement vertex " << soup.vertices.size()
      << "\nproperty double x\nproperty double y\nproperty double z\nelement face "
      << soup.sizes.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const auto& v : soup.vertices) out << v[0] << " " << v[1] << " " << v[2] << "\n";
  size_t next = 0;
  for (int size : soup.sizes) {
    out << size;
    for (int c = 0; c < size; ++c) out << " " << soup.corners[next++];
    out << "\n";
  }
}

inline std::string base64(const std::string& bytes) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned n = (unsigned char)bytes[i] << 16 | (unsigned char)bytes[i + 1] << 8 |
                       (unsigned char)bytes[i + 2];
    for (int s = 18; s >= 0; s -= 6) out += k[(n >> s) & 63];
  }
  if (i < bytes.size()) {
    unsigned n = (unsigned char)bytes[i] << 16;
    if (i + 1 < bytes.size()) n |= (unsigned char)bytes[i + 1] << 8;
    out += k[(n >> 18) & 63];
    out += k[(n >> 12) & 63];
    out += i + 1 < bytes.size() ? k[(n >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

// A glTF 2.0 file (buffer embedded as a data URI) of one mesh, the bunny's triangles, with one
// morph target per `moved` soup (positions given absolute, stored as displacements).
inline void write_gltf(const std::string& path, const PolygonSoup& base,
                       const std::vector<PolygonSoup>& moved) {
  std::string bin;
  auto put_float = [&](float f) { bin.append(reinterpret_cast<const char*>(&f), 4); };
  const size_t n = base.vertices.size();
  nlohmann::json accessors = nlohmann::json::array(), views = nlohmann::json::array();
  auto add_vec3 = [&](const std::vector<std::array<double, 3>>& v, bool displacement_of_base) {
    const size_t offset = bin.size();
    std::array<double, 3> lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
    for (size_t i = 0; i < n; ++i)
      for (int a = 0; a < 3; ++a) {
        const float f =
            static_cast<float>(displacement_of_base ? v[i][a] - base.vertices[i][a] : v[i][a]);
        put_float(f);
        lo[a] = std::min(lo[a], double(f));
        hi[a] = std::max(hi[a], double(f));
      }
    views.push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", 12 * n}});
    accessors.push_back({{"bufferView", views.size() - 1},
                         {"componentType", 5126},
                         {"count", n},
                         {"type", "VEC3"},
                         {"min", lo},
                         {"max", hi}});
    return accessors.size() - 1;
  };
  const size_t position = add_vec3(base.vertices, false);
  nlohmann::json targets = nlohmann::json::array();
  for (const PolygonSoup& m : moved) targets.push_back({{"POSITION", add_vec3(m.vertices, true)}});
  const size_t index_offset = bin.size();
  size_t indices = 0;
  for (size_t next = 0, f = 0; f < base.sizes.size(); next += base.sizes[f], ++f)
    for (int c = 1; c + 1 < base.sizes[f]; ++c)
      for (int k : {0, c, c + 1}) {
        const std::uint32_t idx = static_cast<std::uint32_t>(base.corners[next + k]);
        bin.append(reinterpret_cast<const char*>(&idx), 4);
        ++indices;
      }
  views.push_back({{"buffer", 0}, {"byteOffset", index_offset}, {"byteLength", 4 * indices}});
  accessors.push_back({{"bufferView", views.size() - 1},
                       {"componentType", 5125},
                       {"count", indices},
                       {"type", "SCALAR"}});
  nlohmann::json doc = {{"asset", {{"version", "2.0"}}},
                        {"scene", 0},
                        {"scenes", {{{"nodes", {0}}}}},
                        {"nodes", {{{"mesh", 0}}}},
                        {"meshes",
                         {{{"primitives",
                            {{{"attributes", {{"POSITION", position}}},
                              {"indices", accessors.size() - 1},
                              {"targets", targets}}}},
                           {"weights", std::vector<double>(moved.size(), 0.0)}}}},
                        {"buffers",
                         {{{"byteLength", bin.size()},
                           {"uri", "data:application/octet-stream;base64," + base64(bin)}}}},
                        {"bufferViews", views},
                        {"accessors", accessors}};
  std::ofstream(path) << doc.dump();
}

}  // namespace raywarp::testing
