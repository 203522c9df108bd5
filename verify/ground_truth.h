// The ground truth a scene's image is measured against: exact where an exact form exists (the
// mesh split at the box faces, subdivided and mapped by the exact forward map, then rasterised on
// the CPU; a box cut's CSG difference ray cast against every triangle; a hollow incision mapped
// from each side of its plane), else the CPU ray cast of the scene's own textures at 1/16-voxel
// steps, which measures the sampling's error only (`kind` says which).
#pragma once
#include <string>

#include "library/bake.h"
#include "library/camera.h"
#include "library/image.h"
#include "library/scene.h"

namespace raywarp {

struct Truth {
  Image image;
  std::string kind;       // how it was made: "exact: ..." or "not exact: ..."
  double diagonal = 1.0;  // of the deformed mesh's bounds (depth errors are given in it)
};

Truth ground_truth(const Scene& scene, const PreparedScene& prepared, const Camera& camera,
                   int width, int height);

}  // namespace raywarp
