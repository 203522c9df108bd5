#include "library/ktx2.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <numeric>
#include <set>

#include "base/error.h"
#include "base/version.h"

namespace raywarp {
namespace {

// File identifier: «KTX 20»\r\n\x1A\n.
constexpr std::array<std::uint8_t, 12> kIdentifier = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32,
                                                      0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
// Header (after the identifier, all little endian): vkFormat, typeSize, pixelWidth,
// pixelHeight, pixelDepth, layerCount, faceCount, levelCount, supercompressionScheme (uint32 at
// 12..44); then the index: dfdByteOffset, dfdByteLength, kvdByteOffset, kvdByteLength (uint32 at
// 48..60), sgdByteOffset, sgdByteLength (uint64 at 64, 72); then the level index at 80, per level
// byteOffset, byteLength, uncompressedByteLength (uint64).
constexpr size_t kLevelIndexOffset = 80;
constexpr size_t kLevelIndexEntry = 24;
constexpr std::uint64_t kMaxLevelBytes = std::uint64_t{1} << 30;

// Data Format Descriptor (Khronos Data Format Specification 1.3, "Basic Data Format Descriptor
// Block"): uint32 dfdTotalSize, then one block of 6 words + 4 words per sample.
constexpr std::uint32_t kDfModelRgbsda = 1;      // KHR_DF_MODEL_RGBSDA
constexpr std::uint32_t kDfPrimariesBt709 = 1;   // KHR_DF_PRIMARIES_BT709
constexpr std::uint32_t kDfTransferLinear = 1;   // KHR_DF_TRANSFER_LINEAR
constexpr std::uint32_t kDfVersion = 2;          // KHR_DF_VERSIONNUMBER_1_3
constexpr std::uint32_t kDfSampleFloat = 0x80;   // KHR_DF_SAMPLE_DATATYPE_FLOAT (channelType bit 7)
constexpr std::uint32_t kDfSampleSigned = 0x40;  // KHR_DF_SAMPLE_DATATYPE_SIGNED (bit 6)
// Channel ids of the RGBSDA model: R 0, G 1, B 2, A 15.
constexpr std::array<std::uint32_t, 4> kDfChannelIds = {0, 1, 2, 15};
// sampleLower/sampleUpper of an SFLOAT sample, of either width: the float32 bits of -1.0 and 1.0
// (the range that maps to the normalised colour range, as KTX-Software's createdfd writes).
constexpr std::uint32_t kSfloatLower = 0xBF800000u;
constexpr std::uint32_t kSfloatUpper = 0x3F800000u;

struct Format {
  std::uint32_t vk_format;
  int channels;
  Storage storage;
};
// VkFormat numbers (Vulkan's VkFormat enum).
constexpr std::array<Format, 6> kFormats = {{
    {76, 1, Storage::Half},    // VK_FORMAT_R16_SFLOAT
    {83, 2, Storage::Half},    // VK_FORMAT_R16G16_SFLOAT
    {97, 4, Storage::Half},    // VK_FORMAT_R16G16B16A16_SFLOAT
    {100, 1, Storage::Float},  // VK_FORMAT_R32_SFLOAT
    {103, 2, Storage::Float},  // VK_FORMAT_R32G32_SFLOAT
    {109, 4, Storage::Float},  // VK_FORMAT_R32G32B32A32_SFLOAT
}};

constexpr const char* kWriterKey = "KTXwriter";
constexpr const char* kOrientationKey = "KTXorientation";
// KTXorientation of a 3D texture: x to the right, y down, z into the screen, i.e. the first
// texel of the data is the top-left-front one (the spec's default order of the level data).
constexpr const char* kOrientation = "rdi";

size_t align_up(size_t n, size_t a) { return (n + a - 1) / a * a; }

std::string volume_label(const TextureVolume& v) {
  return "KTX2 export of texture '" + v.name + "'";
}

// The Basic DFD of a float format with `channels` samples of `bytes` bytes each, little endian.
std::vector<std::uint32_t> basic_dfd(int channels, int bytes) {
  const std::uint32_t block_size = 4 * (6 + 4 * static_cast<std::uint32_t>(channels));
  std::vector<std::uint32_t> w;
  w.push_back(4 + block_size);  // dfdTotalSize
  w.push_back(0);               // vendorId 0 (Khronos) | descriptorType 0 (basic) << 17
  w.push_back(kDfVersion | (block_size << 16));  // versionNumber | descriptorBlockSize << 16
  // colorModel | colorPrimaries << 8 | transferFunction << 16 | flags (alpha straight 0) << 24
  w.push_back(kDfModelRgbsda | (kDfPrimariesBt709 << 8) | (kDfTransferLinear << 16));
  w.push_back(0);  // texelBlockDimension0..3: each stored minus one, so 1x1x1x1
  w.push_back(static_cast<std::uint32_t>(channels * bytes));  // bytesPlane0 (bytesPlane1..3 0)
  w.push_back(0);                                             // bytesPlane4..7
  for (int c = 0; c < channels; ++c) {
    const std::uint32_t bits = 8 * static_cast<std::uint32_t>(bytes);
    // bitOffset | (bitLength - 1) << 16 | (channelId | qualifiers) << 24
    w.push_back(bits * c | ((bits - 1) << 16) |
                ((kDfChannelIds[c] | kDfSampleFloat | kDfSampleSigned) << 24));
    w.push_back(0);  // samplePosition0..3
    w.push_back(kSfloatLower);
    w.push_back(kSfloatUpper);
  }
  return w;
}

void check_volume(const TextureVolume& v) {
  const std::string label = volume_label(v);
  if (v.channels != 1 && v.channels != 2 && v.channels != 4)
    throw Error(label + ": channels = " + std::to_string(v.channels) +
                ": KTX2 float textures are written with 1, 2 or 4 channels (R, RG, RGBA)");
  for (int a = 0; a < 3; ++a)
    if (v.dims[a] < 1)
      throw Error(label + ": dims[" + std::to_string(a) + "] = " + std::to_string(v.dims[a]) +
                  ": must be >= 1");
  if (v.values.size() != v.texels() * static_cast<size_t>(v.channels))
    throw Error(label + ": " + std::to_string(v.values.size()) + " values for " +
                std::to_string(v.texels()) + " texels of " + std::to_string(v.channels) +
                " channels");
}

bool valid_orientation(const std::string& s) {
  return s.size() == 3 && (s[0] == 'r' || s[0] == 'l') && (s[1] == 'd' || s[1] == 'u') &&
         (s[2] == 'o' || s[2] == 'i');
}

}  // namespace

std::vector<std::uint8_t> encode_ktx2(
    const TextureVolume& v, Storage s,
    const std::vector<std::pair<std::string, std::string>>& key_values) {
  check_volume(v);
  const std::string label = volume_label(v);
  const Format* format = nullptr;
  for (const Format& f : kFormats)
    if (f.channels == v.channels && f.storage == s) format = &f;
  const size_t texel_bytes = static_cast<size_t>(v.channels * storage_bytes(s));
  const std::uint64_t level_bytes = v.texels() * texel_bytes;
  if (level_bytes > kMaxLevelBytes)
    throw Error(label + ": " + std::to_string(level_bytes) +
                " bytes of texels: at most 2^30 bytes are written");

  // Key/value data: sorted by the keys' bytes; reserved KTX keys only the two the writer knows.
  std::vector<std::pair<std::string, std::string>> kv;
  std::set<std::string> seen;
  for (const auto& [key, value] : key_values) {
    if (key.empty()) throw Error(label + ": a metadata key is empty");
    if (key.find('\0') != std::string::npos)
      throw Error(label + ": metadata key '" + key + "' contains a NUL byte");
    const bool reserved = key.rfind("KTX", 0) == 0 || key.rfind("ktx", 0) == 0;
    if (reserved && key != kWriterKey && key != kOrientationKey)
      throw Error(label + ": metadata key '" + key +
                  "': keys starting with KTX or ktx are reserved by the KTX2 spec (only " +
                  kOrientationKey + " and " + kWriterKey + " may be given)");
    if (key == kOrientationKey && !valid_orientation(value))
      throw Error(label + ": KTXorientation '" + value +
                  "': a 3D texture's orientation is 3 letters, [rl][du][oi]");
    if (value.size() > kMaxLevelBytes)
      throw Error(label + ": metadata value of '" + key + "' is over 2^30 bytes");
    if (!seen.insert(key).second) throw Error(label + ": metadata key '" + key + "' given twice");
    kv.emplace_back(key, value);
  }
  if (!seen.count(kOrientationKey)) kv.emplace_back(kOrientationKey, kOrientation);
  if (!seen.count(kWriterKey)) kv.emplace_back(kWriterKey, std::string("raywarp ") + kVersion);
  std::sort(kv.begin(), kv.end());  // std::string compares as unsigned bytes (char_traits<char>)

  const std::vector<std::uint32_t> dfd = basic_dfd(v.channels, storage_bytes(s));
  const size_t dfd_offset = kLevelIndexOffset + kLevelIndexEntry;  // one level
  const size_t dfd_length = 4 * dfd.size();
  const size_t kvd_offset = dfd_offset + dfd_length;
  size_t kvd_length = 0;
  for (const auto& [key, value] : kv)
    kvd_length += align_up(4 + key.size() + 1 + value.size() + 1, 4);
  if (kvd_length > kMaxLevelBytes) throw Error(label + ": metadata over 2^30 bytes");
  // Level data aligned to lcm(texel block size, 4) from the start of the file (mipPadding).
  const size_t level_alignment = std::lcm(texel_bytes, size_t{4});
  const size_t level_offset = align_up(kvd_offset + kvd_length, level_alignment);

  std::vector<std::uint8_t> out(level_offset + level_bytes, 0);
  std::copy(kIdentifier.begin(), kIdentifier.end(), out.begin());
  put_u32(out, 12, format->vk_format);
  put_u32(out, 16, static_cast<std::uint32_t>(storage_bytes(s)));  // typeSize
  put_u32(out, 20, static_cast<std::uint32_t>(v.dims.x()));        // pixelWidth
  put_u32(out, 24, static_cast<std::uint32_t>(v.dims.y()));        // pixelHeight
  put_u32(out, 28, static_cast<std::uint32_t>(v.dims.z()));        // pixelDepth (> 0: 3D)
  put_u32(out, 32, 0);                                             // layerCount (0: not an array)
  put_u32(out, 36, 1);                                             // faceCount
  put_u32(out, 40, 1);                                             // levelCount (no mipmaps)
  put_u32(out, 44, 0);                                             // supercompressionScheme none
  put_u32(out, 48, static_cast<std::uint32_t>(dfd_offset));
  put_u32(out, 52, static_cast<std::uint32_t>(dfd_length));
  put_u32(out, 56, static_cast<std::uint32_t>(kvd_offset));
  put_u32(out, 60, static_cast<std::uint32_t>(kvd_length));
  put_u64(out, 64, 0);  // sgdByteOffset: no supercompression global data
  put_u64(out, 72, 0);  // sgdByteLength
  put_u64(out, kLevelIndexOffset, level_offset);
  put_u64(out, kLevelIndexOffset + 8, level_bytes);   // byteLength
  put_u64(out, kLevelIndexOffset + 16, level_bytes);  // uncompressedByteLength
  for (size_t i = 0; i < dfd.size(); ++i) put_u32(out, dfd_offset + 4 * i, dfd[i]);
  // Each entry: uint32 keyAndValueByteLength, key, NUL, value (here with its own NUL), then
  // valuePadding to a multiple of 4 (zeros, already there).
  size_t at = kvd_offset;
  for (const auto& [key, value] : kv) {
    const size_t length = key.size() + 1 + value.size() + 1;
    put_u32(out, at, static_cast<std::uint32_t>(length));
    std::memcpy(out.data() + at + 4, key.data(), key.size());
    std::memcpy(out.data() + at + 4 + key.size() + 1, value.data(), value.size());
    at += align_up(4 + length, 4);
  }
  pack_texels(v.values, s, out.data() + level_offset);
  return out;
}

Ktx2File decode_ktx2(const std::vector<std::uint8_t>& bytes, const std::string& where) {
  auto fail = [&](const std::string& what) -> Error { return Error(where + ": " + what); };
  const size_t size = bytes.size();
  if (size < kLevelIndexOffset + kLevelIndexEntry)
    throw fail(std::to_string(size) + " bytes: too short for a KTX2 header (104 bytes)");
  if (!std::equal(kIdentifier.begin(), kIdentifier.end(), bytes.begin()))
    throw fail("not a KTX 2.0 file (the identifier «KTX 20»\\r\\n\\x1A\\n is missing)");

  const std::uint32_t vk_format = get_u32(bytes, 12);
  const Format* format = nullptr;
  for (const Format& f : kFormats)
    if (f.vk_format == vk_format) format = &f;
  if (!format)
    throw fail("vkFormat " + std::to_string(vk_format) +
               ": only R16_SFLOAT (76), R16G16_SFLOAT (83), R16G16B16A16_SFLOAT (97), R32_SFLOAT "
               "(100), R32G32_SFLOAT (103) and R32G32B32A32_SFLOAT (109) are read");
  const int bytes_per_channel = storage_bytes(format->storage);
  const std::uint32_t type_size_field = get_u32(bytes, 16);
  if (type_size_field != static_cast<std::uint32_t>(bytes_per_channel))
    throw fail("typeSize " + std::to_string(type_size_field) + ": must be " +
               std::to_string(bytes_per_channel) + " for vkFormat " + std::to_string(vk_format));
  const std::uint32_t width = get_u32(bytes, 20), height = get_u32(bytes, 24),
                      depth = get_u32(bytes, 28);
  if (width == 0 || height == 0)
    throw fail("pixelWidth " + std::to_string(width) + ", pixelHeight " + std::to_string(height) +
               ": must be >= 1");
  if (depth == 0) throw fail("pixelDepth 0 (a 1D or 2D texture): only 3D textures are read");
  const std::uint32_t layers = get_u32(bytes, 32), faces = get_u32(bytes, 36),
                      levels = get_u32(bytes, 40), scheme = get_u32(bytes, 44);
  if (layers != 0) throw fail("layerCount " + std::to_string(layers) + ": arrays are not read (0)");
  if (faces != 1) throw fail("faceCount " + std::to_string(faces) + ": must be 1 (no cube maps)");
  if (levels != 1) throw fail("levelCount " + std::to_string(levels) + ": must be 1 (no mipmaps)");
  if (scheme != 0)
    throw fail("supercompressionScheme " + std::to_string(scheme) + ": must be 0 (none)");

  const size_t texel_bytes = static_cast<size_t>(format->channels * bytes_per_channel);
  std::uint64_t texels = width;
  for (std::uint64_t n : {std::uint64_t{height}, std::uint64_t{depth}}) {
    texels *= n;
    if (texels > kMaxLevelBytes) break;
  }
  const std::uint64_t level_bytes = texels > kMaxLevelBytes ? texels : texels * texel_bytes;
  if (level_bytes > kMaxLevelBytes)
    throw fail(std::to_string(width) + "x" + std::to_string(height) + "x" + std::to_string(depth) +
               " texels: over 2^30 bytes, not read");

  // The index: each section inside the file.
  auto check_range = [&](const char* name, std::uint64_t offset, std::uint64_t length) {
    if (offset > size || length > size - offset)
      throw fail(std::string(name) + " (offset " + std::to_string(offset) + ", length " +
                 std::to_string(length) + ") runs past the end of the file (" +
                 std::to_string(size) + " bytes)");
  };
  const std::uint32_t dfd_offset = get_u32(bytes, 48), dfd_length = get_u32(bytes, 52);
  const std::uint32_t kvd_offset = get_u32(bytes, 56), kvd_length = get_u32(bytes, 60);
  const std::uint64_t sgd_length = get_u64(bytes, 72);
  check_range("data format descriptor", dfd_offset, dfd_length);
  check_range("key/value data", kvd_offset, kvd_length);
  if (sgd_length != 0)
    throw fail("sgdByteLength " + std::to_string(sgd_length) +
               ": must be 0 (no supercompression global data)");
  const std::uint64_t level_offset = get_u64(bytes, kLevelIndexOffset);
  const std::uint64_t level_length = get_u64(bytes, kLevelIndexOffset + 8);
  const std::uint64_t level_uncompressed = get_u64(bytes, kLevelIndexOffset + 16);
  if (level_length != level_bytes || level_uncompressed != level_bytes)
    throw fail("level 0 byteLength " + std::to_string(level_length) + ", uncompressedByteLength " +
               std::to_string(level_uncompressed) + ": must be " + std::to_string(level_bytes) +
               " for " + std::to_string(width) + "x" + std::to_string(height) + "x" +
               std::to_string(depth) + " texels of " + std::to_string(texel_bytes) + " bytes");
  check_range("level 0", level_offset, level_length);
  if (level_offset % std::lcm(texel_bytes, size_t{4}) != 0)
    throw fail("level 0 byteOffset " + std::to_string(level_offset) + ": must be a multiple of " +
               std::to_string(std::lcm(texel_bytes, size_t{4})));

  // The DFD: one Basic block describing exactly this format.
  const std::uint32_t expected_block = 4 * (6 + 4 * static_cast<std::uint32_t>(format->channels));
  if (dfd_length != 4 + expected_block || get_u32(bytes, dfd_offset) != dfd_length)
    throw fail("data format descriptor of " + std::to_string(dfd_length) +
               " bytes: a Basic DFD of " + std::to_string(format->channels) + " samples is " +
               std::to_string(4 + expected_block) + " bytes, with dfdTotalSize the same");
  {
    const size_t b = dfd_offset + 4;
    const std::uint32_t type_word = get_u32(bytes, b), version_word = get_u32(bytes, b + 4);
    const std::uint32_t model_word = get_u32(bytes, b + 8);
    if (type_word != 0 || (version_word >> 16) != expected_block)
      throw fail("data format descriptor: not a Khronos Basic block of " +
                 std::to_string(format->channels) + " samples");
    if ((model_word & 0xFF) != kDfModelRgbsda)
      throw fail("data format descriptor: colorModel " + std::to_string(model_word & 0xFF) +
                 ": must be 1 (RGBSDA)");
    if ((get_u32(bytes, b + 16) & 0xFF) != texel_bytes)
      throw fail("data format descriptor: bytesPlane0 " +
                 std::to_string(get_u32(bytes, b + 16) & 0xFF) + ": must be " +
                 std::to_string(texel_bytes));
    const std::uint32_t bits = 8 * static_cast<std::uint32_t>(bytes_per_channel);
    for (int c = 0; c < format->channels; ++c) {
      const std::uint32_t w = get_u32(bytes, b + 24 + 16 * static_cast<size_t>(c));
      const std::uint32_t channel_type = w >> 24;
      if ((w & 0xFFFF) != bits * c || ((w >> 16) & 0xFF) != bits - 1 ||
          (channel_type & 0x0F) != kDfChannelIds[c] || !(channel_type & kDfSampleFloat))
        throw fail("data format descriptor: sample " + std::to_string(c) +
                   " does not describe channel " + "RGBA"[c] + " as a " + std::to_string(bits) +
                   "-bit float at bit " + std::to_string(bits * c));
    }
  }

  Ktx2File file;
  // Key/value data: entries of uint32 keyAndValueByteLength, key, NUL, value, padding to 4.
  {
    size_t at = 0;
    std::set<std::string> keys;
    while (at < kvd_length) {
      if (kvd_length - at < 4) throw fail("key/value data: truncated entry length");
      const std::uint32_t length = get_u32(bytes, kvd_offset + at);
      at += 4;
      if (length > kvd_length - at)
        throw fail("key/value data: an entry of " + std::to_string(length) +
                   " bytes runs past the end of the key/value data");
      const std::uint8_t* entry = bytes.data() + kvd_offset + at;
      const std::uint8_t* nul = std::find(entry, entry + length, std::uint8_t{0});
      if (nul == entry + length) throw fail("key/value data: a key without its NUL terminator");
      if (nul == entry) throw fail("key/value data: an empty key");
      std::string key(entry, nul);
      std::string value(nul + 1, entry + length);
      if (!value.empty() && value.back() == '\0') value.pop_back();
      if (!keys.insert(key).second) throw fail("key/value data: key '" + key + "' appears twice");
      file.key_values.emplace_back(std::move(key), std::move(value));
      at = std::min<size_t>(align_up(at + length, 4), kvd_length);
    }
  }

  TextureVolume& v = file.volume;
  file.storage = format->storage;
  v.dims =
      Eigen::Vector3i(static_cast<int>(width), static_cast<int>(height), static_cast<int>(depth));
  v.channels = format->channels;
  v.values.resize(texels * static_cast<size_t>(format->channels));
  unpack_texels(bytes.data() + level_offset, format->storage, v.values);
  return file;
}

}  // namespace raywarp
