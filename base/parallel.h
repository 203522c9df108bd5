// Every parallel loop of raywarp: TBB, with one exception policy.
//
// parallel_for(count, body) runs body(i) for i in [0, count) on TBB's worker threads; each index
// runs exactly once, in no particular order. Exceptions: the first exception a body throws
// cancels the iterations not yet started, and parallel_for rethrows it on the calling thread once
// the running ones have finished (TBB's default task-group behaviour); later exceptions are
// dropped. With an Interrupter, the loop polls it before each index (so one index should be
// well under 50 ms of work) and reports the fraction of indices done under `stage`; a cancel
// surfaces as Cancelled by the same policy.
#pragma once
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <atomic>

#include "base/interrupt.h"

namespace raywarp {

template <class Body>
void parallel_for(long count, const Body& body, Interrupter* interrupter = nullptr,
                  const char* stage = "") {
  if (count <= 0) return;
  std::atomic<long> done{0};
  tbb::parallel_for(tbb::blocked_range<long>(0, count, 1), [&](const tbb::blocked_range<long>& r) {
    for (long i = r.begin(); i != r.end(); ++i) {
      if (interrupter)
        interrupter->poll(stage, static_cast<double>(done.load(std::memory_order_relaxed)) /
                                     static_cast<double>(count));
      body(i);
      done.fetch_add(1, std::memory_order_relaxed);
    }
  });
}

}  // namespace raywarp
