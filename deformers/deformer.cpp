#include "deformers/deformer.h"

#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <exception>
#include <string>
#include <vector>

#include "base/error.h"
#include "base/parallel.h"

namespace raywarp {

std::string shortest_text(double x) {
  char buf[32];
  const auto end = std::to_chars(buf, buf + sizeof buf, x).ptr;
  return std::string(buf, end);
}

std::string vector_text(const Eigen::Vector3d& v) {
  std::string text = "[";
  for (int i = 0; i < 3; ++i) {
    if (i > 0) text += ", ";
    text += shortest_text(v[i]);
  }
  text += ']';
  return text;
}

// For |y| < 2^-26 sin(y) rounds to y, so the quotient is 1 to the last bit and no special range
// is needed beyond y == 0.
double sinc(double y) { return y == 0.0 ? 1.0 : std::sin(y) / y; }

void check_half_extents(const char* what, const Eigen::Vector3d& half_extents) {
  for (int i = 0; i < 3; ++i)
    if (!(half_extents[i] > 0.0) || !std::isfinite(half_extents[i]))
      throw Error(std::string(what) + " half_extents[" + std::to_string(i) +
                  "] = " + shortest_text(half_extents[i]) + ": must be > 0 and finite");
}

char axis_name(Axis a) {
  switch (a) {
    case Axis::X:
      return 'x';
    case Axis::Y:
      return 'y';
    case Axis::Z:
      break;
  }
  return 'z';
}

std::string face_name(Face f) { return std::string(f.side > 0 ? "+" : "-") + axis_name(f.axis); }

Face face_of(int index) { return Face{static_cast<Axis>(index / 2), index % 2 ? 1 : -1}; }

FoldReport measure_folds(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                         int samples_per_axis, Interrupter* interrupter) {
  if (samples_per_axis < 1)
    throw Error("measure_folds: samples_per_axis = " + std::to_string(samples_per_axis) +
                ": must be >= 1");
  const int n = samples_per_axis;
  const Eigen::Vector3d cell = 2.0 * half_extents / n;
  std::atomic<long> folded{0};
  parallel_for(
      n,
      [&](long k) {
        long here = 0;
        for (int j = 0; j < n; ++j)
          for (int i = 0; i < n; ++i) {
            const Eigen::Vector3d p =
                -half_extents + cell.cwiseProduct(Eigen::Vector3d(double(i), double(j), double(k)) +
                                                  Eigen::Vector3d::Constant(0.5));
            if (deformer.jacobian(p).determinant() <= 0.0) ++here;
          }
        folded += here;
      },
      interrupter, "folds");
  FoldReport report;
  report.box_volume = 8.0 * half_extents.prod();
  report.folded_volume = static_cast<double>(folded.load()) * cell.prod();
  return report;
}

namespace {

// Bounds of F over an (n + 1) x (n + 1) lattice of nodes on each of the six faces of the box
// (edges and corners included).
Eigen::AlignedBox3d face_lattice_bounds(const Deformer& deformer, const Eigen::Vector3d& h, int n) {
  Eigen::AlignedBox3d bounds;
  for (int normal = 0; normal < 3; ++normal) {
    const int u = (normal + 1) % 3, v = (normal + 2) % 3;
    for (double side : {-1.0, 1.0})
      for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
          Eigen::Vector3d p;
          p[normal] = side * h[normal];
          p[u] = h[u] * (2.0 * i / n - 1.0);
          p[v] = h[v] * (2.0 * j / n - 1.0);
          bounds.extend(deformer.forward(p));
        }
  }
  return bounds;
}

}  // namespace

// F is continuous, so the boundary of F(box) lies in F(boundary of box) and the extremes of F(box)
// are reached on the faces. Between lattice nodes F bulges by up to (1/8) spacing^2 max|F''|
// (a chord's sagitta), which grows with the angle; worse, a twist of many turns can alias with the
// lattice (16 turns over 64 intervals visit 4 angles per edge: a square section's corners then
// reach 0.71 of their radius).
// So the lattice is refined by halves until the bounds grow by less than 1e-4 of their diagonal,
// which leaves about a third of that unseen (the sagitta shrinks 4x per halving), or until 1024
// intervals. A lattice that aliases at two successive levels (64 whole turns) still fools it; the
// one-texel pad of bake_deformation absorbs the rest.
Eigen::AlignedBox3d deformed_bounds(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                                    double pad) {
  constexpr int kFirstIntervals = 64, kMaxIntervals = 1024;
  Eigen::AlignedBox3d bounds = face_lattice_bounds(deformer, half_extents, kFirstIntervals);
  for (int n = 2 * kFirstIntervals; n <= kMaxIntervals; n *= 2) {
    const Eigen::AlignedBox3d finer = face_lattice_bounds(deformer, half_extents, n);
    const double growth =
        std::max((bounds.min() - finer.min()).maxCoeff(), (finer.max() - bounds.max()).maxCoeff());
    bounds.extend(finer);
    if (growth <= 1e-4 * bounds.diagonal().norm()) break;
  }
  // A cut makes F discontinuous: the images of the cut surface (inside the box) may reach beyond
  // those of the faces (a peeled flap's underside is its outermost layer). Sample the volume too.
  if (deformer.has_cut()) {
    constexpr int n = 96;
    for (int k = 0; k <= n; ++k)
      for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
          const Eigen::Vector3d f(2.0 * i / n - 1.0, 2.0 * j / n - 1.0, 2.0 * k / n - 1.0);
          bounds.extend(deformer.forward(f.cwiseProduct(half_extents)));
        }
  }
  deformer.extend_image_bounds(bounds);
  bounds.min().array() -= pad;
  bounds.max().array() += pad;
  return bounds;
}

}  // namespace raywarp
