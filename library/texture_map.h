// Parameters changed with no bake, through the map M of eq. 2.
//
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

// A peel's hinge moved with no bake (Correa & Silver's progressive peeling, Fig. 4, bottom): the
// peel of hinge h is the peel of hinge h_b read at p' - (h - h_b) e_a, a the peel direction (the
// third axis, neither the curl axis nor the axis of `from`): F commutes with a translation along
// a that moves the hinge alike, so D_h(p') = D_hb(p' - (h - h_b) e_a), and the alpha map alike.
// M is that translation. Read through it, what lay beyond the box's -a face as baked (the
// identity, w = 0: a preimage outside the box) is the identity, and the box decides whether the
// preimage is valid (the shader's and the CPU reference's sample_at). The baked textures hold
// the frame for h >= h_b: the flap shortens, and what the baked flap held beyond the +a face is
// not read.

// The mapping that shows `spec` (a box whose only deformer is a peel) through `baked`, its
// textures baked with the hinge at `baked_hinge` (centred on the lower faces). Throws Error when
// the hinge is below `baked_hinge`.
TextureMapping peel_hinge_mapping(const BoxSpec& spec, const BoxTextures& baked,
                                  double baked_hinge);

// The mapping that shows `spec` (a box whose only deformer is a twist) through `baked`, its
// textures baked at the twist angle `baked_angle_deg`. Throws Error when the angle is not within
// [0, baked_angle_deg] (or [baked_angle_deg, 0]): M scales down, never up or mirrored.
TextureMapping twist_angle_mapping(const BoxSpec& spec, const BoxTextures& baked,
                                   double baked_angle_deg);

}  // namespace raywarp
