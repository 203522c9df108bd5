#include "library/texture_map.h"

#include <cmath>

#include "base/error.h"
#include "base/json_reader.h"
#include "deformers/registry.h"
#include "deformers/twist.h"

namespace raywarp {

TextureMapping twist_angle_mapping(const BoxSpec& spec, const BoxTextures& baked,
                                   double baked_angle_deg) {
  const double angle = spec.deformer.angle_deg;
  if (spec.deformer.type != "twist" || !spec.then.empty())
    throw Error("twist_angle_mapping: the box's only deformer must be a twist");
  if (baked.cylindrical())
    throw Error(
        "twist_angle_mapping: the box's textures are cylindrical, read at p' and not "
        "through M");
  if (baked_angle_deg == 0.0 || angle * baked_angle_deg < 0.0 ||
      std::abs(angle) > std::abs(baked_angle_deg))
    throw Error("twist_angle_mapping: angle " + format_number(angle) + " is not within [0, " +
                format_number(baked_angle_deg) + "], the baked angle");
  const double s = angle / baked_angle_deg;  // in [0, 1]
  const int a = spec.deformer.axis;
  const double h = spec.box.half_extents[a];
  TextureMapping out;
  out.map(a, a) = s;
  out.map(a, 3) = h * (s - 1.0);
  // The region of the new deformed box, within the baked texture's; the bound of
  // |I + J_D M| <= |I + J_D| |M| + |I - M| = L + (1 - s).
  const double texel = baked.deformation.grid.voxel();
  const auto twist = make_twist(spec.box.half_extents, static_cast<Axis>(a), angle);
  out.region = deformed_bounds(*twist, spec.box.half_extents, texel)
                   .intersection(Eigen::AlignedBox3d(baked.deformation.grid.origin,
                                                     baked.deformation.grid.upper()));
  out.lipschitz = baked.lipschitz + (1.0 - s);
  return out;
}

TextureMapping peel_hinge_mapping(const BoxSpec& spec, const BoxTextures& baked,
                                  double baked_hinge) {
  const DeformerSpec& d = spec.deformer;
  if (d.type != "peel" || !spec.then.empty())
    throw Error("peel_hinge_mapping: the box's only deformer must be a peel");
  if (!(d.hinge >= baked_hinge))
    throw Error("peel_hinge_mapping: hinge " + format_number(d.hinge) + " is below " +
                format_number(baked_hinge) + ", the baked hinge: the flap cannot grow");
  const int a = 3 - d.axis - d.from_axis;  // the peel direction
  const double shift = d.hinge - baked_hinge;
  TextureMapping out;
  out.map(a, 3) = -shift;
  // The rays' region: the new peel's deformed box; a translation leaves |I + J_D| as it is.
  const double texel = baked.deformation.grid.voxel();
  const auto peel = make_deformer(d, spec.box.half_extents);
  out.region = deformed_bounds(*peel, spec.box.half_extents, texel);
  out.lipschitz = baked.lipschitz;
  return out;
}

}  // namespace raywarp
