#include "library/image.h"

#include <stb/stb_image.h>
#include <stb/stb_image_write.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <ostream>

#include "base/error.h"

namespace raywarp {

namespace {

// stbi_write_png_to_func's sink: the bytes into the std::ostream at `context`.
void write_to_stream(void* context, void* data, int size) {
  static_cast<std::ostream*>(context)->write(static_cast<const char*>(data), size);
}

// A PNG of `comp` 8-bit channels per pixel, written whole (write_file_atomic).
void write_png_file(const std::string& path, const char* what, int width, int height, int comp,
                    const uint8_t* pixels) {
  write_file_atomic(path, [&](std::ostream& out) {
    const int stride = width * comp;
    if (!stbi_write_png_to_func(&write_to_stream, &out, width, height, comp, pixels, stride))
      throw Error(path + ": cannot encode the " + what + " (out of memory?)");
  });
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
  write_png_file(path, "PNG", image.width, image.height, 4, image.rgba.data());
}

void write_mask_png(const std::string& path, const Image& image) {
  check_size(path, image);
  std::vector<uint8_t> mask(static_cast<size_t>(image.width) * image.height);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      mask[static_cast<size_t>(y) * image.width + x] = image.covered(x, y) ? 255 : 0;
  write_png_file(path, "mask PNG", image.width, image.height, 1, mask.data());
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

double srgb_encode(double linear) {
  const double c = std::clamp(linear, 0.0, 1.0);
  return c < 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
}

uint8_t srgb_byte(double linear) {
  return static_cast<uint8_t>(std::lround(255.0 * srgb_encode(linear)));
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
      c.disagree += ca != cb;
      auto b_covered = [&](int u, int v) {
        return u >= 0 && v >= 0 && u < b.width && v < b.height && b.covered(u, v);
      };
      c.outline += cb && (!b_covered(x - 1, y) || !b_covered(x + 1, y) || !b_covered(x, y - 1) ||
                          !b_covered(x, y + 1));
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

Image difference_image(const Image& a, const Image& b, double depth_threshold) {
  if (a.width != b.width || a.height != b.height)
    throw Error("difference_image: sizes differ: " + std::to_string(a.width) + " x " +
                std::to_string(a.height) + " and " + std::to_string(b.width) + " x " +
                std::to_string(b.height));
  Image d(a.width, a.height);
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      const bool ca = a.covered(x, y), cb = b.covered(x, y);
      uint8_t rgb[3] = {255, 255, 255};
      if (ca && cb) {
        const bool over =
            std::abs(static_cast<double>(a.depth_at(x, y)) - b.depth_at(x, y)) > depth_threshold;
        rgb[0] = over ? 0 : 200;
        rgb[1] = over ? 170 : 200;
        rgb[2] = over ? 0 : 200;
      } else if (ca) {
        rgb[1] = rgb[2] = 0;
      } else if (cb) {
        rgb[0] = rgb[1] = 0;
      }
      uint8_t* px = &d.rgba[4 * (static_cast<size_t>(y) * a.width + x)];
      px[0] = rgb[0];
      px[1] = rgb[1];
      px[2] = rgb[2];
      px[3] = 255;
    }
  return d;
}

Image read_png(const std::string& path) {
  int w = 0, h = 0, n = 0;
  unsigned char* pixels = stbi_load(path.c_str(), &w, &h, &n, 4);
  if (!pixels)
    throw Error(path +
                ": cannot read as a PNG: " + (stbi_failure_reason() ? stbi_failure_reason() : "?"));
  Image image;
  image.width = w;
  image.height = h;
  image.rgba.assign(pixels, pixels + static_cast<size_t>(w) * h * 4);
  stbi_image_free(pixels);
  return image;
}

Image composite_nearest(const Image& a, const Image& b) {
  if (a.width != b.width || a.height != b.height)
    throw Error("composite: images of " + std::to_string(a.width) + "x" + std::to_string(a.height) +
                " and " + std::to_string(b.width) + "x" + std::to_string(b.height) + " pixels");
  Image out = a;
  for (size_t i = 0; i < out.depth.size(); ++i)
    if (b.depth[i] < out.depth[i]) {
      out.depth[i] = b.depth[i];
      for (int c = 0; c < 4; ++c) out.rgba[4 * i + c] = b.rgba[4 * i + c];
    }
  return out;
}

}  // namespace raywarp
