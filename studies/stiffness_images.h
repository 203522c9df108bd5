// The image part of `raywarp study --stiffness` (docs/physics.md#images-against-ks): one
// simulation scene (examples/bunny_simulation.json) run at a range of spring stiffnesses, each
// final state rendered by the three routes of the seed papers and measured against the exact
// ground truth of the same state:
//  - image space: the simulation's deformation texture D = F^-1 - id, baked and ray cast
//    (gl::Renderer);
//  - object space: Mosegaard & Sørensen's mappings (library/surface_mapping.h), the mesh's
//    vertices in the box bound to the body's boundary surface at rest (triangle basis and
//    interpolated basis), moved by the state in a vertex shader and rasterised
//    (gl::SurfaceMappingRenderer); vertices outside the box stay put;
//  - the tetrahedral route: the body's tetrahedra mapped by F and walked by the tetrahedral ray
//    caster in surface mode (library/tet_body.h, gl::TetSceneRenderer);
//  - the ground truth: the mesh split at the box faces, subdivided to a quarter voxel and mapped
//    by the state's exact F (verify/ground_truth.h), rasterised on the CPU.
// Per stiffness and route: silhouette IoU, the share of common pixels whose depth is off by more
// than 1 % of the deformed mesh's diagonal, the mean depth error, and the median frame time at
// the timing size; for object space also the vertex error |mapped - F(vertex)| over the vertices
// in the box; for image space the bake of D (texels, MiB, seconds, interpolation error); the GPU
// memory each route holds; for the tetrahedral route its tetrahedra and the cells' split.
// Needs a current OpenGL context.
#pragma once
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

namespace raywarp {

struct StiffnessImageOptions {
  std::filesystem::path scene;  // a scene with one simulation box
  std::filesystem::path out;    // images.csv, images.svg and the PNGs (images/ below it)
  std::vector<double> ks;       // the stiffnesses, each replacing the scene's
  int size = 256;               // image side of the error figures
  int timing_size = 512;        // image side of the frame times
  int frames = 5;               // timed frames per route (median)
};

// The header of images.csv.
extern const char* const kStiffnessImagesCsvHeader;

// Runs the renders, writes images.csv, images.svg and images/ks_<ks>_{image,object,tets,truth}.png
// under options.out, and returns the report's markdown section. Progress on `progress`. Throws
// Error when the scene has not exactly one box with a simulation deformer.
std::string run_stiffness_images(const StiffnessImageOptions& options, std::ostream& progress);

}  // namespace raywarp
