// Sample counts of the numerical experiments: a quarter of them under the sanitizers. The
// sanitizer pass of .ci/run looks for memory errors and undefined behaviour, which need every code
// path (every case still runs), not the statistics, and runs these 20 to 30 times slower.
#pragma once

// 1 in a build under AddressSanitizer (GCC defines __SANITIZE_ADDRESS__, clang answers
// __has_feature(address_sanitizer)), else 0.
#if defined(__SANITIZE_ADDRESS__)
#define RAYWARP_UNDER_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define RAYWARP_UNDER_SANITIZER 1
#endif
#endif
#ifndef RAYWARP_UNDER_SANITIZER
#define RAYWARP_UNDER_SANITIZER 0
#endif

namespace raywarp::testing {

constexpr int kSampleDivisor = RAYWARP_UNDER_SANITIZER ? 4 : 1;
// The side of the small grids the bake tests use (distance grid, deformation texture, alpha map):
// what a cancel or a cache read does depends on the stages, not on their sizes, and under the
// sanitizers a 64³ deformation texture took a minute a test.
constexpr int kSmallGrid = RAYWARP_UNDER_SANITIZER ? 24 : 64;
constexpr int samples(int n) { return n / kSampleDivisor; }

}  // namespace raywarp::testing
