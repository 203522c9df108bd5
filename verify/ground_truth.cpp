#include "verify/ground_truth.h"

#include "deformers/box_cut.h"
#include "library/mesh.h"
#include "library/textures.h"
#include "verify/reference.h"

namespace raywarp {

Truth ground_truth(const Scene& scene, const PreparedScene& prepared, const Camera& camera,
                   int width, int height) {
  Truth t;
  t.diagonal = mesh_bounds(prepared.mesh()).diagonal().norm();
  bool any_cut = false;
  for (const BakedBox& b : prepared.boxes) any_cut = any_cut || b.deformer->has_cut();
  if (!any_cut) {
    Mesh m = prepared.mesh();
    for (const BakedBox& b : prepared.boxes) {
      auto F = [&](const Eigen::Vector3d& p) { return b.deformer->forward(p); };
      m = ground_truth_mesh(m, b.textures.box, F, 0.25 * implicit_spacing(b.textures));
    }
    t.diagonal = mesh_bounds(m).diagonal().norm();
    t.image = rasterize(m, camera, width, height, scene.render);
    t.kind =
        "exact: the mesh split at the box faces, subdivided to edges of 1/4 voxel, mapped by "
        "the exact forward map and rasterised on the CPU";
    return t;
  }
  if (prepared.boxes.size() == 1) {
    const BakedBox& b = prepared.boxes[0];
    const BoxSpec& spec = scene.boxes[0];
    if (const auto* cut = dynamic_cast<const BoxCut*>(b.deformer.get());
        cut && spec.cut_mode != CutMode::ThickShell) {
      t.image = exact_cut_render(prepared.mesh(), b.textures.box, cut->region(), spec.cut_mode,
                                 camera, width, height, scene.render);
      t.kind = "exact: every triangle along each ray (BVH, double), the cut's region subtracted";
      return t;
    }
    if (spec.deformer.type == "incision" && spec.cut_mode == CutMode::Hollow) {
      auto F = [&](const Eigen::Vector3d& p) { return b.deformer->forward(p); };
      Mesh m = ground_truth_mesh(prepared.mesh(), b.textures.box, F,
                                 0.25 * implicit_spacing(b.textures), spec.deformer.axis);
      t.image = rasterize(m, camera, width, height, scene.render);
      t.kind = "exact: the mesh split at the box faces and the cut plane, mapped from each side";
      return t;
    }
  }
  // No exact form (a solid incision or peel shows cut faces inside the mesh; a thick shell's inner
  // surface): the CPU ray cast of the scene's own textures at 1/16-voxel steps. It measures the
  // sampling's error, not the textures'.
  RenderSettings fine = scene.render;
  fine.sampling = Sampling::Linear;
  fine.step_voxels = 1.0 / 16.0;
  fine.refine_steps = 16;
  fine.max_steps = 100000;
  t.image = reference_render(prepared.mesh(), prepared.textures(), camera, width, height, fine);
  t.kind =
      "not exact: the CPU ray cast of the scene's own textures at 1/16-voxel steps (no exact "
      "form for this cut; the figures show the sampling's error only)";
  return t;
}

}  // namespace raywarp
