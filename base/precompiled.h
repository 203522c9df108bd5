// The system headers that most of raywarp's sources include, precompiled for the larger layers
// (CMakeLists.txt, raywarp_precompile; docs/testing.md#build-time). System headers only, so that
// it holds for every layer.
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>
