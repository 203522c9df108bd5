// Shading and pixel writes of the CPU references (verify/reference.cpp, verify/tet_walk.cpp): the
// same as shaders/shading.glsl, so that reference and GL images agree up to rounding (its sRGB
// encoding: srgb_byte, library/image.h).
#pragma once
#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <string>

#include "base/error.h"
#include "library/image.h"

namespace raywarp::cpu_shading {

// Headlight: the light comes from the eye along the ray (docs/conventions.md#colour).
inline Eigen::Vector3d shade(const Eigen::Vector3d& albedo, const Eigen::Vector3d& normal,
                             const Eigen::Vector3d& ray_direction) {
  const double lambert = std::max(normal.dot(-ray_direction), 0.0);
  return albedo * (0.2 + 0.8 * lambert);
}

// Writes a linear colour into pixel (x, y) as 8-bit sRGB, opaque.
inline void put_colour(Image& image, int x, int y, const Eigen::Vector3d& linear_rgb) {
  uint8_t* px = &image.rgba[4 * (static_cast<size_t>(y) * image.width + x)];
  for (int c = 0; c < 3; ++c) px[c] = srgb_byte(linear_rgb[c]);
  px[3] = 255;
}

// Throws Error unless each side is in [1, 8192]; `who` names the renderer.
inline void check_image_size(const char* who, int width, int height) {
  if (width < 1 || height < 1 || width > 8192 || height > 8192)
    throw Error(std::string(who) + ": image size " + std::to_string(width) + " x " +
                std::to_string(height) + ": each side must be in [1, 8192]");
}

}  // namespace raywarp::cpu_shading
