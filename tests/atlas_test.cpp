// Tiled 2D atlases (library/atlas.h): the engines' tile layout, the clamp-to-edge border, and the
// 16-bit PNG and OpenEXR files, read back through libpng, ImageMagick and OpenEXR.
#include "library/atlas.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "base/error.h"
#include "library/texture_volume.h"
#include "tests/temp_folder.h"

namespace raywarp {
namespace {

// 5 x 4 x 3 texels; channel c of texel (i, j, k) is i + 10 j + 100 k + 1000 c.
TextureVolume recognisable(int channels) {
  TextureVolume v;
  v.name = "recognisable";
  v.dims = {5, 4, 3};
  v.channels = channels;
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 5; ++i)
        for (int c = 0; c < channels; ++c) v.values.push_back(i + 10 * j + 100 * k + 1000 * c);
  return v;
}

TextureVolume random_volume(int channels, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> value(-3.0f, 5.0f);
  TextureVolume v;
  v.name = "random";
  v.dims = {7, 6, 10};
  v.channels = channels;
  v.values.resize(v.texels() * channels);
  for (float& x : v.values) x = value(rng);
  return v;
}

// Runs a shell command; its standard output, or "" with ok = false when it fails.
std::string run(const std::string& command, bool& ok) {
  std::string out;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) {
    ok = false;
    return out;
  }
  char buffer[65536];
  size_t n;
  while ((n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0) out.append(buffer, n);
  ok = ::pclose(pipe) == 0;
  return out;
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(AtlasLayout, TilesFollowTheEnginesOrder) {
  struct Case {
    int nz, tiles_x, tiles_y;
  };
  for (const Case& c : {Case{1, 1, 1}, Case{5, 3, 2}, Case{16, 4, 4}, Case{17, 5, 4}}) {
    for (int border : {0, 1}) {
      SCOPED_TRACE("nz = " + std::to_string(c.nz) + ", border = " + std::to_string(border));
      const AtlasLayout l = atlas_layout({5, 4, c.nz}, border);
      EXPECT_EQ(l.tiles_x, c.tiles_x);
      EXPECT_EQ(l.tiles_y, c.tiles_y);
      EXPECT_EQ(l.width(), c.tiles_x * (5 + 2 * border));
      EXPECT_EQ(l.height(), c.tiles_y * (4 + 2 * border));
      for (int k = 0; k < c.nz; ++k) {
        // Texel (0, 0) of slice k: its tile's top-left pixel, inside the border.
        const Eigen::Vector2i top_left((k % c.tiles_x) * (5 + 2 * border) + border,
                                       (k / c.tiles_x) * (4 + 2 * border) + border);
        EXPECT_EQ(l.texel(0, 0, k), top_left) << "k = " << k;
        EXPECT_EQ(l.texel(4, 3, k), top_left + Eigen::Vector2i(4, 3)) << "k = " << k;
      }
    }
  }
  // Of 17 slices in 5 columns, slice 15 starts the fourth tile row, slice 16 follows it; with a
  // border, slice 6 is column 1, row 1 of 7 x 6 tiles.
  EXPECT_EQ(atlas_layout({5, 4, 17}).texel(2, 1, 15), Eigen::Vector2i(2, 13));
  EXPECT_EQ(atlas_layout({5, 4, 17}).texel(2, 1, 16), Eigen::Vector2i(7, 13));
  EXPECT_EQ(atlas_layout({5, 4, 17}, 1).texel(2, 1, 6), Eigen::Vector2i(7 + 1 + 2, 6 + 1 + 1));
  // The caller's tile columns.
  const AtlasLayout row = atlas_layout({5, 4, 5}, 0, 5);
  EXPECT_EQ(row.tiles_x, 5);
  EXPECT_EQ(row.tiles_y, 1);
  const AtlasLayout column = atlas_layout({5, 4, 5}, 0, 1);
  EXPECT_EQ(column.width(), 5);
  EXPECT_EQ(column.height(), 20);
  EXPECT_EQ(column.texel(1, 2, 3), Eigen::Vector2i(1, 14));
  EXPECT_EQ(atlas_layout({8, 8, 64}).tiles_x, 8);
  // No empty tile where nz has a divisor near sqrt(nz): 65 = 5 x 13, 96 = 8 x 12; a prime nz
  // takes ceil(sqrt(nz)) columns.
  EXPECT_EQ(atlas_layout({8, 8, 65}).tiles_x, 5);
  EXPECT_EQ(atlas_layout({8, 8, 65}).tiles_y, 13);
  EXPECT_EQ(atlas_layout({8, 8, 96}).tiles_x, 8);
  EXPECT_EQ(atlas_layout({8, 8, 96}).tiles_y, 12);
  EXPECT_EQ(atlas_layout({8, 8, 97}).tiles_x, 10);
}

TEST(AtlasLayout, BorderRepeatsTheEdgeTexelsAndUnusedTilesAreZero) {
  const TextureVolume v = recognisable(2);
  const AtlasLayout l = atlas_layout(v.dims, 1, 2);  // 2 x 2 tiles of 7 x 6, the last unused
  const std::vector<float> p = atlas_pixels(v, l);
  ASSERT_EQ(p.size(), static_cast<size_t>(14 * 12 * 2));
  auto pixel = [&](Eigen::Vector2i q, int c) { return p[(q.y() * l.width() + q.x()) * 2 + c]; };
  for (int k = 0; k < 3; ++k)
    for (int c = 0; c < 2; ++c) {
      for (int j = -1; j <= 4; ++j)
        for (int i = -1; i <= 5; ++i) {
          const int si = std::clamp(i, 0, 4), sj = std::clamp(j, 0, 3);
          EXPECT_EQ(pixel(l.texel(i, j, k), c), v.at(si, sj, k, c))
              << "texel " << i << ", " << j << ", " << k << " channel " << c;
        }
    }
  // The top-right corner of slice 1's border copies its texel (4, 0), the bottom-left one of
  // slice 2's its texel (0, 3).
  EXPECT_EQ(pixel({13, 0}, 0), 4 + 100);
  EXPECT_EQ(pixel({13, 0}, 1), 1000 + 4 + 100);
  EXPECT_EQ(pixel({0, 11}, 0), 30 + 200);
  for (int y = 6; y < 12; ++y)
    for (int x = 7; x < 14; ++x) EXPECT_EQ(pixel({x, y}, 0), 0.0f);
  // Without a border, the atlas is the slices side by side.
  const AtlasLayout plain = atlas_layout(v.dims, 0, 2);
  const std::vector<float> q = atlas_pixels(v, plain);
  EXPECT_EQ(q[(4 * plain.width() + 0) * 2 + 1], v.at(0, 0, 2, 1));  // slice 2: row 1, column 0
  EXPECT_EQ(q[(3 * plain.width() + 9) * 2 + 0], v.at(4, 3, 1, 0));  // slice 1: last texel
}

TEST(AtlasLayout, BadInputNamesWhatIsAllowed) {
  EXPECT_NE(message_of([] {
              atlas_layout({5, 0, 3});
            }).find("each must be >= 1"),
            std::string::npos);
  EXPECT_NE(message_of([] {
              atlas_layout({5, 4, 3}, 2);
            }).find("must be 0 or 1"),
            std::string::npos);
  TextureVolume three = recognisable(1);
  three.channels = 3;
  three.values.resize(three.texels() * 3);
  EXPECT_EQ(message_of([&] {
              write_atlas_exr("out/a.exr", three, atlas_layout(three.dims), Storage::Half);
            }),
            "out/a.exr: channels = 3: must be 1, 2 or 4");
  TextureVolume wide;
  wide.dims = {20000, 1, 1};
  wide.values.resize(20000);
  EXPECT_EQ(message_of([&] { write_atlas_png16("out/w.png", wide, atlas_layout(wide.dims)); }),
            "out/w.png: atlas of 20000 x 1 pixels for a 20000 x 1 x 1 volume: each side must be "
            "<= 16384");
  TextureVolume tall;
  tall.dims = {4, 4, 4100};  // one tile column: 4 x 16400 pixels
  tall.values.resize(tall.texels());
  EXPECT_NE(message_of([&] {
              write_atlas_exr("t.exr", tall, atlas_layout(tall.dims, 0, 1), Storage::Float);
            }).find("t.exr: atlas of 4 x 16400 pixels"),
            std::string::npos);
  const TextureVolume v = recognisable(1);
  EXPECT_NE(message_of([&] {
              write_atlas_png16("x.png", v, atlas_layout({5, 4, 4}));
            }).find("x.png: atlas layout for 5 x 4 x 4 texels: must match"),
            std::string::npos);
}

class Atlas : public TempFolderTest {};

// Expected unorm16 codes of the atlas pixels, computed from the formula in atlas.h.
std::vector<std::uint16_t> expected_codes(const TextureVolume& v, const AtlasLayout& l,
                                          const UnormEncoding& enc) {
  const std::vector<float> p = atlas_pixels(v, l);
  std::vector<std::uint16_t> codes;
  for (size_t s = 0; s < p.size(); ++s) {
    const int c = static_cast<int>(s % v.channels);
    const double code = std::round((p[s] - enc.lo[c]) / (enc.hi[c] - enc.lo[c]) * 65535.0);
    codes.push_back(static_cast<std::uint16_t>(std::clamp(code, 0.0, 65535.0)));
  }
  return codes;
}

TEST_F(Atlas, Png16RoundTripsWithinTheEncodingsError) {
  for (int channels : {1, 2, 4})
    for (int border : {0, 1})
      for (const TextureVolume& v : {recognisable(channels), random_volume(channels, 7)}) {
        SCOPED_TRACE(v.name + ", channels " + std::to_string(channels) + ", border " +
                     std::to_string(border));
        const AtlasLayout l = atlas_layout(v.dims, border);
        const std::string file = path("a.png");
        const UnormEncoding enc = write_atlas_png16(file, v, l);
        ASSERT_EQ(enc.lo.size(), static_cast<size_t>(channels));
        for (int c = 0; c < channels; ++c) {
          float lo = INFINITY, hi = -INFINITY;
          for (size_t t = c; t < v.values.size(); t += channels) {
            lo = std::min(lo, v.values[t]);
            hi = std::max(hi, v.values[t]);
          }
          EXPECT_EQ(enc.lo[c], lo);
          EXPECT_EQ(enc.hi[c], hi);
        }
        const TextureVolume back = read_atlas_png16(file, l, enc, channels);
        ASSERT_EQ(back.values.size(), v.values.size());
        EXPECT_EQ(back.dims, v.dims);
        double worst = 0;
        for (size_t t = 0; t < v.values.size(); ++t) {
          const double e = std::abs(static_cast<double>(back.values[t]) - v.values[t]);
          worst = std::max(worst, e);
          EXPECT_LE(e, enc.max_error() + 1e-7 * std::abs(v.values[t])) << "value " << t;
        }
        EXPECT_GT(worst, 0.0);  // quantised, not stored as floats
        EXPECT_EQ(listing(), std::vector<std::string>{"a.png"});
      }
  // A constant channel gets hi = lo + 1 and round-trips exactly; the caller's encoding clamps.
  TextureVolume flat = recognisable(1);
  std::fill(flat.values.begin(), flat.values.end(), 2.5f);
  const AtlasLayout l = atlas_layout(flat.dims);
  const UnormEncoding enc = write_atlas_png16(path("flat.png"), flat, l);
  EXPECT_EQ(enc.lo, std::vector<double>{2.5});
  EXPECT_EQ(enc.hi, std::vector<double>{3.5});
  EXPECT_EQ(read_atlas_png16(path("flat.png"), l, enc, 1).values, flat.values);
  const UnormEncoding given{{0.0}, {2.0}};
  write_atlas_png16(path("given.png"), flat, l, given);
  for (float x : read_atlas_png16(path("given.png"), l, given, 1).values) EXPECT_EQ(x, 2.0f);
  flat.values[3] = NAN;
  EXPECT_NE(message_of([&] {
              write_atlas_png16(path("nan.png"), flat, l);
            }).find("nan.png: texel value nan (value index 3): a 16-bit PNG stores finite"),
            std::string::npos);
}

TEST_F(Atlas, Png16IsBitExactThroughImageMagick) {
  if (!std::filesystem::exists("/usr/bin/stream") || !std::filesystem::exists("/usr/bin/identify"))
    GTEST_SKIP() << "ImageMagick's stream and identify are missing (Debian package imagemagick)";
  for (int channels : {1, 2, 4})
    for (int border : {0, 1})
      for (const TextureVolume& v : {recognisable(channels), random_volume(channels, 11)}) {
        SCOPED_TRACE(v.name + ", channels " + std::to_string(channels) + ", border " +
                     std::to_string(border));
        const AtlasLayout l = atlas_layout(v.dims, border);
        const std::string file = path("a.png");
        const UnormEncoding enc = write_atlas_png16(file, v, l);
        bool ok = false;
        const std::string info =
            run("/usr/bin/identify -format '%w %h %z %[channels]' " + file, ok);
        ASSERT_TRUE(ok) << info;
        const char* kinds[] = {"lineargray", "lineargraya", "", "rgba"};
        EXPECT_EQ(info, std::to_string(l.width()) + " " + std::to_string(l.height()) + " 16 " +
                            kinds[channels - 1]);
        // stream writes the samples unconverted, 16 bits each in the machine's byte order.
        // (convert ... rgba:- is not raw here: it gamma-encodes a gAMA 1.0 RGB image to sRGB.)
        const char* maps[] = {"r", "ra", "", "rgba"};
        const std::string raw = run(std::string("/usr/bin/stream -quiet -map ") +
                                        maps[channels - 1] + " -storage-type short " + file + " -",
                                    ok);
        ASSERT_TRUE(ok);
        const std::vector<std::uint16_t> expected = expected_codes(v, l, enc);
        ASSERT_EQ(raw.size(), expected.size() * 2);
        std::vector<std::uint16_t> codes(expected.size());
        std::memcpy(codes.data(), raw.data(), raw.size());
        EXPECT_EQ(codes, expected);
      }
}

// The header of an OpenEXR file, parsed from its bytes (OpenEXR's file layout, not its library):
// the channels (name, pixel type 0 UINT, 1 HALF, 2 FLOAT), compression and data window.
struct ExrHeader {
  std::vector<std::pair<std::string, int>> channels;
  int compression = -1;
  int window[4] = {-1, -1, -1, -1};
};

ExrHeader parse_exr_header(const std::string& bytes) {
  ExrHeader h;
  auto i32 = [&](size_t at) {
    std::int32_t x;
    std::memcpy(&x, bytes.data() + at, 4);  // little-endian file, little-endian machine
    return x;
  };
  EXPECT_EQ(bytes.substr(0, 4), std::string("\x76\x2f\x31\x01", 4));
  EXPECT_EQ(bytes[4], 2);  // version 2, single-part scanline
  size_t at = 8;
  while (at < bytes.size() && bytes[at] != 0) {
    const std::string name = bytes.c_str() + at;
    at += name.size() + 1;
    const std::string type = bytes.c_str() + at;
    at += type.size() + 1;
    const int size = i32(at);
    at += 4;
    if (name == "channels") {
      size_t c = at;
      while (bytes[c] != 0) {
        const std::string channel = bytes.c_str() + c;
        c += channel.size() + 1;
        h.channels.emplace_back(channel, i32(c));
        c += 16;  // pixel type, pLinear + 3 reserved, x and y sampling
      }
    } else if (name == "compression") {
      h.compression = bytes[at];
    } else if (name == "dataWindow") {
      for (int n = 0; n < 4; ++n) h.window[n] = i32(at + 4 * n);
    }
    at += size;
  }
  return h;
}

TEST_F(Atlas, ExrRoundTripsHalfBitExactAndFloatExact) {
  for (int channels : {1, 2, 4})
    for (int border : {0, 1})
      for (const TextureVolume& v : {recognisable(channels), random_volume(channels, 13)}) {
        SCOPED_TRACE(v.name + ", channels " + std::to_string(channels) + ", border " +
                     std::to_string(border));
        const AtlasLayout l = atlas_layout(v.dims, border);
        write_atlas_exr(path("h.exr"), v, l, Storage::Half);
        write_atlas_exr(path("f.exr"), v, l, Storage::Float);
        const TextureVolume half = read_atlas_exr(path("h.exr"), l, channels);
        const TextureVolume full = read_atlas_exr(path("f.exr"), l, channels);
        ASSERT_EQ(half.values.size(), v.values.size());
        EXPECT_EQ(full.values, v.values);
        for (size_t t = 0; t < v.values.size(); ++t)
          EXPECT_EQ(half.values[t], half_bits_to_float(float_to_half_bits(v.values[t])))
              << "value " << t;
        const std::vector<std::string> names[] = {{"R"}, {"G", "R"}, {}, {"A", "B", "G", "R"}};
        for (const auto& [file, type] : {std::pair{"h.exr", 1}, std::pair{"f.exr", 2}}) {
          const ExrHeader h = parse_exr_header(read_bytes(path(file)));
          ASSERT_EQ(h.channels.size(), static_cast<size_t>(channels));
          for (int c = 0; c < channels; ++c) {
            EXPECT_EQ(h.channels[c].first, names[channels - 1][c]);
            EXPECT_EQ(h.channels[c].second, type);
          }
          EXPECT_EQ(h.compression, 3);  // ZIP_COMPRESSION
          EXPECT_EQ(h.window[0], 0);
          EXPECT_EQ(h.window[1], 0);
          EXPECT_EQ(h.window[2], l.width() - 1);
          EXPECT_EQ(h.window[3], l.height() - 1);
        }
      }
  // Half clamps magnitudes beyond 65504; float keeps them.
  TextureVolume big = recognisable(1);
  big.values[0] = 1e6f;
  big.values[1] = -1e6f;
  const AtlasLayout l = atlas_layout(big.dims);
  write_atlas_exr(path("big.exr"), big, l, Storage::Half);
  const TextureVolume back = read_atlas_exr(path("big.exr"), l, 1);
  EXPECT_EQ(back.values[0], 65504.0f);
  EXPECT_EQ(back.values[1], -65504.0f);
  EXPECT_NE(message_of([&] { read_atlas_exr(path("big.exr"), l, 4); }).find("no channel G"),
            std::string::npos);
  EXPECT_NE(message_of([&] {
              read_atlas_exr(path("big.exr"), atlas_layout({5, 4, 5}), 1);
            }).find("data window"),
            std::string::npos);
}

TEST_F(Atlas, ExrheaderListsTheChannels) {
  if (!std::filesystem::exists("/usr/bin/exrheader"))
    GTEST_SKIP() << "exrheader is missing (Debian package openexr)";
  const TextureVolume v = recognisable(4);
  write_atlas_exr(path("h.exr"), v, atlas_layout(v.dims), Storage::Half);
  bool ok = false;
  const std::string out = run("/usr/bin/exrheader " + path("h.exr"), ok);
  ASSERT_TRUE(ok) << out;
  for (const char* name : {"R, 16-bit floating-point", "G, 16-bit floating-point",
                           "B, 16-bit floating-point", "A, 16-bit floating-point", "zip"})
    EXPECT_NE(out.find(name), std::string::npos) << name << " not in\n" << out;
}

TEST_F(Atlas, WritesAtomicallyAndNamesThePathOnFailure) {
  const TextureVolume v = recognisable(4);
  const AtlasLayout l = atlas_layout(v.dims);
  const std::string missing = path("no/such/folder/a.png");
  EXPECT_NE(message_of([&] { write_atlas_png16(missing, v, l); }).find(missing + ": cannot write"),
            std::string::npos);
  EXPECT_NE(message_of([&] {
              write_atlas_exr(path("no/a.exr"), v, l, Storage::Half);
            }).find(path("no/a.exr") + ": cannot write"),
            std::string::npos);
  EXPECT_TRUE(listing().empty());
  EXPECT_NE(message_of([&] {
              read_atlas_png16(path("none.png"), l, unorm_encoding(v), 4);
            }).find("none.png: cannot open"),
            std::string::npos);
}

}  // namespace
}  // namespace raywarp
