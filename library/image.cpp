#include "library/image.h"

#include <stb/stb_image_write.h>
#include <unistd.h>

#include <atomic>
#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <system_error>

#include "base/error.h"

namespace raywarp {

namespace {

// A name beside `path` that no other writer (thread or process) uses at the same time, so the
// final rename stays within one file system and is atomic.
std::filesystem::path temporary_beside(const std::filesystem::path& path) {
  static std::atomic<unsigned long> counter{0};
  std::filesystem::path tmp = path;
  tmp += ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
  return tmp;
}

// Runs `write(tmp)`, which returns false on failure, then renames tmp to `path`. On any failure
// the temporary file is removed and Error names `path`; `path` itself is never half-written.
void write_via_temporary(const std::string& path, const char* what,
                         const std::function<bool(const std::string&)>& write) {
  const std::filesystem::path tmp = temporary_beside(path);
  std::error_code ec;
  if (!write(tmp.string())) {
    std::filesystem::remove(tmp, ec);
    throw Error(path + ": cannot write the " + what + " (is the folder there and writable?)");
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    throw Error(path + ": cannot write the " + what + ": " + ec.message());
  }
}

void check_size(const std::string& path, const Image& image) {
  if (image.width <= 0 || image.height <= 0)
    throw Error(path + ": image is " + std::to_string(image.width) + " x " +
                std::to_string(image.height) + ": both sides must be > 0");
}

}  // namespace

Image::Image(int w, int h)
    : width(w),
      height(h),
      rgba(static_cast<size_t>(w) * h * 4, 0),
      depth(static_cast<size_t>(w) * h, std::numeric_limits<float>::infinity()) {}

bool Image::covered(int x, int y) const { return std::isfinite(depth_at(x, y)); }

void write_png(const std::string& path, const Image& image) {
  check_size(path, image);
  write_via_temporary(path, "PNG", [&](const std::string& tmp) {
    return stbi_write_png(tmp.c_str(), image.width, image.height, 4, image.rgba.data(),
                          image.width * 4) != 0;
  });
}

void write_mask_png(const std::string& path, const Image& image) {
  check_size(path, image);
  std::vector<uint8_t> mask(static_cast<size_t>(image.width) * image.height);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      mask[static_cast<size_t>(y) * image.width + x] = image.covered(x, y) ? 255 : 0;
  write_via_temporary(path, "mask PNG", [&](const std::string& tmp) {
    return stbi_write_png(tmp.c_str(), image.width, image.height, 1, mask.data(), image.width) != 0;
  });
}

void write_depth_f32(const std::string& path, const Image& image) {
  check_size(path, image);
  static_assert(sizeof(float) == 4 && std::numeric_limits<float>::is_iec559);
  std::vector<uint8_t> bytes(image.depth.size() * 4);
  for (size_t i = 0; i < image.depth.size(); ++i) {
    uint32_t bits = std::bit_cast<uint32_t>(image.depth[i]);
    for (int b = 0; b < 4; ++b) bytes[4 * i + b] = static_cast<uint8_t>(bits >> (8 * b));
  }
  write_file_atomic(path, bytes.data(), bytes.size());
}

void write_file_atomic(const std::string& path, const void* bytes, size_t size) {
  write_via_temporary(path, "file", [&](const std::string& tmp) {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return false;
    out.write(static_cast<const char*>(bytes), static_cast<std::streamsize>(size));
    out.close();
    return !out.fail();
  });
}

ImageComparison compare_images(const Image& a, const Image& b, double depth_threshold) {
  if (a.width != b.width || a.height != b.height)
    throw Error("compare_images: sizes differ: " + std::to_string(a.width) + " x " +
                std::to_string(a.height) + " and " + std::to_string(b.width) + " x " +
                std::to_string(b.height));
  ImageComparison c;
  c.threshold = depth_threshold;
  long either = 0, over = 0;
  double sum = 0.0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      bool ca = a.covered(x, y), cb = b.covered(x, y);
      if (ca || cb) ++either;
      if (!(ca && cb)) continue;
      ++c.common;
      double e = std::abs(static_cast<double>(a.depth_at(x, y)) - b.depth_at(x, y));
      sum += e;
      c.max_depth_error = std::max(c.max_depth_error, e);
      if (e > depth_threshold) ++over;
    }
  // Two empty renders agree perfectly.
  c.iou = either > 0 ? static_cast<double>(c.common) / either : 1.0;
  if (c.common > 0) {
    c.mean_depth_error = sum / c.common;
    c.fraction_over = static_cast<double>(over) / c.common;
  }
  return c;
}

}  // namespace raywarp
