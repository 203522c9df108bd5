#include "base/json_reader.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace raywarp {

using json = nlohmann::json;

// Integers as integers, anything else in the shortest form that reads back exactly.
std::string format_number(double x) {
  char buf[32];
  if (x == std::round(x) && std::abs(x) < 1e7) {
    std::snprintf(buf, sizeof buf, "%.0f", x);
    return buf;
  }
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, x);
    if (std::strtod(buf, nullptr) == x) break;
  }
  return buf;
}

// A value as the user wrote it, shortened so that a message stays one line.
std::string show(const json& v) {
  std::string s = v.dump(-1, ' ', false, json::error_handler_t::replace);
  if (s.size() > 80) s = s.substr(0, 77) + "...";
  return s;
}

std::string child(const std::string& field, const std::string& key) {
  return field.empty() ? key : field + "." + key;
}

std::string element(const std::string& field, size_t i) {
  return field + "[" + std::to_string(i) + "]";
}

}  // namespace raywarp
