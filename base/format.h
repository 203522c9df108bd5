// printf-style number formatting and medians, for reports and messages.
#pragma once
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

namespace raywarp {

// One number through a printf format, e.g. fmt("%.2f", x).
inline std::string fmt(const char* format, double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, x);
  return buf;
}

// The median (the mean of the two middle values for an even count); 0 for none.
inline double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace raywarp
