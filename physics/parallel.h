// Deterministic parallel loops for physics/ (internal to the target): TBB over fixed ranges, with
// results that do not depend on the number of threads or on how TBB splits the work.
//
// - for_each_index(n, grain, f): calls f(begin, end) on disjoint ranges covering [0, n); each
//   index's work must write only its own outputs (a gather), so the result is the same for any
//   split. Below kParallelMin items it runs on the calling thread (TBB's start-up costs more than
//   the work on small systems, e.g. the 54-node bar).
// - chunked_sum(n, f): Σ over [0, n) with f(begin, end) returning the sum of a range; the range is
//   cut into fixed chunks of kChunk items whose sums are added in chunk order, on one thread or
//   many alike, so the bits are the same for any thread count.
#pragma once
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstddef>
#include <vector>

namespace raywarp::physics::detail {

constexpr std::ptrdiff_t kParallelMin = 4096;
constexpr std::ptrdiff_t kChunk = 4096;

template <class F>
void for_each_index(std::ptrdiff_t n, std::ptrdiff_t grain, F&& f) {
  if (n <= 0) return;
  if (n < kParallelMin) {
    f(std::ptrdiff_t(0), n);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::ptrdiff_t>(0, n, std::max<std::ptrdiff_t>(1, grain)),
                    [&](const tbb::blocked_range<std::ptrdiff_t>& r) { f(r.begin(), r.end()); });
}

template <class F>
double chunked_sum(std::ptrdiff_t n, F&& f) {
  if (n <= 0) return 0.0;
  const std::ptrdiff_t chunks = (n + kChunk - 1) / kChunk;
  if (chunks == 1) return f(std::ptrdiff_t(0), n);
  std::vector<double> partial(static_cast<size_t>(chunks));
  auto run = [&](std::ptrdiff_t c0, std::ptrdiff_t c1) {
    for (std::ptrdiff_t c = c0; c < c1; ++c) {
      partial[static_cast<size_t>(c)] = f(c * kChunk, std::min(n, (c + 1) * kChunk));
    }
  };
  if (n < kParallelMin) {
    run(0, chunks);
  } else {
    tbb::parallel_for(
        tbb::blocked_range<std::ptrdiff_t>(0, chunks, 1),
        [&](const tbb::blocked_range<std::ptrdiff_t>& r) { run(r.begin(), r.end()); });
  }
  double s = 0;
  for (double p : partial) s += p;
  return s;
}

}  // namespace raywarp::physics::detail
