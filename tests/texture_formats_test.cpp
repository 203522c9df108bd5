// Named after no one source: two formats (library/ktx2.h, library/dds.h), one suite.
// The KTX2 and DDS writers and readers of 3D float textures (library/ktx2.h, library/dds.h):
// round trips through our readers, header fields at their documented offsets, malformed files
// refused with an Error, and the files read back by readers that are not ours: ktx-parse (npm,
// through tests/js/ktx_read.mjs) for KTX2 and nvddsinfo (NVIDIA Texture Tools) for DDS.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "base/error.h"
#include "base/version.h"
#include "library/dds.h"
#include "library/ktx2.h"
#include "library/texture_volume.h"
#include "tests/temp_folder.h"

namespace raywarp {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;
using KeyValues = std::vector<std::pair<std::string, std::string>>;

constexpr int kChannelCounts[] = {1, 2, 4};
constexpr Storage kStorages[] = {Storage::Half, Storage::Float};

std::uint32_t u32(const Bytes& b, size_t at) {
  return b[at] | (b[at + 1] << 8) | (b[at + 2] << 16) | (std::uint32_t{b[at + 3]} << 24);
}
std::uint64_t u64(const Bytes& b, size_t at) {
  return u32(b, at) | (std::uint64_t{u32(b, at + 4)} << 32);
}
void set_u32(Bytes& b, size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}
void set_u64(Bytes& b, size_t at, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) b[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

// A volume whose first values are the awkward ones (signed zero, half subnormals, values past
// the largest half, infinities, NaN), then random values of many magnitudes.
TextureVolume make_volume(Eigen::Vector3i dims, int channels, unsigned seed = 1) {
  TextureVolume v;
  v.name = "test";
  v.dims = dims;
  v.channels = channels;
  v.values.resize(v.texels() * static_cast<size_t>(channels));
  const float special[] = {0.0f,
                           -0.0f,
                           1.0f,
                           -1.0f,
                           1e-7f,
                           -3e-5f,
                           6.1e-5f,
                           65504.0f,
                           70000.0f,
                           -1e9f,
                           1.0f / 3.0f,
                           std::numeric_limits<float>::infinity(),
                           -std::numeric_limits<float>::infinity(),
                           std::numeric_limits<float>::quiet_NaN(),
                           std::numeric_limits<float>::denorm_min()};
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> mantissa(-1.0f, 1.0f);
  std::uniform_int_distribution<int> exponent(-20, 20);
  for (size_t i = 0; i < v.values.size(); ++i)
    v.values[i] = i < std::size(special) ? special[i] : std::ldexp(mantissa(rng), exponent(rng));
  return v;
}

// What a reader should give back for x stored as `s`: the float itself, or the float of its half.
std::uint32_t stored_bits(float x, Storage s) {
  return std::bit_cast<std::uint32_t>(s == Storage::Half ? half_bits_to_float(float_to_half_bits(x))
                                                         : x);
}

void expect_same_volume(const TextureVolume& read, const TextureVolume& written, Storage s) {
  ASSERT_EQ(read.dims, written.dims);
  ASSERT_EQ(read.channels, written.channels);
  ASSERT_EQ(read.values.size(), written.values.size());
  int mismatches = 0;
  for (size_t i = 0; i < read.values.size(); ++i)
    if (std::bit_cast<std::uint32_t>(read.values[i]) != stored_bits(written.values[i], s) &&
        ++mismatches <= 5)
      ADD_FAILURE() << "value " << i << ": read " << read.values[i] << ", wrote "
                    << written.values[i] << " as " << storage_name(s);
  EXPECT_EQ(mismatches, 0);
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// ---------------------------------------------------------------------------------------------
// Round trips through our readers.

TEST(TextureFormats, RoundTripEveryChannelCountAndStorage) {
  for (int channels : kChannelCounts)
    for (Storage s : kStorages) {
      SCOPED_TRACE(std::to_string(channels) + " channels, " + storage_name(s));
      const TextureVolume v = make_volume({7, 5, 3}, channels, static_cast<unsigned>(channels));
      const KeyValues kv = {{"raywarp.export", R"({"box": [1, 2, 3], "name": "défo"})"}};
      const Ktx2File k = decode_ktx2(encode_ktx2(v, s, kv), "round.ktx2");
      EXPECT_EQ(k.storage, s);
      expect_same_volume(k.volume, v, s);
      EXPECT_EQ(k.key_values, (KeyValues{{"KTXorientation", "rdi"},
                                         {"KTXwriter", std::string("raywarp ") + kVersion},
                                         {"raywarp.export", kv[0].second}}));
      for (DdsHeader form : {DdsHeader::Dx10, DdsHeader::Legacy}) {
        Storage read_storage = s == Storage::Half ? Storage::Float : Storage::Half;
        const TextureVolume d = decode_dds(encode_dds(v, s, form), "round.dds", &read_storage);
        EXPECT_EQ(read_storage, s);
        expect_same_volume(d, v, s);
      }
    }
}

TEST(TextureFormats, SingleTexelAndFlatVolumesStayThreeDimensional) {
  for (const Eigen::Vector3i& dims : {Eigen::Vector3i(1, 1, 1), Eigen::Vector3i(9, 4, 1)}) {
    const TextureVolume v = make_volume(dims, 4);
    const Bytes k = encode_ktx2(v, Storage::Half, {});
    EXPECT_EQ(u32(k, 28), static_cast<std::uint32_t>(dims.z()));  // pixelDepth, never 0
    expect_same_volume(decode_ktx2(k, "flat.ktx2").volume, v, Storage::Half);
    const Bytes d = encode_dds(v, Storage::Float);
    EXPECT_EQ(u32(d, 24), static_cast<std::uint32_t>(dims.z()));
    expect_same_volume(decode_dds(d, "flat.dds"), v, Storage::Float);
  }
}

TEST(TextureFormats, WritersRefuseWhatTheyCannotStore) {
  TextureVolume rgb = make_volume({2, 2, 2}, 3);
  rgb.name = "deformation";
  const std::string k = error_of([&] { encode_ktx2(rgb, Storage::Half, {}); });
  EXPECT_NE(k.find("'deformation'"), std::string::npos) << k;
  EXPECT_NE(k.find("channels = 3"), std::string::npos) << k;
  EXPECT_NE(k.find("1, 2 or 4"), std::string::npos) << k;
  const std::string d = error_of([&] { encode_dds(rgb, Storage::Float); });
  EXPECT_NE(d.find("channels = 3"), std::string::npos) << d;

  TextureVolume empty = make_volume({2, 2, 2}, 1);
  empty.dims.z() = 0;
  empty.values.clear();
  EXPECT_NE(error_of([&] { encode_ktx2(empty, Storage::Half, {}); }).find("dims[2] = 0"),
            std::string::npos);
  EXPECT_NE(error_of([&] { encode_dds(empty, Storage::Half); }).find("dims[2] = 0"),
            std::string::npos);
  TextureVolume short_values = make_volume({2, 2, 2}, 2);
  short_values.values.pop_back();
  EXPECT_THROW(encode_ktx2(short_values, Storage::Float, {}), Error);
  EXPECT_THROW(encode_dds(short_values, Storage::Float), Error);

  const TextureVolume v = make_volume({2, 2, 2}, 1);
  for (const char* reserved : {"KTXcubemapIncomplete", "ktxFoo", "KTXswizzle"}) {
    const std::string e = error_of([&] { encode_ktx2(v, Storage::Half, {{reserved, "x"}}); });
    EXPECT_NE(e.find(reserved), std::string::npos) << e;
    EXPECT_NE(e.find("reserved"), std::string::npos) << e;
  }
  EXPECT_THROW(encode_ktx2(v, Storage::Half, {{"", "x"}}), Error);
  EXPECT_THROW(encode_ktx2(v, Storage::Half, {{std::string("a\0b", 3), "x"}}), Error);
  EXPECT_THROW(encode_ktx2(v, Storage::Half, {{"a", "1"}, {"a", "2"}}), Error);
  EXPECT_THROW(encode_ktx2(v, Storage::Half, {{"KTXorientation", "rd"}}), Error);
}

TEST(TextureFormats, CallerMaySetWriterAndOrientation) {
  const TextureVolume v = make_volume({2, 3, 4}, 2);
  const Ktx2File k = decode_ktx2(
      encode_ktx2(v, Storage::Float,
                  {{"zeta", ""}, {"KTXwriter", "baker 2"}, {"KTXorientation", "rui"}, {"b", "B"}}),
      "w.ktx2");
  EXPECT_EQ(
      k.key_values,
      (KeyValues{{"KTXorientation", "rui"}, {"KTXwriter", "baker 2"}, {"b", "B"}, {"zeta", ""}}));
}

// ---------------------------------------------------------------------------------------------
// Header bytes at the offsets the specifications give.

TEST(TextureFormats, Ktx2HeaderFields) {
  const TextureVolume v = make_volume({6, 5, 4}, 4);
  const KeyValues kv = {{"raywarp.export", "{\"k\": 1}"}, {"a.first", "1"}, {"Zed", "z"}};
  const Bytes b = encode_ktx2(v, Storage::Half, kv);
  const std::uint8_t identifier[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32,
                                       0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
  EXPECT_TRUE(std::equal(std::begin(identifier), std::end(identifier), b.begin()));
  EXPECT_EQ(u32(b, 12), 97u);  // vkFormat R16G16B16A16_SFLOAT
  EXPECT_EQ(u32(b, 16), 2u);   // typeSize
  EXPECT_EQ(u32(b, 20), 6u);   // pixelWidth
  EXPECT_EQ(u32(b, 24), 5u);   // pixelHeight
  EXPECT_EQ(u32(b, 28), 4u);   // pixelDepth
  EXPECT_EQ(u32(b, 32), 0u);   // layerCount
  EXPECT_EQ(u32(b, 36), 1u);   // faceCount
  EXPECT_EQ(u32(b, 40), 1u);   // levelCount
  EXPECT_EQ(u32(b, 44), 0u);   // supercompressionScheme
  const std::uint32_t dfd_offset = u32(b, 48), dfd_length = u32(b, 52);
  EXPECT_EQ(dfd_offset, 104u);  // right after the one-level index
  EXPECT_EQ(dfd_length, 92u);
  EXPECT_EQ(u32(b, dfd_offset), 92u);                   // dfdTotalSize
  EXPECT_EQ(u32(b, dfd_offset + 4), 0u);                // vendorId Khronos, descriptorType basic
  EXPECT_EQ(u32(b, dfd_offset + 8), 2u | (88u << 16));  // version 2, descriptorBlockSize 88
  EXPECT_EQ(u32(b, dfd_offset + 12), 1u | (1u << 8) | (1u << 16));  // RGBSDA, BT709, LINEAR
  EXPECT_EQ(u32(b, dfd_offset + 20), 8u);                           // bytesPlane0
  const std::uint32_t ids[4] = {0, 1, 2, 15};
  for (std::uint32_t c = 0; c < 4; ++c) {
    const size_t s = dfd_offset + 28 + 16 * c;
    EXPECT_EQ(u32(b, s), 16 * c | (15u << 16) | ((0xC0u | ids[c]) << 24)) << c;
    EXPECT_EQ(u32(b, s + 8), 0xBF800000u);   // sampleLower -1.0f
    EXPECT_EQ(u32(b, s + 12), 0x3F800000u);  // sampleUpper 1.0f
  }
  EXPECT_EQ(u64(b, 64), 0u);  // sgdByteOffset
  EXPECT_EQ(u64(b, 72), 0u);  // sgdByteLength
  const std::uint64_t level_offset = u64(b, 80), level_length = u64(b, 88);
  EXPECT_EQ(level_offset % 8, 0u);
  EXPECT_EQ(level_length, 6u * 5 * 4 * 8);
  EXPECT_EQ(u64(b, 96), level_length);
  EXPECT_EQ(level_offset + level_length, b.size());

  // Key/value data right after the DFD, sorted by key bytes, each value NUL-terminated.
  const std::uint32_t kvd_offset = u32(b, 56), kvd_length = u32(b, 60);
  EXPECT_EQ(kvd_offset, dfd_offset + dfd_length);
  EXPECT_EQ(kvd_length % 4, 0u);
  EXPECT_LE(kvd_offset + kvd_length, level_offset);
  std::vector<std::string> keys;
  for (size_t at = kvd_offset; at < kvd_offset + kvd_length;) {
    const std::uint32_t n = u32(b, at);
    const std::string entry(b.begin() + at + 4, b.begin() + at + 4 + n);
    keys.push_back(entry.substr(0, entry.find('\0')));
    EXPECT_EQ(entry.back(), '\0') << keys.back();
    at += (4 + n + 3) / 4 * 4;
  }
  EXPECT_EQ(keys, (std::vector<std::string>{"KTXorientation", "KTXwriter", "Zed", "a.first",
                                            "raywarp.export"}));
  EXPECT_TRUE(std::is_sorted(keys.begin(), keys.end()));

  // RGBA32F: vkFormat 109, typeSize 4, level aligned to its 16-byte texels.
  const Bytes f = encode_ktx2(v, Storage::Float, kv);
  EXPECT_EQ(u32(f, 12), 109u);
  EXPECT_EQ(u32(f, 16), 4u);
  EXPECT_EQ(u64(f, 80) % 16, 0u);
  // VkFormat numbers: {channels, SFLOAT16, SFLOAT32}.
  const std::uint32_t vk[3][3] = {{1, 76, 100}, {2, 83, 103}, {4, 97, 109}};
  for (const auto& [channels, half, single] : vk) {
    const TextureVolume w = make_volume({2, 2, 2}, static_cast<int>(channels));
    EXPECT_EQ(u32(encode_ktx2(w, Storage::Half, {}), 12), half);
    EXPECT_EQ(u32(encode_ktx2(w, Storage::Float, {}), 12), single);
  }
}

TEST(TextureFormats, DdsHeaderFields) {
  const TextureVolume v = make_volume({6, 5, 4}, 4);
  const Bytes b = encode_dds(v, Storage::Half);
  EXPECT_EQ(std::string(b.begin(), b.begin() + 4), "DDS ");
  EXPECT_EQ(u32(b, 4), 124u);  // dwSize
  // DDSD_CAPS | HEIGHT | WIDTH | PITCH | PIXELFORMAT | MIPMAPCOUNT | DEPTH
  EXPECT_EQ(u32(b, 8), 0x1u | 0x2u | 0x4u | 0x8u | 0x1000u | 0x20000u | 0x800000u);
  EXPECT_EQ(u32(b, 12), 5u);      // dwHeight
  EXPECT_EQ(u32(b, 16), 6u);      // dwWidth
  EXPECT_EQ(u32(b, 20), 6u * 8);  // dwPitchOrLinearSize: bytes per row
  EXPECT_EQ(u32(b, 24), 4u);      // dwDepth
  EXPECT_EQ(u32(b, 28), 1u);      // dwMipMapCount
  EXPECT_EQ(u32(b, 76), 32u);     // ddspf.dwSize
  EXPECT_EQ(u32(b, 80), 0x4u);    // DDPF_FOURCC
  EXPECT_EQ(std::string(b.begin() + 84, b.begin() + 88), "DX10");
  EXPECT_EQ(u32(b, 108), 0x1000u | 0x8u);  // DDSCAPS_TEXTURE | DDSCAPS_COMPLEX
  EXPECT_EQ(u32(b, 112), 0x200000u);       // DDSCAPS2_VOLUME
  EXPECT_EQ(u32(b, 128), 10u);             // DXGI_FORMAT_R16G16B16A16_FLOAT
  EXPECT_EQ(u32(b, 132), 4u);              // D3D10_RESOURCE_DIMENSION_TEXTURE3D
  EXPECT_EQ(u32(b, 136), 0u);              // miscFlag
  EXPECT_EQ(u32(b, 140), 1u);              // arraySize
  EXPECT_EQ(u32(b, 144), 4u);              // DDS_ALPHA_MODE_CUSTOM
  EXPECT_EQ(b.size(), 148u + 6 * 5 * 4 * 8);

  const Bytes legacy = encode_dds(v, Storage::Half, DdsHeader::Legacy);
  EXPECT_EQ(u32(legacy, 84), 113u);  // D3DFMT_A16B16G16R16F
  EXPECT_EQ(u32(legacy, 112), 0x200000u);
  EXPECT_EQ(legacy.size(), 128u + 6 * 5 * 4 * 8);
  EXPECT_TRUE(std::equal(b.begin() + 148, b.end(), legacy.begin() + 128));

  struct Expected {
    int channels;
    Storage s;
    std::uint32_t dxgi, d3dfmt;
  };
  const Expected formats[] = {{1, Storage::Half, 54, 111},  {2, Storage::Half, 34, 112},
                              {4, Storage::Half, 10, 113},  {1, Storage::Float, 41, 114},
                              {2, Storage::Float, 16, 115}, {4, Storage::Float, 2, 116}};
  for (const Expected& e : formats) {
    const TextureVolume w = make_volume({3, 2, 2}, e.channels);
    EXPECT_EQ(u32(encode_dds(w, e.s), 128), e.dxgi);
    EXPECT_EQ(u32(encode_dds(w, e.s, DdsHeader::Legacy), 84), e.d3dfmt);
  }
}

// ---------------------------------------------------------------------------------------------
// Malformed files: an Error naming the file, never a crash or a read out of bounds (the
// sanitizer build checks the latter).

// Decodes `bytes`; true if it was read, false if refused with an Error naming `where`.
bool decodes(const Bytes& bytes, bool ktx2, const std::string& where) {
  try {
    if (ktx2) {
      decode_ktx2(bytes, where);
    } else {
      decode_dds(bytes, where);
    }
    return true;
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(where + ": ", 0), 0u) << e.what();
    return false;
  }
}

TEST(TextureFormats, EveryTruncationIsRefused) {
  const TextureVolume v = make_volume({3, 2, 2}, 4);
  const Bytes k = encode_ktx2(v, Storage::Half, {{"raywarp.export", "{}"}});
  for (size_t n = 0; n < k.size(); ++n)
    EXPECT_FALSE(decodes(Bytes(k.begin(), k.begin() + n), true, "cut.ktx2")) << n;
  for (DdsHeader form : {DdsHeader::Dx10, DdsHeader::Legacy}) {
    const Bytes d = encode_dds(v, Storage::Float, form);
    for (size_t n = 0; n < d.size(); ++n)
      EXPECT_FALSE(decodes(Bytes(d.begin(), d.begin() + n), false, "cut.dds")) << n;
    Bytes longer = d;
    longer.push_back(0);
    EXPECT_FALSE(decodes(longer, false, "long.dds"));
  }
}

TEST(TextureFormats, RandomByteFlipsNeverCrash) {
  const TextureVolume v = make_volume({3, 2, 2}, 2);
  const Bytes files[] = {encode_ktx2(v, Storage::Half, {{"raywarp.export", "{\"a\": 1}"}}),
                         encode_ktx2(v, Storage::Float, {}), encode_dds(v, Storage::Half),
                         encode_dds(v, Storage::Float, DdsHeader::Legacy)};
  std::mt19937 rng(12345);
  int refused = 0;
  for (int f = 0; f < 4; ++f) {
    const bool ktx2 = f < 2;
    const Bytes& good = files[f];
    // Mostly in the headers, where a flip changes meaning; some anywhere.
    const size_t header = std::min<size_t>(good.size(), ktx2 ? 240 : 148);
    for (int trial = 0; trial < 3000; ++trial) {
      Bytes bad = good;
      const int flips = 1 + static_cast<int>(rng() % 4);
      for (int i = 0; i < flips; ++i) {
        const size_t at = (rng() % 4 ? rng() % header : rng() % bad.size());
        bad[at] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
      }
      refused += !decodes(bad, ktx2, "flipped");
    }
  }
  EXPECT_GT(refused, 1000);
}

TEST(TextureFormats, HostileFieldsAreRefusedWithReasons) {
  const TextureVolume v = make_volume({3, 2, 2}, 4);
  const Bytes k = encode_ktx2(v, Storage::Half, {});
  auto ktx_error = [&](const std::function<void(Bytes&)>& edit) {
    Bytes b = k;
    edit(b);
    return error_of([&] { decode_ktx2(b, "bad.ktx2"); });
  };
  EXPECT_NE(ktx_error([](Bytes& b) { b[0] = 'X'; }).find("not a KTX 2.0 file"), std::string::npos);
  EXPECT_NE(ktx_error([](Bytes& b) { set_u32(b, 12, 43); }).find("vkFormat 43"), std::string::npos);
  EXPECT_NE(ktx_error([](Bytes& b) { set_u32(b, 12, 90); }).find("vkFormat 90"),
            std::string::npos);  // RGB16F is not read
  EXPECT_NE(ktx_error([](Bytes& b) { set_u32(b, 40, 3); }).find("levelCount 3"), std::string::npos);
  EXPECT_NE(ktx_error([](Bytes& b) { set_u32(b, 32, 2); }).find("layerCount 2"), std::string::npos);
  EXPECT_NE(ktx_error([](Bytes& b) { set_u32(b, 36, 6); }).find("faceCount 6"), std::string::npos);
  EXPECT_NE(ktx_error([](Bytes& b) { set_u32(b, 44, 2); }).find("supercompressionScheme 2"),
            std::string::npos);
  EXPECT_NE(ktx_error([](Bytes& b) { set_u32(b, 28, 0); }).find("pixelDepth 0"), std::string::npos);
  EXPECT_NE(ktx_error([](Bytes& b) {
              set_u32(b, 20, 0x80000000u), set_u32(b, 24, 0x80000000u), set_u32(b, 28, 7);
            }).find("2^30"),
            std::string::npos);
  EXPECT_NE(ktx_error([](Bytes& b) { set_u64(b, 80, ~std::uint64_t{0} - 8); }).find("level 0"),
            std::string::npos);
  EXPECT_NE(ktx_error([](Bytes& b) { set_u32(b, 60, 0xFFFFFFF0u); }).find("key/value data"),
            std::string::npos);
  EXPECT_NE(ktx_error([](Bytes& b) { set_u32(b, u32(b, 56), 0x7FFFFFFFu); }).find("key/value"),
            std::string::npos);
  EXPECT_NE(ktx_error([](Bytes& b) { set_u32(b, 52, 60); }).find("data format descriptor"),
            std::string::npos);

  const Bytes d = encode_dds(v, Storage::Half);
  auto dds_error = [&](const std::function<void(Bytes&)>& edit) {
    Bytes b = d;
    edit(b);
    return error_of([&] { decode_dds(b, "bad.dds"); });
  };
  EXPECT_NE(dds_error([](Bytes& b) { b[3] = 'Z'; }).find("not a DDS file"), std::string::npos);
  EXPECT_NE(dds_error([](Bytes& b) { set_u32(b, 128, 28); }).find("DXGI format 28"),
            std::string::npos);
  EXPECT_NE(dds_error([](Bytes& b) { set_u32(b, 132, 3); }).find("resourceDimension 3"),
            std::string::npos);
  EXPECT_NE(dds_error([](Bytes& b) { set_u32(b, 140, 0); }).find("arraySize 0"), std::string::npos);
  EXPECT_NE(dds_error([](Bytes& b) { set_u32(b, 28, 3); }).find("mipMapCount 3"),
            std::string::npos);
  EXPECT_NE(dds_error([](Bytes& b) {
              set_u32(b, 12, 0xFFFFFFFFu), set_u32(b, 16, 0xFFFFFFFFu), set_u32(b, 24, 9);
            }).find("2^30"),
            std::string::npos);
  EXPECT_NE(dds_error([](Bytes& b) { set_u32(b, 84, 0x31545844); }).find("FourCC"),
            std::string::npos);  // "DXT1"
  EXPECT_NE(dds_error([](Bytes& b) { set_u32(b, 8, 0x100F), set_u32(b, 112, 0); }).find("volume"),
            std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// Readers that are not ours, run as processes.

struct Process {
  int code = -1;
  std::string output;  // stdout
};

Process run(const std::string& command) {
  Process r;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) r.output.append(buf, n);
  const int status = pclose(pipe);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

bool have(const std::string& tool) {
  return run("command -v " + tool + " >/dev/null 2>&1").code == 0;
}

std::string quoted(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string hex(Bytes::const_iterator begin, Bytes::const_iterator end) {
  static const char* digits = "0123456789abcdef";
  std::string s;
  for (auto it = begin; it != end; ++it) {
    s += digits[*it >> 4];
    s += digits[*it & 15];
  }
  return s;
}

std::string text_hex(const std::string& s) {
  const Bytes b(s.begin(), s.end());
  return hex(b.begin(), b.end());
}

void write_bytes(const std::string& path, const Bytes& b) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
  ASSERT_TRUE(out.good()) << path;
}

class ExternalReaders : public TempFolderTest {};

TEST_F(ExternalReaders, KtxParseReadsWhatWeWrote) {
  const fs::path js = fs::path(RAYWARP_SOURCE_DIR) / "tests" / "js";
  if (!have("node"))
    GTEST_SKIP() << "node is not installed, so ktx-parse cannot check the KTX2 files: install "
                    "Node.js (Debian package nodejs), then run `npm ci` in "
                 << js.string();
  if (!fs::exists(js / "node_modules" / "ktx-parse" / "package.json"))
    GTEST_SKIP() << "ktx-parse is not installed, so the KTX2 files are not checked by an "
                    "independent reader: run `npm ci` in "
                 << js.string();
  const std::string json_text = R"({"box": "a\"b", "size": [1, 2, 3], "ünïcode": "✓"})";
  for (int channels : kChannelCounts)
    for (Storage s : kStorages) {
      SCOPED_TRACE(std::to_string(channels) + " channels, " + storage_name(s));
      const TextureVolume v = make_volume({5, 3, 2}, channels, 7);
      const KeyValues kv = {{"raywarp.export", json_text}, {"raywarp.note", "second"}};
      const Bytes b = encode_ktx2(v, s, kv);
      const std::string file = path("v.ktx2");
      write_bytes(file, b);
      const Process r = run("node " + quoted((js / "ktx_read.mjs").string()) + " " + quoted(file) +
                            " 2>" + quoted(path("stderr.txt")));
      std::ifstream err_in(path("stderr.txt"));
      const std::string err((std::istreambuf_iterator<char>(err_in)), {});
      ASSERT_EQ(r.code, 0) << "ktx_read.mjs failed: " << err << r.output;
      const nlohmann::json j = nlohmann::json::parse(r.output);
      if (channels == 4 && s == Storage::Half)
        std::cout << "ktx-parse: " << r.output.substr(0, 300) << "...\n";
      const std::uint32_t vk[2][5] = {{0, 76, 83, 0, 97}, {0, 100, 103, 0, 109}};
      const int type_size = s == Storage::Half ? 2 : 4;
      EXPECT_EQ(j["vkFormat"], vk[s == Storage::Float][channels]);
      EXPECT_EQ(j["typeSize"], type_size);
      EXPECT_EQ(j["pixelWidth"], 5);
      EXPECT_EQ(j["pixelHeight"], 3);
      EXPECT_EQ(j["pixelDepth"], 2);
      EXPECT_EQ(j["layerCount"], 0);
      EXPECT_EQ(j["faceCount"], 1);
      EXPECT_EQ(j["levelCount"], 1);
      EXPECT_EQ(j["supercompressionScheme"], 0);

      ASSERT_EQ(j["dataFormatDescriptor"].size(), 1u);
      const nlohmann::json& dfd = j["dataFormatDescriptor"][0];
      EXPECT_EQ(dfd["vendorId"], 0);
      EXPECT_EQ(dfd["descriptorType"], 0);
      EXPECT_EQ(dfd["versionNumber"], 2);
      EXPECT_EQ(dfd["colorModel"], 1);        // RGBSDA
      EXPECT_EQ(dfd["colorPrimaries"], 1);    // BT709
      EXPECT_EQ(dfd["transferFunction"], 1);  // LINEAR
      EXPECT_EQ(dfd["flags"], 0);             // alpha straight
      EXPECT_EQ(dfd["texelBlockDimension"], nlohmann::json({0, 0, 0, 0}));
      EXPECT_EQ(dfd["bytesPlane"], nlohmann::json({channels * type_size, 0, 0, 0, 0, 0, 0, 0}));
      ASSERT_EQ(dfd["samples"].size(), static_cast<size_t>(channels));
      const int ids[4] = {0, 1, 2, 15};
      for (int c = 0; c < channels; ++c) {
        const nlohmann::json& sample = dfd["samples"][c];
        EXPECT_EQ(sample["bitOffset"], 8 * type_size * c);
        EXPECT_EQ(sample["bitLength"], 8 * type_size - 1);       // stored minus one
        EXPECT_EQ(sample["channelType"], 0x80 | 0x40 | ids[c]);  // FLOAT | SIGNED | id
        EXPECT_EQ(sample["samplePosition"], nlohmann::json({0, 0, 0, 0}));
        EXPECT_EQ(sample["sampleLower"], 0xBF800000u);
        EXPECT_EQ(sample["sampleUpper"], 0x3F800000u);
      }

      const nlohmann::json& kvs = j["keyValues"];
      ASSERT_EQ(kvs.size(), 4u) << kvs.dump();
      const KeyValues expected = {{"KTXorientation", "rdi"},
                                  {"KTXwriter", std::string("raywarp ") + kVersion},
                                  {"raywarp.export", json_text},
                                  {"raywarp.note", "second"}};
      for (size_t i = 0; i < expected.size(); ++i) {
        EXPECT_EQ(kvs[i]["key"], expected[i].first);
        EXPECT_EQ(kvs[i]["text"], expected[i].second);
        if (i >= 2) {  // raw bytes, as ktx-parse keeps them for non-KTX keys: value and its NUL
          EXPECT_EQ(kvs[i]["hex"], text_hex(expected[i].second) + "00");
        }
      }

      ASSERT_EQ(j["levels"].size(), 1u);
      const nlohmann::json& level = j["levels"][0];
      const size_t level_offset = u64(b, 80), level_length = u64(b, 88);
      EXPECT_EQ(level["byteLength"], level_length);
      EXPECT_EQ(level["uncompressedByteLength"], level_length);
      EXPECT_EQ(level_length, v.values.size() * static_cast<size_t>(type_size));
      EXPECT_EQ(level["hex"],
                hex(b.begin() + level_offset, b.begin() + level_offset + level_length));
    }
}

TEST_F(ExternalReaders, NvddsinfoReadsWhatWeWrote) {
  if (!have("nvddsinfo"))
    GTEST_SKIP() << "nvddsinfo is not installed, so the DDS files are not checked by an "
                    "independent reader: install NVIDIA Texture Tools (Debian package libnvtt-bin)";
  struct Case {
    int channels;
    Storage s;
    const char* dxgi;  // as nvddsinfo prints it
    std::uint32_t d3dfmt;
  };
  const Case cases[] = {{1, Storage::Half, "54 (R16_FLOAT)", 111},
                        {2, Storage::Half, "34 (R16G16_FLOAT)", 112},
                        {4, Storage::Half, "10 (R16G16B16A16_FLOAT)", 113},
                        {1, Storage::Float, "41 (R32_FLOAT)", 114},
                        {2, Storage::Float, "16 (R32G32_FLOAT)", 115},
                        {4, Storage::Float, "2 (R32G32B32A32_FLOAT)", 116}};
  // The value after "name:" on the line that starts (after tabs) with name, or "" if none.
  auto field = [](const std::string& text, const std::string& name) {
    std::istringstream lines(text);
    for (std::string line; std::getline(lines, line);) {
      const size_t start = line.find_first_not_of('\t');
      if (start != std::string::npos && line.compare(start, name.size() + 1, name + ":") == 0)
        return line.substr(line.find_first_not_of(' ', start + name.size() + 1));
    }
    return std::string();
  };
  for (const Case& c : cases)
    for (DdsHeader form : {DdsHeader::Dx10, DdsHeader::Legacy}) {
      const bool dx10 = form == DdsHeader::Dx10;
      SCOPED_TRACE(std::string(c.dxgi) + (dx10 ? ", DX10 header" : ", legacy header"));
      const TextureVolume v = make_volume({7, 5, 3}, c.channels);
      const std::string file = path("v.dds");
      write_bytes(file, encode_dds(v, c.s, form));
      const Process r = run("nvddsinfo " + quoted(file) + " 2>&1");
      ASSERT_EQ(r.code, 0) << r.output;
      if (c.channels == 4 && c.s == Storage::Half)
        std::cout << "nvddsinfo (" << (dx10 ? "DX10" : "legacy")
                  << "): " << field(r.output, "Width") << "x" << field(r.output, "Height") << "x"
                  << field(r.output, "Depth") << ", FourCC "
                  << (dx10 ? field(r.output, "FourCC")
                           : "'\\" + std::to_string(field(r.output, "FourCC")[1]) + "\\0\\0\\0'")
                  << (dx10 ? ", DXGI Format " + field(r.output, "DXGI Format") +
                                 ", Resource dimension " + field(r.output, "Resource dimension")
                           : std::string())
                  << "\n";
      EXPECT_EQ(field(r.output, "Width"), "7") << r.output;
      EXPECT_EQ(field(r.output, "Height"), "5");
      EXPECT_EQ(field(r.output, "Depth"), "3");
      EXPECT_EQ(field(r.output, "Mipmap count"), "1");
      EXPECT_EQ(field(r.output, "Pitch"),
                std::to_string(7 * c.channels * (c.s == Storage::Half ? 2 : 4)));
      EXPECT_EQ(field(r.output, "Caps 2"), "0x00200000");
      EXPECT_NE(r.output.find("DDSCAPS2_VOLUME"), std::string::npos);
      EXPECT_NE(r.output.find("DDSD_DEPTH"), std::string::npos);
      if (dx10) {
        EXPECT_EQ(field(r.output, "FourCC"), "'DX10'");
        EXPECT_EQ(field(r.output, "DXGI Format"), c.dxgi);
        EXPECT_EQ(field(r.output, "Resource dimension"), "4 (TEXTURE3D)");
        EXPECT_EQ(field(r.output, "Array size"), "1");
      } else {
        // nvddsinfo prints the FourCC as its 4 bytes; a D3DFORMAT number is one byte and 3 NULs.
        const std::string four_cc = field(r.output, "FourCC");
        ASSERT_EQ(four_cc.size(), 6u) << four_cc;
        EXPECT_EQ(static_cast<unsigned char>(four_cc[1]), c.d3dfmt) << four_cc;
        EXPECT_EQ(r.output.find("DX10 Header"), std::string::npos);
      }
    }
}

TEST_F(ExternalReaders, KtxValidateAcceptsWhatWeWrote) {
  if (!have("ktx"))
    GTEST_SKIP() << "KTX-Software's `ktx validate` is not installed, so the KTX2 files are not "
                    "checked against the spec's validator: install KTX-Software 4.3 or later "
                    "(https://github.com/KhronosGroup/KTX-Software/releases; not packaged by "
                    "Debian)";
  for (int channels : kChannelCounts)
    for (Storage s : kStorages) {
      const std::string file = path("v.ktx2");
      write_bytes(file, encode_ktx2(make_volume({5, 3, 2}, channels), s,
                                    {{"raywarp.export", "{\"a\": 1}"}}));
      const Process r = run("ktx validate " + quoted(file) + " 2>&1");
      EXPECT_EQ(r.code, 0) << channels << " channels, " << storage_name(s) << ": " << r.output;
    }
}

}  // namespace
}  // namespace raywarp
