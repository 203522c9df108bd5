// raywarp's version, as `raywarp --version`, the exported files' sidecars and KTX2 writer key say.
#pragma once

namespace raywarp {

inline constexpr const char* kVersion = "0.1.0";

}  // namespace raywarp
