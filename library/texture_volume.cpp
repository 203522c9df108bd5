#include "library/texture_volume.h"

#include <Imath/half.h>

#include <algorithm>
#include <bit>
#include <cmath>

namespace raywarp {

const char* storage_name(Storage storage) { return storage == Storage::Half ? "half" : "float"; }

std::uint16_t float_to_half_bits(float x) {
  // Imath rounds to nearest even; values past the largest half would round to infinity.
  constexpr float kLargest = 65504.0f;
  if (std::isfinite(x)) x = std::clamp(x, -kLargest, kLargest);
  return Imath::half(x).bits();
}

float half_bits_to_float(std::uint16_t h) {
  Imath::half v;
  v.setBits(h);
  return static_cast<float>(v);
}

int storage_bytes(Storage storage) { return storage == Storage::Half ? 2 : 4; }

void pack_texels(const std::vector<float>& values, Storage storage, std::uint8_t* out) {
  for (size_t i = 0; i < values.size(); ++i) {
    if (storage == Storage::Half) {
      const std::uint16_t h = float_to_half_bits(values[i]);
      out[2 * i] = static_cast<std::uint8_t>(h);
      out[2 * i + 1] = static_cast<std::uint8_t>(h >> 8);
    } else {
      const std::uint32_t f = std::bit_cast<std::uint32_t>(values[i]);
      for (int b = 0; b < 4; ++b) out[4 * i + b] = static_cast<std::uint8_t>(f >> (8 * b));
    }
  }
}

void unpack_texels(const std::uint8_t* in, Storage storage, std::vector<float>& values) {
  for (size_t i = 0; i < values.size(); ++i) {
    if (storage == Storage::Half) {
      values[i] = half_bits_to_float(static_cast<std::uint16_t>(in[2 * i] | (in[2 * i + 1] << 8)));
    } else {
      std::uint32_t f = 0;
      for (int b = 0; b < 4; ++b) f |= std::uint32_t{in[4 * i + b]} << (8 * b);
      values[i] = std::bit_cast<float>(f);
    }
  }
}

void put_u32(std::vector<std::uint8_t>& out, size_t at, std::uint32_t v) {
  for (int b = 0; b < 4; ++b) out[at + b] = static_cast<std::uint8_t>(v >> (8 * b));
}
void put_u64(std::vector<std::uint8_t>& out, size_t at, std::uint64_t v) {
  for (int b = 0; b < 8; ++b) out[at + b] = static_cast<std::uint8_t>(v >> (8 * b));
}
std::uint32_t get_u32(const std::vector<std::uint8_t>& in, size_t at) {
  std::uint32_t v = 0;
  for (int b = 0; b < 4; ++b) v |= std::uint32_t{in[at + b]} << (8 * b);
  return v;
}
std::uint64_t get_u64(const std::vector<std::uint8_t>& in, size_t at) {
  std::uint64_t v = 0;
  for (int b = 0; b < 8; ++b) v |= std::uint64_t{in[at + b]} << (8 * b);
  return v;
}

}  // namespace raywarp
