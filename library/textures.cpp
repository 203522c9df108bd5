#include "library/textures.h"

#include <algorithm>
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

float round_to_half(float x) {
  if (!std::isfinite(x) || x == 0.0f) return x;
  constexpr float kLargest = 65504.0f;
  if (std::abs(x) >= kLargest) return std::copysign(kLargest, x);
  int e = 0;
  std::frexp(x, &e);  // |x| in [2^(e-1), 2^e)
  // 11 significant bits; below the smallest normal half (2^-14) the spacing stays 2^-24.
  const float ulp = std::ldexp(1.0f, std::max(e, -13) - 11);
  const float r = std::nearbyint(x / ulp) * ulp;  // the default rounding mode: ties to even
  return std::abs(r) > kLargest ? std::copysign(kLargest, r) : r;
}

void round_textures_to_half(BoxTextures& b) {
  for (float& v : b.sdf.grid.data) v = round_to_half(v);
  b.sdf.background = round_to_half(b.sdf.background);
  for (Eigen::Vector4f& v : b.deformation.grid.data)
    for (int c = 0; c < 4; ++c) v[c] = round_to_half(v[c]);
  for (float& v : b.alpha.grid.data) v = round_to_half(v);
  b.half_precision = true;
}

bool skipping_pays(const BoxTextures& b, double step_voxels, bool requested) {
  if (!requested) return false;
  if (b.has_cut) return true;
  return b.sdf.background / (std::sqrt(3.0) * b.lipschitz) > step_voxels * b.sdf.grid.spacing;
}

}  // namespace raywarp
