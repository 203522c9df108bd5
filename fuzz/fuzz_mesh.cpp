// libFuzzer target: a mesh file as load_mesh reads one (the checks of library/mesh_file.h, then
// assimp, welding and the mesh figures). The first byte picks the format (ply, obj, stl, off);
// the rest is the file. Any exception but raywarp::Error is a bug, as is a crash or a hang.
#include <cstddef>
#include <cstdint>
#include <string>

#include "base/error.h"
#include "library/mesh.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const char* const kFormats[] = {"ply", "obj", "stl", "off"};
  if (size < 2) return 0;
  const std::string format = kFormats[data[0] % 4];
  const std::string bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  try {
    const raywarp::Mesh mesh = raywarp::load_mesh_bytes(bytes, format, "fuzz." + format);
    (void)raywarp::describe(raywarp::mesh_stats(mesh));
  } catch (const raywarp::Error&) {
  }
  return 0;
}
