// OpenVDB export (library/vdb_export.h), read back by OpenVDB's own Python module (pyopenvdb,
// through Debian's /usr/bin/python3) and vdb_print: grid names, types and classes, exact float32
// values, active voxels, world positions of voxel centres and metadata.
#include "library/vdb_export.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "base/error.h"
#include "tests/temp_folder.h"

namespace raywarp {
namespace {

const char* const kPython = "/usr/bin/python3";  // Debian's, with python3-openvdb

std::string run(const std::string& command, bool& ok) {
  std::string out;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) {
    ok = false;
    return out;
  }
  char buffer[65536];
  size_t n;
  while ((n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0) out.append(buffer, n);
  ok = ::pclose(pipe) == 0;
  return out;
}

bool have_pyopenvdb() {
  if (!std::filesystem::exists(kPython)) return false;
  bool ok = false;
  run(std::string(kPython) + " -c 'import pyopenvdb' 2>/dev/null", ok);
  return ok;
}

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

// Prints every grid's name, value type, class, vector type and active voxel count, then its
// values (float.hex, exact) and the world positions (repr, exact) of the voxels on the command
// line, then the file's metadata.
const char* const kReader = R"(import sys
import pyopenvdb as vdb
grids, meta = vdb.readAll(sys.argv[1])
points = [tuple(int(x) for x in p.split(',')) for p in sys.argv[2:]]
for g in grids:
    print('grid', g.name, g.valueTypeName, g.gridClass.replace(' ', '_'),
          str(g.metadata.get('vector_type', '-')).replace(' ', '_'), g.activeVoxelCount(),
          'background', ' '.join(float(x).hex() for x in (g.background if isinstance(g.background, tuple) else (g.background,))))
    acc = g.getConstAccessor()
    for p in points:
        v = acc.getValue(p)
        v = v if isinstance(v, tuple) else (v,)
        print('value', g.name, *p, int(acc.isValueOn(p)), *(float(x).hex() for x in v))
        print('world', g.name, *p, *(repr(x) for x in g.transform.indexToWorld(p)))
    for k in sorted(g.metadata):
        if k.startswith('raywarp'):
            print('gridmeta', g.name, k, g.metadata[k])
for k in sorted(meta):
    print('filemeta', k, meta[k])
)";

class VdbExport : public TempFolderTest {
 protected:
  // Index (i, j, k) to world: a rotation, a non-uniform scale and a translation.
  static Eigen::Matrix4d transform() {
    Eigen::Affine3d a = Eigen::Translation3d(1.5, -2.0, 3.25) *
                        Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()) *
                        Eigen::Scaling(0.5, 1.25, 2.0);
    return a.matrix();
  }
  // A fog volume (5 x 4 x 3, value i + 10 j + 100 k: voxel (0, 0, 0) equals the background 0),
  // a displacement (random, every 7th voxel the background) and a level set.
  static std::vector<VdbGrid> grids() {
    std::vector<VdbGrid> g(3);
    g[0].volume.name = "density";
    g[0].volume.dims = {5, 4, 3};
    for (int k = 0; k < 3; ++k)
      for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 5; ++i) g[0].volume.values.push_back(i + 10 * j + 100 * k + 0.125f);
    g[0].volume.values[0] = 0;
    g[0].index_to_world = transform();

    std::mt19937 rng(5);
    std::uniform_real_distribution<float> value(-1.0f, 1.0f);
    g[1].name = "deformation";
    g[1].volume.dims = {6, 5, 4};
    g[1].volume.channels = 3;
    g[1].volume.values.resize(g[1].volume.texels() * 3);
    for (float& x : g[1].volume.values) x = value(rng);
    for (size_t t = 0; t < g[1].volume.texels(); t += 7)
      for (int c = 0; c < 3; ++c) g[1].volume.values[t * 3 + c] = 0.25f;
    g[1].background = 0.25f;
    g[1].vector_is_displacement = true;
    g[1].index_to_world = transform();

    g[2].name = "distance";
    g[2].volume.dims = {4, 4, 4};
    for (int k = 0; k < 4; ++k)
      for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i)
          g[2].volume.values.push_back(std::min(i - 1.5f, 3.0f * (k - 2)));
    g[2].level_set = true;
    g[2].background = 3;
    g[2].index_to_world = Eigen::Matrix4d::Identity();
    g[2].index_to_world.topLeftCorner<3, 3>() *= 0.1;
    return g;
  }
};

TEST_F(VdbExport, PyopenvdbReadsGridsValuesTransformsAndMetadata) {
  if (!have_pyopenvdb())
    GTEST_SKIP() << "/usr/bin/python3 cannot import pyopenvdb (Debian package python3-openvdb)";
  const std::vector<VdbGrid> in = grids();
  const std::string file = path("out.vdb");
  write_vdb(file, in, {{"raywarp_version", "1.2"}, {"raywarp_box", "[0, 1] x [0, 2] x [0, 3]"}});
  EXPECT_EQ(listing(), std::vector<std::string>{"out.vdb"});
  {
    std::ofstream script(path("read.py"));
    script << kReader;
  }
  std::string command = std::string(kPython) + " " + path("read.py") + " " + file;
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 6; ++i)
        command += ' ' + std::to_string(i) + ',' + std::to_string(j) + ',' + std::to_string(k);
  bool ok = false;
  const std::string out = run(command + " 2>&1", ok);
  ASSERT_TRUE(ok) << out;

  std::map<std::string, std::string> header;
  std::map<std::string, std::string> file_meta, grid_meta;
  int values = 0, worlds = 0;
  std::istringstream lines(out);
  std::string line;
  while (std::getline(lines, line)) {
    std::istringstream words(line);
    std::string kind, name;
    words >> kind >> name;
    if (kind == "grid") {
      std::string rest;
      std::getline(words, rest);
      header[name] = rest;
    } else if (kind == "filemeta" || kind == "gridmeta") {
      std::string key = name, text;
      if (kind == "gridmeta") {
        words >> key;
        key = name + "/" + key;
      }
      std::getline(words, text);
      (kind == "filemeta" ? file_meta : grid_meta)[key] = text.substr(1);
    } else if (kind == "value" || kind == "world") {
      int i, j, k;
      words >> i >> j >> k;
      const VdbGrid* g = nullptr;
      for (const VdbGrid& candidate : in)
        if ((candidate.name.empty() ? candidate.volume.name : candidate.name) == name)
          g = &candidate;
      ASSERT_NE(g, nullptr) << line;
      const TextureVolume& v = g->volume;
      const bool inside = i < v.dims.x() && j < v.dims.y() && k < v.dims.z();
      if (kind == "value") {
        int on;
        words >> on;
        for (int c = 0; c < v.channels; ++c) {
          std::string hex;
          words >> hex;
          const double got = std::strtod(hex.c_str(), nullptr);
          const float expected = inside ? v.at(i, j, k, c) : g->background;
          EXPECT_EQ(got, static_cast<double>(expected)) << line;
        }
        bool background = true;
        for (int c = 0; c < v.channels; ++c)
          background = background && (!inside || v.at(i, j, k, c) == g->background);
        EXPECT_EQ(on, background ? 0 : 1) << line;
        ++values;
      } else {
        const Eigen::Vector3d expected =
            (g->index_to_world * Eigen::Vector4d(i, j, k, 1)).head<3>();
        Eigen::Vector3d got;
        words >> got.x() >> got.y() >> got.z();
        EXPECT_LE((got - expected).norm(), 1e-9 * std::max(1.0, expected.norm()))
            << line << "\nexpected " << expected.transpose();
        ++worlds;
      }
    }
  }
  EXPECT_EQ(values, 3 * 120);
  EXPECT_EQ(worlds, 3 * 120);
  // Active voxels: all but those equal to the background (1 of 60; 18 of 120; the 3s of 64).
  int distance_active = 0;
  for (float x : in[2].volume.values) distance_active += x != 3.0f;
  EXPECT_EQ(header["density"], " float fog_volume - 59 background 0x0.0p+0");
  EXPECT_EQ(header["deformation"],
            " vec3s unknown contravariant_relative 102 background 0x1.0000000000000p-2 "
            "0x1.0000000000000p-2 0x1.0000000000000p-2");
  EXPECT_EQ(header["distance"], " float level_set - " + std::to_string(distance_active) +
                                    " background 0x1.8000000000000p+1");
  EXPECT_EQ(header.size(), 3u) << out;
  EXPECT_EQ(file_meta["raywarp_version"], "1.2");
  EXPECT_EQ(file_meta["raywarp_box"], "[0, 1] x [0, 2] x [0, 3]");
  EXPECT_EQ(grid_meta["deformation/raywarp_version"], "1.2");
}

TEST_F(VdbExport, VdbPrintListsGridsAndMetadata) {
  if (!std::filesystem::exists("/usr/bin/vdb_print"))
    GTEST_SKIP() << "vdb_print is missing (Debian package libopenvdb-tools)";
  const std::string file = path("out.vdb");
  write_vdb(file, grids(), {{"raywarp_version", "1.2"}, {"raywarp_source", "scene.json"}});
  bool ok = false;
  const std::string out = run("/usr/bin/vdb_print -l -m " + file + " 2>&1", ok);
  ASSERT_TRUE(ok) << out;
  for (const char* text : {"density", "deformation", "distance", "raywarp_version: 1.2",
                           "raywarp_source: scene.json", "fog volume", "level set", "vec3s"})
    EXPECT_NE(out.find(text), std::string::npos) << text << " not in\n" << out;
}

TEST_F(VdbExport, BadInputNamesThePathTheGridAndWhatIsAllowed) {
  const std::string file = path("bad.vdb");
  std::vector<VdbGrid> g = grids();
  g[0].volume.channels = 4;
  EXPECT_EQ(message_of([&] { write_vdb(file, g, {}); }),
            file + ": grid 0 (\"density\"): channels = 4: must be 1 (FloatGrid) or 3 (Vec3SGrid)");
  g = grids();
  g[1].index_to_world(3, 0) = 0.5;
  EXPECT_NE(message_of([&] { write_vdb(file, g, {}); }).find("last row (0, 0, 0, 1)"),
            std::string::npos);
  g = grids();
  g[1].index_to_world.col(2).setZero();
  EXPECT_NE(message_of([&] { write_vdb(file, g, {}); }).find("singular"), std::string::npos);
  g = grids();
  g[2].name = "density";
  EXPECT_NE(message_of([&] { write_vdb(file, g, {}); }).find("duplicate name"), std::string::npos);
  g = grids();
  g[0].volume.values.pop_back();
  EXPECT_NE(message_of([&] { write_vdb(file, g, {}); }).find("59 values: must be 60"),
            std::string::npos);
  EXPECT_NE(message_of([&] {
              write_vdb(path("no/such/out.vdb"), grids(), {});
            }).find(path("no/such/out.vdb") + ": cannot write OpenVDB file"),
            std::string::npos);
  EXPECT_TRUE(listing().empty());
}

}  // namespace
}  // namespace raywarp
