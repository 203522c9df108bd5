// The two textures the ray caster reads, both in a box's local frame (object units).
#pragma once
#include <Eigen/Core>
#include <string>

#include "library/box.h"
#include "library/grid.h"

namespace raywarp {

// Implicit surface of S_D (the part of the mesh inside the box): signed distance,
// f > 0 inside, f < 0 outside, |grad f| ~ 1, object units (Correa & Silver's sign; OpenVDB's is
// the opposite and is flipped at bake time). The grid covers the box plus a margin. Within the
// narrow band of half width `band_voxels` the values are distances; beyond it they are
// +-`background` (= band_voxels * spacing), a lower bound of the true distance, so steps of
// |f| stay safe.
struct DistanceGrid {
  Grid3<float> grid;
  float background = 0.0f;
  double band_voxels = 0.0;
  std::string sign_method;  // how inside was decided, for the report
  long active_voxels = 0;   // voxels in the narrow band
  double bake_seconds = 0.0;
};

// Inverse displacement D(p') with p = p' + D(p') (deformed -> undeformed), in object units in
// the box's local frame, over the bounds of the deformed box F(box). Channel w is the validity:
// 1 where the preimage p lies in the box, 0 elsewhere (D is still finite there, never NaN).
struct DeformationTexture {
  Grid3<Eigen::Vector4f> grid;
  double bake_seconds = 0.0;
};

// Where a ray leaves a box through a face, the ray caster counts a sample within this many
// voxels of the implicit surface as a hit: the distance grid's surface may lie up to about a voxel
// inside the mesh the raster pass draws beyond the face, and a crack would show the mesh's inside.
constexpr double kSeamVoxels = 1.0;

// Everything the ray caster needs for one box.
struct BoxTextures {
  Box box;
  DistanceGrid sdf;
  DeformationTexture deformation;
};

}  // namespace raywarp
