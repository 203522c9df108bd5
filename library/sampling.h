// The ray caster's sampling methods (render.sampling; docs/scene.md, sampling) and their names in
// the scene file. The one table of both: every other file compares the enum.
#pragma once
#include <optional>
#include <string_view>

namespace raywarp {

enum class Sampling {
  Linear,     // a fixed step
  Threshold,  // Hadwiger et al. 2005: a fine step near the surface, a coarse one capped by |f|
  Jacobian,   // eq. 4: step / |(I + J_D) v|
  Bounded,    // sphere tracing with Lipschitz-bounded steps (continuous deformations only)
};

struct SamplingName {
  Sampling sampling;
  const char* name;
};
inline constexpr SamplingName kSamplingNames[] = {{Sampling::Linear, "linear"},
                                                  {Sampling::Threshold, "threshold"},
                                                  {Sampling::Jacobian, "jacobian"},
                                                  {Sampling::Bounded, "bounded"}};

// The scene file's name of a method.
constexpr const char* sampling_name(Sampling s) {
  for (const SamplingName& n : kSamplingNames)
    if (n.sampling == s) return n.name;
  return "?";
}

// The method of a scene file's name; none for a name that is not one.
constexpr std::optional<Sampling> parse_sampling(std::string_view name) {
  for (const SamplingName& n : kSamplingNames)
    if (name == n.name) return n.sampling;
  return std::nullopt;
}

}  // namespace raywarp
