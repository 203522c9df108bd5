// A texture as it leaves raywarp: a dense 3D array of 1 to 4 float channels, in the memory order
// every exported format shares (channels interleaved, then x fastest, then y, then z: texel
// (i, j, k) channel c at ((k * ny + j) * nx + i) * channels + c). Values are already in the
// exported encoding (library/export.h: displacements in box units, distances in voxels); the
// format writers (KTX2, DDS, tiled atlases, OpenVDB) store them, at half or full float precision,
// and never reinterpret them.
#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace raywarp {

// How a format stores each channel of a float volume.
enum class Storage {
  Half,   // IEEE 754 binary16, round to nearest even (RGBA16F, R16F)
  Float,  // IEEE 754 binary32 (RGBA32F, R32F)
};
const char* storage_name(Storage storage);  // "half", "float"

struct TextureVolume {
  std::string name;                                // "deformation", "alpha", "distance", ...
  Eigen::Vector3i dims = Eigen::Vector3i::Zero();  // texels along x, y, z (each >= 1)
  int channels = 1;                                // 1, 2 or 4
  std::vector<float> values;                       // dims.prod() * channels, layout above

  size_t texels() const {
    return static_cast<size_t>(dims.x()) * static_cast<size_t>(dims.y()) *
           static_cast<size_t>(dims.z());
  }
  size_t index(int i, int j, int k, int c) const {
    return ((static_cast<size_t>(k) * dims.y() + j) * dims.x() + i) * channels + c;
  }
  float at(int i, int j, int k, int c) const { return values[index(i, j, k, c)]; }
};

// IEEE binary16 bits of a float, round to nearest even; magnitudes beyond the largest half
// (65504) are clamped to it, so a finite value stays finite (as round_to_half,
// library/textures.h). And back: the exact float of a half.
std::uint16_t float_to_half_bits(float x);
float half_bits_to_float(std::uint16_t h);

// What the binary formats (KTX2, DDS) share. Bytes per channel of a storage: 2 or 4.
int storage_bytes(Storage storage);
// `values` as a format stores them, little-endian, storage_bytes(storage) each, into `out`.
void pack_texels(const std::vector<float>& values, Storage storage, std::uint8_t* out);
// Back: values.size() values from `in`.
void unpack_texels(const std::uint8_t* in, Storage storage, std::vector<float>& values);
// Little-endian unsigned integers at byte `at` of a buffer (the caller checks the bounds).
void put_u32(std::vector<std::uint8_t>& out, size_t at, std::uint32_t v);
void put_u64(std::vector<std::uint8_t>& out, size_t at, std::uint64_t v);
std::uint32_t get_u32(const std::vector<std::uint8_t>& in, size_t at);
std::uint64_t get_u64(const std::vector<std::uint8_t>& in, size_t at);

}  // namespace raywarp
