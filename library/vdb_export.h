// OpenVDB export (.vdb, the sparse volume format of Houdini, Blender, Maya/Arnold, EmberGen):
// each dense TextureVolume becomes a grid, a FloatGrid for one channel or a Vec3SGrid for three,
// with its index-to-world transform, name, class and metadata. Voxels whose value equals the
// grid's background stay inactive (OpenVDB's sparse representation); every other voxel is active
// and stored at full float precision, unchanged.
#pragma once
#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "library/texture_volume.h"

namespace raywarp {

struct VdbGrid {
  // channels 1 -> FloatGrid, 3 -> Vec3SGrid (x, y, z); texel (i, j, k) is OpenVDB voxel (i, j, k).
  TextureVolume volume;
  // Maps an index-space position (i, j, k) — OpenVDB samples at integer coordinates, so these
  // are voxel centres — to world space, as a column-vector affine matrix: world = M * (i, j, k, 1).
  // The last row must be (0, 0, 0, 1) and the 3 x 3 part invertible.
  Eigen::Matrix4d index_to_world = Eigen::Matrix4d::Identity();
  std::string name;  // the grid's name ("density", "deformation", ...); empty: volume.name
  // GRID_LEVEL_SET (a signed distance in world units, background the narrow band's half width)
  // instead of GRID_FOG_VOLUME (1 channel) or GRID_UNKNOWN (3 channels).
  bool level_set = false;
  float background = 0;  // every component of a Vec3 grid's background
  // Vec3 grids only: VEC_CONTRAVARIANT_RELATIVE (a displacement or velocity, which a tool that
  // resamples or transforms the grid maps by the transform's linear part) instead of
  // VEC_INVARIANT (values kept as they are).
  bool vector_is_displacement = false;
};

// Writes the grids, in order, to `path` (atomically: a temporary file beside it, renamed over
// it), with `file_metadata` as string metadata of the file and of every grid. Compression is
// ZIP with the active mask, which every OpenVDB reader decodes. Throws Error naming the path,
// the grid and what is allowed for bad input (channels not 1 or 3, dims < 1, a wrong number of
// values, a transform that is not affine and invertible, duplicate or empty names) and for a
// failure to write.
void write_vdb(const std::string& path, const std::vector<VdbGrid>& grids,
               const std::vector<std::pair<std::string, std::string>>& file_metadata);

}  // namespace raywarp
