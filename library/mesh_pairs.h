// The vertex pairs a from_mesh deformer fits: the scene's mesh and a deformed copy of it (another
// mesh file with the same vertices in the same order, or a morph target of a glTF), matched by
// the files' own vertex order, so that vertices the reader joins (identical positions: an STL's
// corners, a glTF's seams) map back to their copies in the target.
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

#include "base/box.h"
#include "library/mesh.h"

namespace raywarp {

struct MeshPairs {
  std::vector<Eigen::Vector3d> sources, targets;  // box frame, the vertices inside the box
  long file_vertices = 0;   // the mesh file's vertices, before identical ones were joined
  long mesh_vertices = 0;   // load_mesh's (joined)
  long torn = 0;            // joined vertices whose copies the target moves apart: their mean is
                            // used (a target that tears the surface)
  double largest_move = 0;  // |target - source| over the pairs, object units
  long moved_outside = 0;   // vertices outside the box that the target moves: drawn at rest
};

// `mesh` is load_mesh(mesh_file); the target is `target_file`'s vertices (morph >= 0: its morph
// target `morph` blended by `weight`; load_file_vertices). A vertex is in the box within 1e-9 of
// its diagonal; "moves" means by more than 1e-9 of the box diagonal. Throws Error naming both
// files when their vertex counts differ.
MeshPairs mesh_pairs(const std::string& mesh_file, const Mesh& mesh, const std::string& target_file,
                     int morph, double weight, const Box& box);

}  // namespace raywarp
