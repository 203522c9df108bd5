// Mesh loading (assimp) and the mesh figures: counts, welding, closedness, orientation.
#include "library/mesh.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "base/error.h"
#include "tests/mesh_fixtures.h"

namespace raywarp {
namespace {

namespace fs = std::filesystem;

// A fresh folder per test, removed afterwards.
class MeshFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("raywarp_mesh_test_" + std::to_string(::getpid()) + "_" + info->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) {
    const fs::path path = dir_ / name;
    std::ofstream(path, std::ios::binary) << text;
    return path.string();
  }
  fs::path dir_;
};

// The cube [-1, 1]^3 as six quads, counter-clockwise from outside (OBJ is 1-based).
const char* kCubeObj = R"(# cube
v -1 -1 -1
v 1 -1 -1
v -1 1 -1
v 1 1 -1
v -1 -1 1
v 1 -1 1
v -1 1 1
v 1 1 1
f 1 3 4 2
f 5 6 8 7
f 1 2 6 5
f 3 7 8 4
f 1 5 7 3
f 2 4 8 6
)";

// The same cube, 12 facets with 3 vertices each and no sharing, as STL has it.
std::string cube_stl() {
  const Mesh cube = fixtures::cube(1.0);
  std::string text = "solid cube\n";
  for (int f = 0; f < cube.F.rows(); ++f) {
    const Eigen::Vector3d n =
        (cube.vertex(f, 1) - cube.vertex(f, 0)).cross(cube.vertex(f, 2) - cube.vertex(f, 0));
    text += "facet normal " + std::to_string(n.x() / 4) + " " + std::to_string(n.y() / 4) + " " +
            std::to_string(n.z() / 4) + "\nouter loop\n";
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3d p = cube.vertex(f, c);
      text += "vertex " + std::to_string(p.x()) + " " + std::to_string(p.y()) + " " +
              std::to_string(p.z()) + "\n";
    }
    text += "endloop\nendfacet\n";
  }
  return text + "endsolid cube\n";
}

const char* kCubeOff = R"(OFF
8 6 0
-1 -1 -1
1 -1 -1
-1 1 -1
1 1 -1
-1 -1 1
1 -1 1
-1 1 1
1 1 1
4 0 2 3 1
4 4 5 7 6
4 0 1 5 4
4 2 6 7 3
4 0 4 6 2
4 1 3 7 5
)";

void expect_closed_cube(const Mesh& mesh) {
  const MeshStats stats = mesh_stats(mesh);
  EXPECT_EQ(stats.vertices, 8);
  EXPECT_EQ(stats.faces, 12);
  EXPECT_EQ(stats.boundary_edges, 0);
  EXPECT_EQ(stats.nonmanifold_edges, 0);
  EXPECT_EQ(stats.degenerate_faces, 0);
  EXPECT_TRUE(stats.closed());
  EXPECT_TRUE(stats.bounds.min().isApprox(Eigen::Vector3d(-1, -1, -1)));
  EXPECT_TRUE(stats.bounds.max().isApprox(Eigen::Vector3d(1, 1, 1)));
  // Orientation survives loading and triangulation: counter-clockwise from outside gives +8.
  EXPECT_NEAR(fixtures::signed_volume(mesh), 8.0, 1e-9);
}

TEST(Mesh, BunnyCountsAndBounds) {
  const Mesh bunny = load_mesh(RAYWARP_SOURCE_DIR "/examples/meshes/bunny.ply");
  const MeshStats stats = mesh_stats(bunny);
  EXPECT_EQ(stats.vertices, 1839);  // the PLY header's counts: no duplicates to weld
  EXPECT_EQ(stats.faces, 3674);
  EXPECT_FALSE(stats.bounds.isEmpty());
  EXPECT_GT(fixtures::signed_volume(bunny), 0.0);  // outward oriented
  const std::string line = describe(stats);
  EXPECT_NE(line.find("1839 vertices, 3674 triangles"), std::string::npos) << line;
  EXPECT_EQ(line.find('\n'), std::string::npos);
}

TEST_F(MeshFiles, ObjCubeIsWeldedTriangulatedAndClosed) {
  expect_closed_cube(load_mesh(write("cube.obj", kCubeObj)));
}

// A closed surface written inside out (every face clockwise from outside) is turned outwards, and
// says so; a correctly oriented one is left as it is.
TEST_F(MeshFiles, InsideOutClosedMeshIsTurnedOutwards) {
  std::string inside_out = kCubeObj;
  for (const auto& [from, to] :
       std::vector<std::pair<std::string, std::string>>{{"f 1 3 4 2", "f 2 4 3 1"},
                                                        {"f 5 6 8 7", "f 7 8 6 5"},
                                                        {"f 1 2 6 5", "f 5 6 2 1"},
                                                        {"f 3 7 8 4", "f 4 8 7 3"},
                                                        {"f 1 5 7 3", "f 3 7 5 1"},
                                                        {"f 2 4 8 6", "f 6 8 4 2"}})
    inside_out.replace(inside_out.find(from), from.size(), to);
  const Mesh turned = load_mesh(write("inside_out.obj", inside_out));
  EXPECT_TRUE(turned.reoriented);
  EXPECT_NEAR(signed_volume(turned), 8.0, 1e-12);
  EXPECT_NE(describe(mesh_stats(turned)).find("turned outwards"), std::string::npos);
  const Mesh cube = load_mesh(write("cube.obj", kCubeObj));
  EXPECT_FALSE(cube.reoriented);
  EXPECT_NEAR(signed_volume(cube), 8.0, 1e-12);
  EXPECT_EQ(describe(mesh_stats(cube)).find("turned"), std::string::npos);
}

TEST_F(MeshFiles, StlCubeIsWeldedAndClosed) {
  // 36 STL corners, each with its facet's normal: only positions say which are the same vertex.
  expect_closed_cube(load_mesh(write("cube.stl", cube_stl())));
}

TEST_F(MeshFiles, OffCubeIsClosed) { expect_closed_cube(load_mesh(write("cube.off", kCubeOff))); }

TEST_F(MeshFiles, ObjGroupsAreMergedIntoOneSurface) {
  // Two objects sharing the cube's edges by position only: merged and welded, closed.
  std::string text = kCubeObj;
  text.insert(text.find("f 1 3 4 2"), "o bottom\n");
  text.insert(text.find("f 1 2 6 5"), "o sides\n");
  expect_closed_cube(load_mesh(write("groups.obj", text)));
}

TEST_F(MeshFiles, GltfNodeTransformsAreApplied) {
  // One triangle instanced by two nodes: translated by (10, 0, 0), and mirrored in x (which
  // must not turn it clockwise). Buffer: 3 float positions then 3 uint16 indices (+2 pad).
  const char* kBuffer =  // base64 of (0,0,0), (1,0,0), (0,1,0), then 0 1 2
      "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAABAAIAAAA=";
  const std::string gltf = std::string(R"({
  "asset": {"version": "2.0"},
  "scene": 0,
  "scenes": [{"nodes": [0, 1]}],
  "nodes": [{"mesh": 0, "translation": [10, 0, 0]}, {"mesh": 0, "scale": [-1, 1, 1]}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
  "buffers": [{"byteLength": 44, "uri": "data:application/octet-stream;base64,)") +
                           kBuffer + R"("}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                  {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
  "accessors": [
    {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
     "min": [0, 0, 0], "max": [1, 1, 0]},
    {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}]
})";
  const Mesh mesh = load_mesh(write("triangle.gltf", gltf));
  const MeshStats stats = mesh_stats(mesh);
  ASSERT_EQ(stats.faces, 2);
  EXPECT_EQ(stats.vertices, 6);  // no corner of one instance coincides with the other's
  EXPECT_NEAR(stats.bounds.min().x(), -1.0, 1e-12);
  EXPECT_NEAR(stats.bounds.max().x(), 11.0, 1e-12);
  for (int f = 0; f < 2; ++f) {
    const Eigen::Vector3d n =
        (mesh.vertex(f, 1) - mesh.vertex(f, 0)).cross(mesh.vertex(f, 2) - mesh.vertex(f, 0));
    EXPECT_GT(n.z(), 0.0) << "triangle " << f << " was turned over";
  }
}

TEST_F(MeshFiles, OpenCubeHasBoundaryEdges) {
  std::string text = kCubeObj;
  text.erase(text.find("f 2 4 8 6"));  // the x = +1 face
  const MeshStats stats = mesh_stats(load_mesh(write("open.obj", text)));
  EXPECT_EQ(stats.faces, 10);
  EXPECT_EQ(stats.boundary_edges, 4);
  EXPECT_EQ(stats.nonmanifold_edges, 0);
  EXPECT_FALSE(stats.closed());
  const std::string line = describe(stats);
  EXPECT_NE(line.find("open (4 boundary edges, 0 non-manifold)"), std::string::npos) << line;
}

TEST_F(MeshFiles, MissingFileNamesThePath) {
  const std::string path = (dir_ / "no_such_mesh.ply").string();
  try {
    load_mesh(path);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST_F(MeshFiles, GarbageFileNamesThePath) {
  for (const char* name : {"garbage.ply", "garbage.stl", "garbage.obj", "garbage.off"}) {
    const std::string path = write(name, "\x01\x02 this is not a mesh \xff\xfe\n");
    try {
      load_mesh(path);
      FAIL() << name << ": no error";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
}

TEST_F(MeshFiles, PointsOnlyHasNoTriangles) {
  const std::string path = write("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\np 1 2 3\n");
  try {
    load_mesh(path);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no triangles"), std::string::npos) << e.what();
  }
}

// A binary little-endian PLY of the cube fixture: 8 vertices (12 bytes each), 12 faces (13 bytes).
std::string cube_binary_ply() {
  const Mesh cube = fixtures::cube(1.0);
  std::string s =
      "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(cube.V.rows()) +
      "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
      std::to_string(cube.F.rows()) + "\nproperty list uchar int vertex_indices\nend_header\n";
  for (int v = 0; v < cube.V.rows(); ++v)
    for (int a = 0; a < 3; ++a) {
      const float x = static_cast<float>(cube.V(v, a));
      s.append(reinterpret_cast<const char*>(&x), 4);
    }
  for (int f = 0; f < cube.F.rows(); ++f) {
    s.push_back('\3');
    for (int c = 0; c < 3; ++c) {
      const int32_t i = cube.F(f, c);
      s.append(reinterpret_cast<const char*>(&i), 4);
    }
  }
  return s;
}

const char* kTriangleAsciiPlyHeader =
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
    "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";

TEST_F(MeshFiles, BinaryPlyCubeLoads) {
  expect_closed_cube(load_mesh(write("cube.ply", cube_binary_ply())));
}

// Files that lie about their contents: each is refused with a message naming the file and the
// element, row or vertex, before assimp sees it (a binary PLY cut short crashed assimp's
// triangulation: its PLY reader hands on faces with indices of garbage).
TEST_F(MeshFiles, InconsistentFilesAreRefusedNamingTheElement) {
  const std::string ply = cube_binary_ply();
  std::string nan_ply = ply;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(&nan_ply[ply.find("end_header\n") + 11 + 5 * 12 + 4], &nan, 4);  // vertex 5's y
  std::string far_index = ply;
  const int32_t nine = 9;
  std::memcpy(&far_index[ply.size() - 4], &nine, 4);  // face 11's last corner
  std::string cube_stl_binary(80, ' ');
  const uint32_t facets = 12;
  cube_stl_binary.append(reinterpret_cast<const char*>(&facets), 4);
  cube_stl_binary.append(50 * 5, '\0');  // 5 of 12 facets
  struct Case {
    const char* name;
    std::string text;
    std::vector<std::string> needles;
  };
  const std::vector<Case> cases = {
      {"cut_binary.ply", ply.substr(0, ply.size() - 100), {"PLY face 4", "cut short"}},
      {"cut_by_one_byte.ply", ply.substr(0, ply.size() - 1), {"PLY face 11", "cut short"}},
      {"cut_in_header_counts.ply",
       ply.substr(0, ply.find("end_header") + 30),
       {"declares 8 vertex elements", "cut short"}},
      {"nan.ply", nan_ply, {"PLY vertex 5 has y = nan", "finite"}},
      {"far_index.ply", far_index, {"PLY face 11 uses vertex 9, allowed [0, 8)"}},
      {"short_body.ply",
       std::string(kTriangleAsciiPlyHeader) + "0 0 0\n1 0 0\n0 1 0\n",
       {"PLY face 0", "cut short"}},
      {"bad_index.ply",
       std::string(kTriangleAsciiPlyHeader) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
       {"PLY face 0 (line 13) uses vertex 3, allowed [0, 3)"}},
      {"overflow.ply",
       std::string(kTriangleAsciiPlyHeader) + "0 0 0\n1 0 0\n0 1e39 0\n3 0 1 2\n",
       {"PLY vertex 2 has y = 1e+39", "float range"}},
      {"no_end_header.ply", "ply\nformat ascii 1.0\nelement vertex 3\n", {"no end_header"}},
      {"overflow.obj",
       "v 0 0 0\nv 1 0 0\nv 0 1e39 0\nf 1 2 3\n",
       {"OBJ vertex 3 (line 3) has y = 1e+39", "float range"}},
      {"nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", {"OBJ vertex 2 (line 2) has x = nan"}},
      {"far_index.obj",
       "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 7\n",
       {"OBJ line 5", "uses vertex 7, but the file has 3 vertices"}},
      {"zero_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", {"OBJ line 4", "non-zero"}},
      {"degenerate.obj",
       "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\nf 3 2 1\n",
       {"all 2 triangles are degenerate"}},
      {"cut.stl", cube_stl_binary, {"declares 12 facets", "cut short"}},
      {"cut.off", "OFF\n8 6 0\n-1 -1 -1\n1 -1 -1\n", {"OFF vertex 2 of 8", "cut short"}},
      {"far_index.off",
       "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
       {"OFF face 0 (line 6) uses vertex 3, allowed [0, 3)"}},
      {"not_xz.ply.xz", ply, {"not a valid xz file"}},
  };
  for (const Case& c : cases) {
    const std::string path = write(c.name, c.text);
    try {
      load_mesh(path);
      ADD_FAILURE() << c.name << ": no error";
    } catch (const Error& e) {
      const std::string message = e.what();
      EXPECT_EQ(message.rfind(path + ": cannot read mesh: ", 0), 0u) << message;
      for (const std::string& n : c.needles)
        EXPECT_NE(message.find(n), std::string::npos) << c.name << ": " << message;
    }
  }
}

// Polygons are triangulated inside their outline: a concave L-shaped hexagon and a concave quad
// (a dart) keep their area, and every triangle faces the polygon's normal (+z).
TEST_F(MeshFiles, ConcavePolygonsAreTriangulatedInsideTheirOutline) {
  const std::string obj =
      "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\n"  // L, area 3
      "v 5 0 0\nv 6 1 0\nv 7 0 0\nv 6 3 0\n"                    // dart, area 2
      "f 1 2 3 4 5 6\nf 7 8 9 10\n";
  const Mesh mesh = load_mesh(write("concave.obj", obj));
  ASSERT_EQ(mesh.F.rows(), 4 + 2);
  double area = 0;
  for (int f = 0; f < mesh.F.rows(); ++f) {
    const Eigen::Vector3d n =
        (mesh.vertex(f, 1) - mesh.vertex(f, 0)).cross(mesh.vertex(f, 2) - mesh.vertex(f, 0));
    EXPECT_GT(n.z(), 0) << "triangle " << f << " faces away or is empty";
    area += 0.5 * n.z();
  }
  EXPECT_NEAR(area, 3.0 + 2.0, 1e-12);
}

// PLY faces of one and two corners (points and lines) beside triangles and quads: the triangles
// and quads load, the rest is left out (assimp's triangulation aborted on this file).
TEST_F(MeshFiles, PointAndLineFacesBesidePolygonsAreLeftOut) {
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
      "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 2\n2 0 1\n3 0 1 4\n4 0 1 2 3\n";
  const Mesh mesh = load_mesh(write("mixed.ply", ply));
  EXPECT_EQ(mesh.F.rows(), 1 + 2);
}

// A mesh stored xz-compressed (NAME.ply.xz) reads as the file inside.
TEST_F(MeshFiles, XzCompressedPlyLoads) {
  const std::string plain = write("cube.ply", cube_binary_ply());
  ASSERT_EQ(std::system(("xz -k " + plain).c_str()), 0);
  expect_closed_cube(load_mesh(plain + ".xz"));
}

TEST(Mesh, NonManifoldAndDegenerateEdgesAreCounted) {
  // Three triangles on the edge (0, 1), and one zero-area triangle (collinear corners).
  Mesh mesh;
  mesh.V.resize(6, 3);
  mesh.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, -1, 0, 2, 0, 0;
  mesh.F.resize(4, 3);
  mesh.F << 0, 1, 2, 1, 0, 3, 0, 1, 4, 0, 1, 5;
  const MeshStats stats = mesh_stats(mesh);
  EXPECT_EQ(stats.nonmanifold_edges, 1);  // (0, 1) four times
  EXPECT_EQ(stats.degenerate_faces, 1);   // (0, 1, 5)
  // Every other edge once: (1,2) (2,0) (0,3) (3,1) (1,4) (4,0) (1,5) (5,0).
  EXPECT_EQ(stats.boundary_edges, 8);
  EXPECT_FALSE(stats.closed());
}

TEST(Mesh, VertexNormalsOfASphereAreRadial) {
  // A triangle inscribed in a sphere of radius r has its normal along the axis of its
  // circumcircle (radius rho), at angle asin(rho / r) from the radius at each of its corners.
  // An area-weighted mean of such normals stays in that cone: the bound is the widest cone.
  const double r = 2.0;
  const Mesh sphere = fixtures::icosphere(r, 3);
  double cone = 0;
  for (int f = 0; f < sphere.F.rows(); ++f) {
    const Eigen::Vector3d a = sphere.vertex(f, 0), b = sphere.vertex(f, 1), c = sphere.vertex(f, 2);
    const double rho =
        (b - c).norm() * (c - a).norm() * (a - b).norm() / (2.0 * (b - a).cross(c - a).norm());
    cone = std::max(cone, std::asin(rho / r));
  }
  const auto N = vertex_normals(sphere);
  for (int v = 0; v < sphere.V.rows(); ++v) {
    const Eigen::RowVector3d radial = sphere.V.row(v).normalized();
    EXPECT_NEAR(N.row(v).norm(), 1.0, 1e-12);
    EXPECT_GE(N.row(v).dot(radial), std::cos(cone) - 1e-12) << "vertex " << v;
  }
}

TEST(Mesh, VertexNormalsOfAFlatSquareAndAnIsolatedVertex) {
  Mesh mesh;
  mesh.V.resize(5, 3);
  mesh.V << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 5, 5, 5;
  mesh.F.resize(2, 3);
  mesh.F << 0, 1, 2, 0, 2, 3;
  const auto N = vertex_normals(mesh);
  for (int v = 0; v < 4; ++v) EXPECT_EQ(N.row(v), Eigen::RowVector3d(0, 0, 1));
  EXPECT_EQ(N.row(4), Eigen::RowVector3d(0, 0, 0));
}

}  // namespace
}  // namespace raywarp
