// The figures of a box whose deformer list adds detail (deformers/composed.h, AddedDetail): its
// texture holds the sum of the inverse displacements, D = D_rest + D_detail, where the list means
// the composition F = F_detail o F_rest, whose inverse displacement is
// D_exact(p') = F^-1(p') - p'. The bake measures two things:
//   - measure_inverse_residual (library/deformation_bake.h) with the list's deformer: its
//     forward() is the exact composition, so |F(p' + D(p')) - p'| is how far the summed texture
//     is from inverting F, in the deformed frame;
//   - measure_added_detail, below: |D(p') - D_exact(p')| at the same texels, the same error in
//     the undeformed frame.
#pragma once
#include "base/interrupt.h"
#include "deformers/composed.h"
#include "library/textures.h"

namespace raywarp {

struct AddedDetailFigures {
  // |D(p') - D_exact(p')| over the valid texels (w >= 0.5), D as stored (float), object units.
  double difference_max = 0, difference_mean = 0;
  long texels = 0;
  // The diagonal of the box, 2 |h|, to give the figures as a fraction of it.
  double box_diagonal = 0;
};

AddedDetailFigures measure_added_detail(const AddedDetail& deformer,
                                        const Eigen::Vector3d& half_extents,
                                        const DeformationTexture& texture,
                                        Interrupter* interrupter = nullptr);

}  // namespace raywarp
