// The refinement the automatic texture layouts share (library/deformation_bake.h,
// library/cylindrical.h).
#pragma once
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "base/error.h"
#include "library/deformation_bake.h"

namespace raywarp::layout {

constexpr int kMaxCount = 1024;  // texels along any axis of an automatic layout

// The refinement both automatic layouts share. `bake(counts, first)` bakes at `counts` (the
// floor's own layout when `first`) and returns the measured error; `per_axis()` estimates the
// errors along each axis of what was baked last; `keep()` and `restore()` save the last bake as
// the best so far and bring it back. `grown` texels are added along each axis after the choice
// (the lower-face shift), and counted against the budget.
template <class Bake, class PerAxis, class Keep, class Restore>
void refine_layout(const Eigen::Vector3i& floor, std::uint64_t texel_bytes, int grown,
                   ResolutionChoice& choice, double& error, Bake&& bake, PerAxis&& per_axis,
                   Keep&& keep, Restore&& restore) {
  auto bytes_of = [&](const Eigen::Vector3i& n) {
    return std::uint64_t(n.x() + grown) * (n.y() + grown) * (n.z() + grown) * texel_bytes;
  };
  // Texel counts whose texture fits the budget: all axes scaled down alike, none below 3.
  auto within_budget = [&](Eigen::Vector3i n) {
    for (int round = 0; round < 64 && bytes_of(n) > choice.budget_bytes; ++round) {
      const double s = std::cbrt(double(choice.budget_bytes) / double(bytes_of(n)));
      Eigen::Vector3i m;
      for (int a = 0; a < 3; ++a) m[a] = std::max(3, int(std::floor(n[a] * std::min(s, 0.999))));
      if (m == n) break;
      n = m;
      choice.budget_bound = true;
    }
    return n;
  };
  Eigen::Vector3i counts = within_budget(floor);
  // The estimates are per axis; the target is shared with a margin, since the measured error
  // (at cell centres, all axes at once) may exceed their sum a little.
  constexpr double kMargin = 0.8;
  constexpr int kMaxBakes = 4;
  const double target = choice.target;
  double best = std::numeric_limits<double>::infinity();
  bool improved = true;
  for (int n = 1;; ++n) {
    error = bake(counts, n == 1 && counts == floor);
    choice.bakes = n;
    // A refinement along the axes the estimates name can fail to help where the error is a
    // kink's (it falls as 1 / n, along every axis that crosses it): the best bake so far is
    // kept, and the next round refines every axis alike.
    improved = error < best;
    if (improved) {
      best = error;
      keep();
    }
    if (error <= target || choice.budget_bound || n == kMaxBakes) break;
    Eigen::Vector3i next = counts;
    if (improved) {
      const Eigen::Vector3d errors = per_axis();
      // Where the per-axis estimates fall short of the measured error, the target shrinks alike.
      const double sum = errors.sum();
      const double scale = sum > 0.0 ? std::min(1.0, sum / error) : 1.0;
      next = counts_for_error(counts, errors, kMargin * target * scale, counts);
    }
    if (next == counts) {  // no axis stands out, or that did not help: refine all alike
      const double grow = std::clamp(best / (kMargin * target), 1.25, 2.0);
      for (int a = 0; a < 3; ++a) next[a] = std::min(kMaxCount, int(std::ceil(counts[a] * grow)));
      if (next == counts) break;
    }
    next = within_budget(next.cwiseMax(3));
    if (next == counts) break;
    counts = next;
  }
  if (error > best) {
    restore();
    error = best;
  }
}

inline ResolutionChoice start_choice(double target, std::uint64_t budget_bytes) {
  if (!(target > 0.0)) throw Error("automatic layout: the target error must be > 0");
  ResolutionChoice choice;
  choice.automatic = true;
  choice.target = target;
  choice.budget_bytes = budget_bytes;
  return choice;
}

}  // namespace raywarp::layout
