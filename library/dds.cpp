#include "library/dds.h"

#include <array>
#include <bit>

#include "base/error.h"

namespace raywarp {
namespace {

// File layout (all little endian): the magic "DDS " (4 bytes); DDS_HEADER (124 bytes: dwSize,
// dwFlags, dwHeight, dwWidth, dwPitchOrLinearSize, dwDepth, dwMipMapCount, dwReserved1[11],
// DDS_PIXELFORMAT (32 bytes: dwSize, dwFlags, dwFourCC, dwRGBBitCount, 4 bit masks), dwCaps,
// dwCaps2, dwCaps3, dwCaps4, dwReserved2); with FourCC "DX10", DDS_HEADER_DXT10 (20 bytes:
// dxgiFormat, resourceDimension, miscFlag, arraySize, miscFlags2); then the texels.
// File offsets of the fields:
constexpr size_t kSize = 4, kFlags = 8, kHeight = 12, kWidth = 16, kPitch = 20, kDepth = 24,
                 kMipMapCount = 28, kPfSize = 76, kPfFlags = 80, kPfFourCC = 84, kCaps = 108,
                 kCaps2 = 112, kDxgiFormat = 128, kResourceDimension = 132, kMiscFlag = 136,
                 kArraySize = 140, kMiscFlags2 = 144;
constexpr size_t kHeaderEnd = 128, kDx10HeaderEnd = 148;

constexpr std::uint32_t kDdsdCaps = 0x1, kDdsdHeight = 0x2, kDdsdWidth = 0x4, kDdsdPitch = 0x8,
                        kDdsdPixelFormat = 0x1000, kDdsdMipMapCount = 0x20000,
                        kDdsdDepth = 0x800000;
constexpr std::uint32_t kDdpfFourCC = 0x4;
constexpr std::uint32_t kDdsCapsComplex = 0x8, kDdsCapsTexture = 0x1000;
constexpr std::uint32_t kDdsCaps2Volume = 0x200000;
constexpr std::uint32_t kFourCCDx10 = 0x30315844;  // "DX10"
constexpr std::uint32_t kResourceTexture3D = 4;    // D3D10_RESOURCE_DIMENSION_TEXTURE3D
constexpr std::uint32_t kMiscTextureCube = 0x4;    // D3D11_RESOURCE_MISC_TEXTURECUBE
// miscFlags2 bits 0..2: DDS_ALPHA_MODE_CUSTOM, the 4th channel is data, not opacity.
constexpr std::uint32_t kAlphaModeCustom = 4;
constexpr std::uint64_t kMaxBytes = std::uint64_t{1} << 30;

struct Format {
  int channels;
  Storage storage;
  std::uint32_t dxgi;    // DXGI_FORMAT
  std::uint32_t d3dfmt;  // D3DFORMAT, stored as the FourCC in the legacy form
};
constexpr std::array<Format, 6> kFormats = {{
    {1, Storage::Half, 54, 111},   // DXGI_FORMAT_R16_FLOAT, D3DFMT_R16F
    {2, Storage::Half, 34, 112},   // DXGI_FORMAT_R16G16_FLOAT, D3DFMT_G16R16F
    {4, Storage::Half, 10, 113},   // DXGI_FORMAT_R16G16B16A16_FLOAT, D3DFMT_A16B16G16R16F
    {1, Storage::Float, 41, 114},  // DXGI_FORMAT_R32_FLOAT, D3DFMT_R32F
    {2, Storage::Float, 16, 115},  // DXGI_FORMAT_R32G32_FLOAT, D3DFMT_G32R32F
    {4, Storage::Float, 2, 116},   // DXGI_FORMAT_R32G32B32A32_FLOAT, D3DFMT_A32B32G32R32F
}};
// (D3DFMT names list channels from the most significant bits, so D3DFMT_A16B16G16R16F has R in
// the lowest bytes: the same memory order as DXGI's R16G16B16A16.)

}  // namespace

std::vector<std::uint8_t> encode_dds(const TextureVolume& v, Storage s, DdsHeader form) {
  const std::string label = "DDS export of texture '" + v.name + "'";
  if (v.channels != 1 && v.channels != 2 && v.channels != 4)
    throw Error(label + ": channels = " + std::to_string(v.channels) +
                ": DDS float textures are written with 1, 2 or 4 channels (R, RG, RGBA)");
  for (int a = 0; a < 3; ++a)
    if (v.dims[a] < 1)
      throw Error(label + ": dims[" + std::to_string(a) + "] = " + std::to_string(v.dims[a]) +
                  ": must be >= 1");
  if (v.values.size() != v.texels() * static_cast<size_t>(v.channels))
    throw Error(label + ": " + std::to_string(v.values.size()) + " values for " +
                std::to_string(v.texels()) + " texels of " + std::to_string(v.channels) +
                " channels");
  const Format* format = nullptr;
  for (const Format& f : kFormats)
    if (f.channels == v.channels && f.storage == s) format = &f;
  const size_t texel_bytes = static_cast<size_t>(v.channels * storage_bytes(s));
  const std::uint64_t data_bytes = v.texels() * texel_bytes;
  if (data_bytes > kMaxBytes)
    throw Error(label + ": " + std::to_string(data_bytes) +
                " bytes of texels: at most 2^30 bytes are written");

  const size_t data_offset = form == DdsHeader::Dx10 ? kDx10HeaderEnd : kHeaderEnd;
  std::vector<std::uint8_t> out(data_offset + data_bytes, 0);
  out[0] = 'D', out[1] = 'D', out[2] = 'S', out[3] = ' ';
  put_u32(out, kSize, 124);
  put_u32(out, kFlags,
          kDdsdCaps | kDdsdHeight | kDdsdWidth | kDdsdPitch | kDdsdPixelFormat | kDdsdMipMapCount |
              kDdsdDepth);
  put_u32(out, kHeight, static_cast<std::uint32_t>(v.dims.y()));
  put_u32(out, kWidth, static_cast<std::uint32_t>(v.dims.x()));
  put_u32(out, kPitch, static_cast<std::uint32_t>(v.dims.x() * texel_bytes));  // bytes per row
  put_u32(out, kDepth, static_cast<std::uint32_t>(v.dims.z()));
  put_u32(out, kMipMapCount, 1);
  put_u32(out, kPfSize, 32);
  put_u32(out, kPfFlags, kDdpfFourCC);
  put_u32(out, kPfFourCC, form == DdsHeader::Dx10 ? kFourCCDx10 : format->d3dfmt);
  put_u32(out, kCaps, kDdsCapsTexture | kDdsCapsComplex);
  put_u32(out, kCaps2, kDdsCaps2Volume);
  if (form == DdsHeader::Dx10) {
    put_u32(out, kDxgiFormat, format->dxgi);
    put_u32(out, kResourceDimension, kResourceTexture3D);
    put_u32(out, kMiscFlag, 0);
    put_u32(out, kArraySize, 1);  // must be 1 for a 3D texture
    put_u32(out, kMiscFlags2, kAlphaModeCustom);
  }
  pack_texels(v.values, s, out.data() + data_offset);
  return out;
}

TextureVolume decode_dds(const std::vector<std::uint8_t>& bytes, const std::string& where,
                         Storage* storage) {
  auto fail = [&](const std::string& what) -> Error { return Error(where + ": " + what); };
  const size_t size = bytes.size();
  if (size < kHeaderEnd)
    throw fail(std::to_string(size) + " bytes: too short for a DDS header (128 bytes)");
  if (bytes[0] != 'D' || bytes[1] != 'D' || bytes[2] != 'S' || bytes[3] != ' ')
    throw fail("not a DDS file (the magic \"DDS \" is missing)");
  if (get_u32(bytes, kSize) != 124)
    throw fail("DDS_HEADER dwSize " + std::to_string(get_u32(bytes, kSize)) + ": must be 124");
  if (get_u32(bytes, kPfSize) != 32)
    throw fail("DDS_PIXELFORMAT dwSize " + std::to_string(get_u32(bytes, kPfSize)) +
               ": must be 32");
  if (!(get_u32(bytes, kPfFlags) & kDdpfFourCC))
    throw fail("pixel format without a FourCC (bit masks): only the float formats are read");

  const std::uint32_t four_cc = get_u32(bytes, kPfFourCC);
  const Format* format = nullptr;
  size_t data_offset = kHeaderEnd;
  if (four_cc == kFourCCDx10) {
    if (size < kDx10HeaderEnd)
      throw fail(std::to_string(size) + " bytes: too short for a DX10 header (148 bytes)");
    data_offset = kDx10HeaderEnd;
    const std::uint32_t dxgi = get_u32(bytes, kDxgiFormat);
    for (const Format& f : kFormats)
      if (f.dxgi == dxgi) format = &f;
    if (!format)
      throw fail("DXGI format " + std::to_string(dxgi) +
                 ": only R16_FLOAT (54), R16G16_FLOAT (34), R16G16B16A16_FLOAT (10), R32_FLOAT "
                 "(41), R32G32_FLOAT (16) and R32G32B32A32_FLOAT (2) are read");
    const std::uint32_t dimension = get_u32(bytes, kResourceDimension);
    if (dimension != kResourceTexture3D)
      throw fail("resourceDimension " + std::to_string(dimension) +
                 ": only 3D textures (4) are read");
    if (get_u32(bytes, kMiscFlag) & kMiscTextureCube) throw fail("a cube map: not read");
    const std::uint32_t array_size = get_u32(bytes, kArraySize);
    if (array_size != 1)
      throw fail("arraySize " + std::to_string(array_size) + ": must be 1 for a 3D texture");
  } else {
    for (const Format& f : kFormats)
      if (f.d3dfmt == four_cc) format = &f;
    if (!format)
      throw fail("FourCC " + std::to_string(four_cc) +
                 ": only DX10 and the D3DFORMATs R16F (111), G16R16F (112), A16B16G16R16F (113), "
                 "R32F (114), G32R32F (115) and A32B32G32R32F (116) are read");
  }
  const std::uint32_t flags = get_u32(bytes, kFlags);
  if (!(flags & kDdsdDepth) && !(get_u32(bytes, kCaps2) & kDdsCaps2Volume))
    throw fail("neither DDSD_DEPTH nor DDSCAPS2_VOLUME set: only volume textures are read");
  const std::uint32_t width = get_u32(bytes, kWidth), height = get_u32(bytes, kHeight),
                      depth = get_u32(bytes, kDepth);
  if (width == 0 || height == 0 || depth == 0)
    throw fail("width " + std::to_string(width) + ", height " + std::to_string(height) +
               ", depth " + std::to_string(depth) + ": each must be >= 1");
  const std::uint32_t mips = get_u32(bytes, kMipMapCount);
  if ((flags & kDdsdMipMapCount) && mips > 1)
    throw fail("mipMapCount " + std::to_string(mips) + ": only 1 (no mipmaps) is read");

  const size_t texel_bytes = static_cast<size_t>(format->channels * storage_bytes(format->storage));
  std::uint64_t texels = width;
  for (std::uint64_t n : {std::uint64_t{height}, std::uint64_t{depth}}) {
    texels *= n;
    if (texels > kMaxBytes) break;
  }
  const std::uint64_t data_bytes = texels > kMaxBytes ? texels : texels * texel_bytes;
  if (data_bytes > kMaxBytes)
    throw fail(std::to_string(width) + "x" + std::to_string(height) + "x" + std::to_string(depth) +
               " texels: over 2^30 bytes, not read");
  if (size - data_offset != data_bytes)
    throw fail(std::to_string(size - data_offset) +
               " bytes of texels after the header: " + std::to_string(width) + "x" +
               std::to_string(height) + "x" + std::to_string(depth) + " texels of " +
               std::to_string(texel_bytes) + " bytes need exactly " + std::to_string(data_bytes));

  TextureVolume v;
  v.dims =
      Eigen::Vector3i(static_cast<int>(width), static_cast<int>(height), static_cast<int>(depth));
  v.channels = format->channels;
  v.values.resize(texels * static_cast<size_t>(format->channels));
  unpack_texels(bytes.data() + data_offset, format->storage, v.values);
  if (storage) *storage = format->storage;
  return v;
}

}  // namespace raywarp
