// A twist's angle changed with no bake: the deformation texture baked for a larger angle of the
// same sign (texel centres on the lower faces, bake_deformation's centre_on_lower_faces), read
// through the map M of eq. 2 that scales the box along the twist's axis about its lower face.
// A twist of angle s * A is the twist of angle A read at that scale, s = angle / A in [0, 1].
#pragma once
#include <Eigen/Geometry>

#include "library/scene.h"
#include "library/textures.h"

namespace raywarp {

struct TextureMapping {
  Eigen::Matrix4d map = Eigen::Matrix4d::Identity();  // BoxTextures::texture_map
  Eigen::AlignedBox3d region;  // the rays' region: the new deformed box, within the texture's
  double lipschitz = 0.0;      // a bound of |I + J_D M| for the mapped texture
};

// The mapping that shows `spec` (a box whose only deformer is a twist) through `baked`, its
// textures baked at the twist angle `baked_angle_deg`. Throws Error when the angle is not within
// [0, baked_angle_deg] (or [baked_angle_deg, 0]): M scales down, never up or mirrored.
TextureMapping twist_angle_mapping(const BoxSpec& spec, const BoxTextures& baked,
                                   double baked_angle_deg);

}  // namespace raywarp
