// The two tables of the ray-cast pass: the features that pick a box's shader variant, each with
// the macro that shaders/march.glsl tests, and the texture units its samplers read. The
// renderer (defines, program cache, texture bindings, sampler uniforms) and the tests read these
// tables; nothing else names a feature macro or a texture unit.
#pragma once
#include <GL/glcorearb.h>

#include <bitset>
#include <cstddef>
#include <iterator>
#include <optional>
#include <string>

#include "library/sampling.h"

namespace raywarp::gl {

// A feature of a ray-cast variant. A variant has exactly one Sampling* feature, and either no cut
// feature or Cut and exactly one of CutHollow, CutSolid, CutThick (march.glsl checks it).
// Half precision is no feature: it changes the textures' formats, not the shader.
enum class Feature {
  SamplingLinear,     // steps of u_step
  SamplingThreshold,  // u_step, and u_step * u_fine_factor near the surface
  SamplingJacobian,   // eq. 4's steps, dt = ds / |(I + J_D) v|
  SamplingBounded,    // sphere tracing with Lipschitz-bounded steps (traces_bounded)
  Cut,                // an alpha map A: the box has a cut (any mode)
  CutHollow,          // the cut shows a thin shell
  CutSolid,           // the cut shows a solid with cut faces
  CutThick,           // the cut shows a shell of thickness tau (eq. 7)
  DepthCube,          // the implicit is a depth-map cube, not a distance grid
  MovesNothing,       // D = 0: no deformation texture (a box cut)
  TextureMap,         // D read at M p' (eq. 2's mapping)
  Skip,               // empty-space skipping
  Cylindrical,        // D and A stored over (angle, radius, height) about an axis of the box
  kCount
};
inline constexpr size_t kFeatureCount = static_cast<size_t>(Feature::kCount);

struct FeatureInfo {
  Feature feature;
  const char* macro;  // #defined (empty) in the variant's shader when it has the feature
  std::optional<Sampling> sampling;  // for a Sampling* feature, its render.sampling method
};

// Indexed by Feature.
inline constexpr FeatureInfo kFeatures[] = {
    {Feature::SamplingLinear, "RAYWARP_SAMPLING_LINEAR", Sampling::Linear},
    {Feature::SamplingThreshold, "RAYWARP_SAMPLING_THRESHOLD", Sampling::Threshold},
    {Feature::SamplingJacobian, "RAYWARP_SAMPLING_JACOBIAN", Sampling::Jacobian},
    {Feature::SamplingBounded, "RAYWARP_SAMPLING_BOUNDED", Sampling::Bounded},
    {Feature::Cut, "RAYWARP_CUT", std::nullopt},
    {Feature::CutHollow, "RAYWARP_CUT_HOLLOW", std::nullopt},
    {Feature::CutSolid, "RAYWARP_CUT_SOLID", std::nullopt},
    {Feature::CutThick, "RAYWARP_CUT_THICK", std::nullopt},
    {Feature::DepthCube, "RAYWARP_DEPTH_CUBE", std::nullopt},
    {Feature::MovesNothing, "RAYWARP_MOVES_NOTHING", std::nullopt},
    {Feature::TextureMap, "RAYWARP_TEXTURE_MAP", std::nullopt},
    {Feature::Skip, "RAYWARP_SKIP", std::nullopt},
    {Feature::Cylindrical, "RAYWARP_CYLINDRICAL", std::nullopt},
};
static_assert(std::size(kFeatures) == kFeatureCount, "one kFeatures row per Feature");
constexpr bool features_in_order() {
  for (size_t i = 0; i < kFeatureCount; ++i)
    if (kFeatures[i].feature != static_cast<Feature>(i)) return false;
  return true;
}
static_assert(features_in_order(), "kFeatures is indexed by Feature");

constexpr const FeatureInfo& info(Feature f) { return kFeatures[static_cast<size_t>(f)]; }

// The features of one variant: a set of Feature.
class Variant {
 public:
  Variant& add(Feature f) {
    bits_.set(static_cast<size_t>(f));
    return *this;
  }
  bool has(Feature f) const { return bits_.test(static_cast<size_t>(f)); }
  // The key of the variant's compiled program: one bit per Feature.
  unsigned long key() const { return bits_.to_ulong(); }
  // `#define MACRO` lines, one per feature, in table order.
  std::string defines() const {
    std::string s;
    for (const FeatureInfo& f : kFeatures)
      if (has(f.feature)) s += std::string("#define ") + f.macro + "\n";
    return s;
  }
  bool operator==(const Variant& other) const { return bits_ == other.bits_; }

 private:
  static_assert(kFeatureCount <= 32, "Variant::key holds 32 features");
  std::bitset<kFeatureCount> bits_;
};

// A texture unit of the ray-cast pass; the enum value is the unit's number.
enum class TextureUnit { Sdf, Deformation, Alpha, Bricks, SdfBricks, DepthCube, kCount };
inline constexpr size_t kTextureUnitCount = static_cast<size_t>(TextureUnit::kCount);

struct TextureUnitInfo {
  TextureUnit unit;
  const char* sampler;  // the sampler uniform of raycast.frag.glsl that reads it
  GLenum target;        // what is bound there
};

// Indexed by TextureUnit.
inline constexpr TextureUnitInfo kTextureUnits[] = {
    {TextureUnit::Sdf, "u_sdf", GL_TEXTURE_3D},                  // the distance grid f
    {TextureUnit::Deformation, "u_deformation", GL_TEXTURE_3D},  // D and its validity w
    {TextureUnit::Alpha, "u_alpha", GL_TEXTURE_3D},              // A of a cut
    {TextureUnit::Bricks, "u_bricks", GL_TEXTURE_3D},            // bounds of |I + J_D| per brick
    {TextureUnit::SdfBricks, "u_sdf_bricks", GL_TEXTURE_3D},     // bounds of |grad f| per brick
    {TextureUnit::DepthCube, "u_depth", GL_TEXTURE_3D},          // the six faces, a slice each
};
static_assert(std::size(kTextureUnits) == kTextureUnitCount, "one kTextureUnits row per unit");
constexpr bool units_in_order() {
  for (size_t i = 0; i < kTextureUnitCount; ++i)
    if (kTextureUnits[i].unit != static_cast<TextureUnit>(i)) return false;
  return true;
}
static_assert(units_in_order(), "kTextureUnits is indexed by TextureUnit");

constexpr const TextureUnitInfo& info(TextureUnit u) {
  return kTextureUnits[static_cast<size_t>(u)];
}
constexpr GLint unit_number(TextureUnit u) { return static_cast<GLint>(u); }

}  // namespace raywarp::gl
