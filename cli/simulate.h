// `raywarp simulate SCENE`: runs the scene's simulation boxes once (with progress), keeps every
// K-th state in the bake session (and the disk cache), bakes the deformation texture of each kept
// state, and renders the sequence: DIR/NAME_0000.png ... and DIR/NAME.gif (docs/simulation.md).
#pragma once
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include "library/bake_cache.h"

namespace raywarp {

struct SimulateOptions {
  std::filesystem::path scene;
  std::filesystem::path output;  // DIR/NAME.png: frames DIR/NAME_0000.png ..., DIR/NAME.gif
  long every = 0;                // steps between frames; 0: the longest run / 30, at least 1
  std::string camera;            // camera file overriding the scene's, or empty
  int width = 0, height = 0;     // 0: the camera's or the scene's
  std::string context = "auto";
  int delay_cs = 4;
  bool write_frames = true;
  BakeCache* cache = nullptr;
};

struct SimulateResult {
  int frames = 0;
  std::vector<long> steps;  // the step count each frame shows (the longest run's)
  long simulations = 0;     // simulation stages run (the rest read from memory or the cache)
  std::vector<double> frame_ms;
  std::filesystem::path gif;
};

// Throws Error (naming the scene) when no box holds a simulation, or for a bad option.
SimulateResult simulate(const SimulateOptions& options, std::ostream& log);

}  // namespace raywarp
