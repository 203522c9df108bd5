// libFuzzer target: an exported texture file as raywarp reads it back (library/ktx2.h,
// library/dds.h). The first byte picks the reader (even: KTX2, odd: DDS); the rest is the file.
// Any exception but raywarp::Error is a bug, as is a crash, a hang or a read out of bounds.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "base/error.h"
#include "library/dds.h"
#include "library/ktx2.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const std::vector<std::uint8_t> bytes(data + 1, data + size);
  try {
    if (data[0] % 2 == 0)
      (void)raywarp::decode_ktx2(bytes, "fuzz.ktx2");
    else
      (void)raywarp::decode_dds(bytes, "fuzz.dds");
  } catch (const raywarp::Error&) {
  }
  return 0;
}
