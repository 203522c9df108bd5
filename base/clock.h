#pragma once
// Wall-clock seconds for reports and progress (steady_clock: never goes back).

#include <chrono>

namespace raywarp {

inline double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace raywarp
