#pragma once
// What the bake cache keeps of each stage of a box's bake (library/bake.cpp): the records the
// stages produce, their serialisers for the disk cache (CacheWriter and CacheReader,
// library/bake_cache.h) and their sizes for the memory cache. A load returns false on bytes it
// does not recognise (an older layout or a damaged entry), and the stage is baked again.

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <vector>

#include "base/grid.h"
#include "deformers/deformer.h"
#include "library/added_detail.h"
#include "library/bake.h"
#include "library/deformation_bake.h"
#include "library/depth_cube.h"
#include "library/textures.h"

namespace raywarp {

template <class T>
std::uint64_t grid_bytes(const Grid3<T>& g) {
  return static_cast<std::uint64_t>(g.size()) * sizeof(T);
}

// D with the figures measured on it, which cost as much as the bake.
struct DeformationRecord {
  DeformationTexture texture;
  double lipschitz = std::numeric_limits<double>::infinity();
  double texture_error = 0.0;
  ResolutionChoice choice;
  FoldReport folds;
  InverseResidual residual;
  AddedDetailFigures added_detail;  // texels > 0: measured (a list that adds detail)
};

// A with its measured error and how its layout was chosen.
struct AlphaRecord {
  AlphaMap map;
  double error = 0.0;
  ResolutionChoice choice;
};

// A simulation's last state (box frame) and what the run took.
struct SimulationRecord {
  std::vector<Eigen::Vector3d> positions;
  long steps = 0, cg_iterations = 0, cg_capped = 0;
  double seconds = 0.0;
};

// A from_mesh fit: the fitted lattice (box frame) and the report of the pairs and the fit.
struct FitRecord {
  std::vector<Eigen::Vector3d> positions;
  FromMeshReport report;
  Eigen::Vector3i cells = Eigen::Vector3i::Zero();
};

// The disk cache's bytes of each record, and the record read back from them.
std::vector<char> save_sdf(const DistanceGrid& g);
bool load_sdf(const std::vector<char>& bytes, DistanceGrid& g);
std::vector<char> save_deformation(const DeformationRecord& d);
bool load_deformation(const std::vector<char>& bytes, DeformationRecord& d);
std::vector<char> save_alpha(const AlphaRecord& a);
bool load_alpha(const std::vector<char>& bytes, AlphaRecord& a);
std::vector<char> save_step_bounds(const StepBounds& b);
bool load_step_bounds(const std::vector<char>& bytes, StepBounds& b);
std::vector<char> save_simulation(const SimulationRecord& s);
bool load_simulation(const std::vector<char>& bytes, SimulationRecord& s);
std::vector<char> save_fit(const FitRecord& f);
bool load_fit(const std::vector<char>& bytes, FitRecord& f);

// What each record holds in memory, for the memory cache's budget.
std::uint64_t value_bytes(const DistanceGrid& g);
std::uint64_t value_bytes(const DepthCube& c);
std::uint64_t value_bytes(const DeformationRecord& d);
std::uint64_t value_bytes(const AlphaRecord& a);
std::uint64_t value_bytes(const StepBounds& b);
std::uint64_t value_bytes(const SimulationRecord& s);
std::uint64_t value_bytes(const FitRecord& f);

}  // namespace raywarp
