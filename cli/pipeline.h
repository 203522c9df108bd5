// From a validated scene to what the renderer needs: the mesh, and per box its distance grid,
// its deformation texture, its deformer and what raywarp has to say about it (folds, seams).
// The command line, the tests and the benchmarks share this one path.
#pragma once
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

#include "library/deformation_bake.h"
#include "deformers/control_points.h"
#include "deformers/deformer.h"
#include "library/bake_cache.h"
#include "gl/renderer.h"
#include "library/mesh.h"
#include "library/scene.h"
#include "library/textures.h"

namespace raywarp {

struct PreparedBox {
  BoxTextures textures;
  std::shared_ptr<const Deformer> deformer;
  FoldReport folds;
  double texture_error = 0.0;  // deformation_texture_error, object units
  InverseResidual residual;    // measure_inverse_residual of the baked texture
  std::vector<std::string> warnings;
};

struct PreparedScene {
  Mesh mesh;
  MeshStats stats;
  std::vector<PreparedBox> boxes;
  int bakes = 0;  // textures baked (not read from the bake cache)
  std::vector<BoxTextures> textures() const;
};

// The deformer a scene box asks for; errors name the scene file and the field.
// `warnings`, when given, receives what building it found worth saying (control points whose
// targets leave the box, ...).
std::shared_ptr<const Deformer> make_deformer(const Scene& scene, size_t box_index,
                                              std::vector<std::string>* warnings = nullptr);

// Loads the mesh and bakes every box, logging stages, times and warnings to `log`. With a
// cache, every texture (and the figures measured on it) whose inputs are unchanged is read from
// it instead of baked, and every bake is stored in it.
// `centre_on_lower_faces` bakes the deformation textures with texel centres on the box's lower
// faces (bake_deformation), as the animation by a texture map needs.
PreparedScene prepare_scene(const Scene& scene, std::ostream& log, BakeCache* cache = nullptr,
                            bool centre_on_lower_faces = false);

// The cache key of a box's deformers: their every parameter and the box's half extents.
std::string deformer_key(const BoxSpec& spec);

// Edges of the mesh used by one triangle (boundary) or by three or more (non-manifold) whose
// midpoints lie in the box: there the mesh has no well-defined inside.
struct OpenEdges {
  long boundary = 0, nonmanifold = 0;
  bool any() const { return boundary + nonmanifold > 0; }
};
OpenEdges open_edges_in_box(const Mesh& mesh, const Box& box);

// Median frame time (ms) of `frames` frames of width x height after one warm-up frame, which
// pays for llvmpipe's compilation of the shader variants at their first draw.
double frame_median(gl::Renderer& renderer, const Camera& camera, int width, int height,
                    const RenderSettings& settings, int frames);

// Faces of the box, as "-x", "+y", ..., that the mesh crosses where F is not the identity.
std::vector<std::string> torn_faces(const Mesh& mesh, const Box& box, const Deformer& deformer);

}  // namespace raywarp
