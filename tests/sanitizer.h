// Sample counts of the numerical experiments: a quarter of them under the sanitizers. The
// sanitizer pass of .ci/run looks for memory errors and undefined behaviour, which need every code
// path (every case still runs), not the statistics, and runs these 20 to 30 times slower.
#pragma once

namespace raywarp::testing {

#if defined(__SANITIZE_ADDRESS__)
constexpr int kSampleDivisor = 4;
#else
constexpr int kSampleDivisor = 1;
#endif
constexpr int samples(int n) { return n / kSampleDivisor; }

}  // namespace raywarp::testing
