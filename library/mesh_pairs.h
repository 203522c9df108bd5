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

// A from_mesh target as read: the deformed copy's vertices in the file's order (FileVertices),
// from one file or blended from two frames of a sequence.
//
// A sequence is either a folder of copies, its frames the folder's mesh files (PLY, OBJ, STL,
// OFF, glTF, GLB, FBX, DAE, each possibly .xz) in natural name order (target_2.ply before
// target_10.ply; hidden files skipped), or a glTF's morph targets, frame k being morph target k
// at weight 1. A fractional frame f blends frames floor(f) and floor(f) + 1 vertex by vertex:
// (1 - t) a + t b, t = f - floor(f).
struct DeformedCopy {
  FileVertices vertices;
  std::vector<std::string> files;  // the files read (their bytes key what is baked from them)
  int frames = 0;                  // the sequence's length; 0: not a sequence
  std::string name;                // for messages: the file (of a folder: frame floor(F)'s)
};

constexpr int kMaxSequenceFrames = 100000;

// The mesh files of a sequence folder, in natural name order. Throws Error naming the folder when
// it holds none, or more than kMaxSequenceFrames.
std::vector<std::string> sequence_files(const std::string& folder);

// The frames of `target` as a sequence: the folder's mesh files, or a glTF's morph targets (the
// file is read); 0 for a file with no morph target.
int sequence_frames(const std::string& target);

// `target`: a mesh file (morph >= 0: its morph target `morph` blended by `weight`) or, with
// frame >= 0 (a folder: always; frame < 0 reads frame 0), frame `frame` of a sequence. Throws
// Error: "frame = F: ..." when F is past the sequence's last frame, naming the count; "morph
// ..." or the file's message otherwise.
DeformedCopy read_deformed_copy(const std::string& target, int morph, double weight, double frame);

// The files read_deformed_copy(target, ..., frame) reads, without reading them: of a folder,
// frame floor(frame)'s copy and, for a fraction, the next one; otherwise `target`. Throws Error
// as read_deformed_copy does for a folder's frame past the last.
std::vector<std::string> deformed_copy_files(const std::string& target, double frame);

// `mesh` is load_mesh(mesh_file); `moved` the target's vertices, `target_name` for messages. A
// vertex is in the box within 1e-9 of its diagonal; "moves" means by more than 1e-9 of the box
// diagonal. Throws Error naming both files when their vertex counts differ.
MeshPairs mesh_pairs(const std::string& mesh_file, const Mesh& mesh, const FileVertices& moved,
                     const std::string& target_name, const Box& box);

}  // namespace raywarp
