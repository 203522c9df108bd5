#include "library/textures.h"

#include <cmath>

namespace raywarp {

const char* cut_mode_name(CutMode mode) {
  switch (mode) {
    case CutMode::Hollow:
      return "hollow";
    case CutMode::Solid:
      return "solid";
    case CutMode::ThickShell:
      break;
  }
  return "thick_shell";
}

Eigen::AlignedBox3d ray_cast_region(const BoxTextures& b) {
  if (!b.region.isEmpty()) return b.region;
  return Eigen::AlignedBox3d(b.deformation.grid.origin, b.deformation.grid.upper());
}

double cut_margin(const BoxTextures& b) {
  if (!b.has_cut) return 0.0;
  return std::sqrt(3.0) * (b.alpha.grid.spacing + 0.5 * b.deformation.grid.spacing);
}

bool skipping_pays(const BoxTextures& b, double step_voxels, bool requested) {
  if (!requested) return false;
  if (b.has_cut) return true;
  return b.sdf.background / (std::sqrt(3.0) * b.lipschitz) > step_voxels * b.sdf.grid.spacing;
}

}  // namespace raywarp
