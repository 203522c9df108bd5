// KTX 2.0 files (Khronos, https://registry.khronos.org/KTX/specs/2.0/ktxspec.v2.html) holding one
// 3D float texture: one mip level, no array layers, one face, no supercompression, the texels in
// TextureVolume's order (which is KTX2's: x fastest, then y, then z, channels interleaved).
#pragma once
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "library/texture_volume.h"

namespace raywarp {

// The bytes of a KTX2 file for `v`, stored as half or float (R16_SFLOAT ... R32G32B32A32_SFLOAT;
// 3 channels are refused, as RGB16F/RGB32F are not sampleable formats on most GPUs).
// `key_values` go into the file's key/value data (sorted by key, each value stored with a
// trailing NUL). The writer adds KTXorientation = "rdi" and KTXwriter = "raywarp <kVersion>"
// (base/version.h) unless the caller gives them; other keys starting with "KTX" or "ktx" are
// reserved by the spec and refused. Throws Error for a volume or key it cannot store.
std::vector<std::uint8_t> encode_ktx2(
    const TextureVolume& v, Storage s,
    const std::vector<std::pair<std::string, std::string>>& key_values);

struct Ktx2File {
  TextureVolume volume;  // name left empty; values decoded to floats
  Storage storage = Storage::Half;
  // In file order (sorted by key), values without their trailing NUL; includes KTXorientation
  // and KTXwriter when the file has them.
  std::vector<std::pair<std::string, std::string>> key_values;
};

// Reads a KTX2 file of the kind encode_ktx2 writes. Any malformed or unsupported input (wrong
// identifier, a format other than the six float formats, mip levels, layers, cube faces,
// supercompression, offsets or lengths out of bounds, a level over 2^30 bytes) throws Error
// with a message starting with `where`.
Ktx2File decode_ktx2(const std::vector<std::uint8_t>& bytes, const std::string& where);

}  // namespace raywarp
