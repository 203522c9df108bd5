// DirectDraw Surface files (Microsoft, "DDS" programming guide: DDS_HEADER, DDS_PIXELFORMAT,
// DDS_HEADER_DXT10) holding one uncompressed 3D float texture: one mip level, slices one after
// another, rows tightly packed, channels interleaved (TextureVolume's order).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "library/texture_volume.h"

namespace raywarp {

enum class DdsHeader {
  Dx10,    // FourCC "DX10" and a DDS_HEADER_DXT10 with a DXGI_FORMAT (Direct3D 10 and later)
  Legacy,  // FourCC holding a D3DFORMAT number (D3DFMT_A16B16G16R16F = 113, ...), for old readers
};

// The bytes of a DDS file for `v`, stored as half or float (R16_FLOAT ... R32G32B32A32_FLOAT);
// 3 channels are refused. Throws Error for a volume it cannot store.
std::vector<std::uint8_t> encode_dds(const TextureVolume& v, Storage s,
                                     DdsHeader form = DdsHeader::Dx10);

// Reads a DDS file of the kind encode_dds writes (either header form). Any malformed or
// unsupported input (wrong magic or sizes, a format other than the six float formats, a 1D, 2D
// or cube texture, an array, mip levels, too little or too much pixel data, a volume over 2^30
// bytes) throws Error with a message starting with `where`. `storage`, when given, receives how
// the file stored the values.
TextureVolume decode_dds(const std::vector<std::uint8_t>& bytes, const std::string& where,
                         Storage* storage = nullptr);

}  // namespace raywarp
