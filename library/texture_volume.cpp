#include "library/texture_volume.h"

#include <Imath/half.h>

#include <algorithm>
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

}  // namespace raywarp
