#include "library/added_detail.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "base/parallel.h"

namespace raywarp {

AddedDetailFigures measure_added_detail(const AddedDetail& deformer,
                                        const Eigen::Vector3d& half_extents,
                                        const DeformationTexture& texture,
                                        Interrupter* interrupter) {
  const Grid3<Eigen::Vector4f>& grid = texture.grid;
  struct Slice {
    double max = 0, sum = 0;
    long texels = 0;
  };
  // One row of texels per index: the detail's Newton iterations make a slice too long between
  // polls.
  const int rows = grid.dims.y();
  std::vector<Slice> slices(static_cast<size_t>(std::max(rows, 0)) * std::max(grid.dims.z(), 0));
  parallel_for(
      long(slices.size()),
      [&](long row) {
        const int j = int(row % rows), k = int(row / rows);
        Slice s;
        for (int i = 0; i < grid.dims.x(); ++i) {
          const Eigen::Vector4f& texel = grid.at(i, j, k);
          if (!(texel.w() >= 0.5f)) continue;
          const Eigen::Vector3d p_def = grid.texel_centre(i, j, k);
          const Eigen::Vector3d exact = deformer.exact_inverse(p_def) - p_def;
          const double d = (texel.head<3>().cast<double>() - exact).norm();
          s.max = std::max(s.max, std::isfinite(d) ? d : std::numeric_limits<double>::infinity());
          s.sum += d;
          ++s.texels;
        }
        slices[row] = s;
      },
      interrupter, "deformation texture: added detail against the composition");
  AddedDetailFigures out;
  double sum = 0;
  for (const Slice& s : slices) {
    out.difference_max = std::max(out.difference_max, s.max);
    sum += s.sum;
    out.texels += s.texels;
  }
  out.difference_mean = out.texels > 0 ? sum / out.texels : 0.0;
  out.box_diagonal = 2.0 * half_extents.norm();
  return out;
}

}  // namespace raywarp
