// Errors raywarp reports to its user. A message names the file, the field, the value and
// what is allowed, e.g. "scene.json: boxes[0].half_extents[2] = -1: must be > 0".
#pragma once
#include <stdexcept>
#include <string>

namespace raywarp {

struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace raywarp
