// Rendered images and their files. Row 0 is the top row.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

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
// Writes `bytes` to `path` atomically (temporary file, then rename).
void write_file_atomic(const std::string& path, const void* bytes, size_t size);

// Silhouette and depth agreement of two renders of the same camera.
struct ImageComparison {
  double iou = 0.0;               // |A and B| / |A or B| of the covered pixels
  long common = 0;                // pixels covered in both
  double mean_depth_error = 0.0;  // over common pixels
  double max_depth_error = 0.0;   // over common pixels
  double fraction_over = 0.0;     // common pixels with |depth error| > threshold
  double threshold = 0.0;
};
ImageComparison compare_images(const Image& a, const Image& b, double depth_threshold);

}  // namespace raywarp
