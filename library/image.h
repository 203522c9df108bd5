// Rendered images and their files. Row 0 is the top row (docs/conventions.md#image-rows).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "base/atomic_file.h"

namespace raywarp {

struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgba;  // 8-bit sRGB, 4 per pixel
  std::vector<float> depth;   // linear eye depth along the view axis, +inf where empty
  Image() = default;
  Image(int w, int h);
  bool covered(int x, int y) const;  // finite depth
  float depth_at(int x, int y) const { return depth[static_cast<size_t>(y) * width + x]; }
};

// Each writer writes a temporary file beside `path` and renames it, so a failed write never
// leaves a half-written file. Throws Error naming the path.
void write_png(const std::string& path, const Image& image);
void write_mask_png(const std::string& path, const Image& image);   // 255 where covered
void write_depth_f32(const std::string& path, const Image& image);  // float32 LE, H x W, row-major
// write_file_atomic (base/atomic_file.h) writes any other file whole.
// Reads an 8-bit PNG (any channel count, as RGBA; depth left empty). Throws Error naming the path.
Image read_png(const std::string& path);

// The sRGB transfer function (IEC 61966-2-1) of a linear value clamped to [0, 1]: 12.92 c below
// 0.0031308, else 1.055 c^(1/2.4) - 0.055. shaders/shading.glsl's srgb_encode is the same.
double srgb_encode(double linear);
// The 8-bit sRGB code of a linear value: round(255 srgb_encode(linear)), halves away from 0.
uint8_t srgb_byte(double linear);

// Silhouette and depth agreement of two renders of the same camera.
// Per pixel, the nearer of a and b by depth (a where neither is covered or they tie): two frames
// of one camera composited. Throws Error when their sizes differ.
Image composite_nearest(const Image& a, const Image& b);

struct ImageComparison {
  double iou = 0.0;               // |A and B| / |A or B| of the covered pixels
  long common = 0;                // pixels covered in both
  double mean_depth_error = 0.0;  // over common pixels
  double max_depth_error = 0.0;   // over common pixels
  double fraction_over = 0.0;     // common pixels with |depth error| > threshold
  double threshold = 0.0;
  // The outline bias, in pixels: the pixels covered in one image and not the other, per pixel of
  // b's outline (b's covered pixels with an uncovered 4-neighbour, the image's border counting
  // as uncovered). b is the reference.
  long disagree = 0, outline = 0;
  double outline_bias() const { return outline ? static_cast<double>(disagree) / outline : 0.0; }
};
ImageComparison compare_images(const Image& a, const Image& b, double depth_threshold);
// The comparison as a picture: grey where both are covered and agree within depth_threshold,
// green where the depths differ by more, red where only a is covered, blue where only b is,
// white where neither. Throws Error when their sizes differ.
Image difference_image(const Image& a, const Image& b, double depth_threshold);

}  // namespace raywarp
