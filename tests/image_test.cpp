// Image files (PNG colour and mask, raw float32 depth), the atomic writer and image comparison.
#include "library/image.h"

#include <gtest/gtest.h>
#include <stb/stb_image.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <random>

#include "base/error.h"
#include "tests/temp_folder.h"

namespace raywarp {
namespace {

namespace fs = std::filesystem;
constexpr float kInf = std::numeric_limits<float>::infinity();

class ImageFiles : public TempFolderTest {};

// A 7 x 5 image with distinct bytes everywhere and depth covering every other pixel.
Image pattern_image() {
  Image im(7, 5);
  for (size_t i = 0; i < im.rgba.size(); ++i)
    im.rgba[i] = static_cast<uint8_t>((i * 37 + 11) % 256);
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x)
      if ((x + y) % 2 == 0) im.depth[static_cast<size_t>(y) * im.width + x] = 0.25f * x - 1.5f * y;
  return im;
}

std::vector<char> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<char>(std::istreambuf_iterator<char>(in), {});
}

TEST(ImageBasics, NewImageIsTransparentBlackAndEmpty) {
  Image im(3, 2);
  ASSERT_EQ(im.rgba.size(), 3u * 2u * 4u);
  ASSERT_EQ(im.depth.size(), 6u);
  for (uint8_t b : im.rgba) EXPECT_EQ(b, 0);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 3; ++x) {
      EXPECT_EQ(im.depth_at(x, y), kInf);
      EXPECT_FALSE(im.covered(x, y));
    }
  im.depth[4] = 2.0f;  // (1, 1)
  EXPECT_TRUE(im.covered(1, 1));
}

TEST_F(ImageFiles, PngRoundTripsEveryByte) {
  Image im = pattern_image();
  write_png(path("colour.png"), im);
  int w = 0, h = 0, channels = 0;
  uint8_t* data = stbi_load(path("colour.png").c_str(), &w, &h, &channels, 0);
  ASSERT_NE(data, nullptr);
  EXPECT_EQ(w, 7);
  EXPECT_EQ(h, 5);
  EXPECT_EQ(channels, 4);
  EXPECT_EQ(std::memcmp(data, im.rgba.data(), im.rgba.size()), 0);
  stbi_image_free(data);
  EXPECT_EQ(listing(), std::vector<std::string>{"colour.png"});
}

TEST_F(ImageFiles, MaskPngIsGreyWith255WhereCovered) {
  Image im = pattern_image();
  write_mask_png(path("mask.png"), im);
  int w = 0, h = 0, channels = 0;
  uint8_t* data = stbi_load(path("mask.png").c_str(), &w, &h, &channels, 0);
  ASSERT_NE(data, nullptr);
  ASSERT_EQ(w, 7);
  ASSERT_EQ(h, 5);
  EXPECT_EQ(channels, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) EXPECT_EQ(data[y * w + x], im.covered(x, y) ? 255 : 0);
  stbi_image_free(data);
}

TEST_F(ImageFiles, DepthIsRawLittleEndianFloat32RowMajor) {
  Image im = pattern_image();
  write_depth_f32(path("depth.f32"), im);
  std::vector<char> bytes = read_bytes(path("depth.f32"));
  ASSERT_EQ(bytes.size(), 7u * 5u * 4u);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 7; ++x) {
      size_t i = static_cast<size_t>(y) * 7 + x;
      uint32_t bits = 0;
      for (int b = 0; b < 4; ++b)
        bits |= static_cast<uint32_t>(static_cast<uint8_t>(bytes[4 * i + b])) << (8 * b);
      float v = std::bit_cast<float>(bits);
      EXPECT_EQ(v, im.covered(x, y) ? im.depth_at(x, y) : kInf) << x << ", " << y;
    }
}

TEST_F(ImageFiles, AtomicWriterReplacesAndLeavesNoTemporary) {
  const std::string p = path("data.bin");
  write_file_atomic(p, "first version", 13);
  write_file_atomic(p, "second", 6);
  std::vector<char> bytes = read_bytes(p);
  EXPECT_EQ(std::string(bytes.begin(), bytes.end()), "second");
  EXPECT_EQ(listing(), std::vector<std::string>{"data.bin"});
}

TEST_F(ImageFiles, WriteIntoMissingFolderThrowsNamingPathAndLeavesNothing) {
  const std::string p = path("missing/out.png");
  Image im = pattern_image();
  auto expect_error = [&](const std::function<void()>& write) {
    try {
      write();
      ADD_FAILURE() << "no error for " << p;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what();
    }
  };
  expect_error([&] { write_png(p, im); });
  expect_error([&] { write_mask_png(p, im); });
  expect_error([&] { write_depth_f32(p, im); });
  expect_error([&] { write_file_atomic(p, "x", 1); });
  EXPECT_TRUE(listing().empty());
}

TEST_F(ImageFiles, EmptyImageIsRefused) {
  EXPECT_THROW(write_png(path("empty.png"), Image()), Error);
  EXPECT_TRUE(listing().empty());
}

// Two 10 x 10 renders: A covers columns 0..5, B columns 4..9; they share columns 4 and 5
// (20 pixels) of a union of 100. In the shared pixels B is deeper by 0.5 in column 4 and by
// 0.01 in column 5.
TEST(ImageCompare, KnownOverlapAndDepthErrors) {
  Image a(10, 10), b(10, 10);
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 10; ++x) {
      size_t i = static_cast<size_t>(y) * 10 + x;
      if (x <= 5) a.depth[i] = 2.0f;
      if (x >= 4) b.depth[i] = x == 4 ? 2.5f : (x == 5 ? 2.01f : 7.0f);
    }
  ImageComparison c = compare_images(a, b, 0.1);
  EXPECT_EQ(c.common, 20);
  EXPECT_DOUBLE_EQ(c.iou, 0.2);
  EXPECT_NEAR(c.mean_depth_error, 0.5 * (0.5 + 0.01), 1e-6);
  EXPECT_NEAR(c.max_depth_error, 0.5, 1e-6);
  EXPECT_DOUBLE_EQ(c.fraction_over, 0.5);
  EXPECT_DOUBLE_EQ(c.threshold, 0.1);
  // Symmetric.
  ImageComparison d = compare_images(b, a, 0.1);
  EXPECT_DOUBLE_EQ(d.iou, c.iou);
  EXPECT_DOUBLE_EQ(d.mean_depth_error, c.mean_depth_error);
}

TEST(ImageCompare, IdenticalAndEmptyImagesAgree) {
  Image a = pattern_image();
  ImageComparison c = compare_images(a, a, 0.0);
  EXPECT_DOUBLE_EQ(c.iou, 1.0);
  EXPECT_EQ(c.max_depth_error, 0.0);
  EXPECT_EQ(c.fraction_over, 0.0);
  ImageComparison e = compare_images(Image(4, 4), Image(4, 4), 0.1);
  EXPECT_DOUBLE_EQ(e.iou, 1.0);
  EXPECT_EQ(e.common, 0);
}

TEST(ImageCompare, SizesMustMatch) {
  EXPECT_THROW(compare_images(Image(4, 4), Image(4, 5), 0.1), Error);
}

}  // namespace
}  // namespace raywarp
