// Pre-integrated transfer functions for volume rendering in the emission-absorption model
// (docs/tet_walk.md): the exact integral of a ray segment along which the scalar goes linearly
// from s_front to s_back over `length` object units, by quadrature (the reference), and a 3D
// table of it over (s_front, s_back, length) built by incremental pre-integration (Lum, Ma &
// Clyne 2004), read trilinearly, as the tetrahedral ray caster of Tejada & Ertl 2005 (section
// 5.1) looks it up once per tetrahedron.
//
// Model: along the segment, s(t) = s_front + (s_back - s_front) t / length, t in [0, length];
// the transfer function gives a colour c(s) (linear RGB in [0, 1]) and an extinction τ(s) >= 0
// per object unit. Colour is emission weighted by extinction:
//   C = ∫_0^l c(s(t)) τ(s(t)) exp(-∫_0^t τ(s(u)) du) dt,   α = 1 - exp(-∫_0^l τ(s(t)) dt).
// C is associated (premultiplied by opacity), so segments composite front to back as
// C' = C'_{k-1} + (1 - α'_{k-1}) C_k, α' = α'_{k-1} + (1 - α'_{k-1}) α_k.
// Closed forms for a constant scalar s: α = 1 - exp(-τ(s) l), C = c(s) (1 - exp(-τ(s) l)).
#pragma once
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace raywarp {

// One control point of a piecewise-linear transfer function.
struct TransferPoint {
  double s = 0.0;                                    // the scalar
  Eigen::Vector3d colour = Eigen::Vector3d::Zero();  // linear RGB in [0, 1]
  double tau = 0.0;                                  // extinction per object unit, >= 0
};

// Linear between control points, constant beyond the first and the last.
struct TransferFunction {
  std::vector<TransferPoint> points;  // strictly increasing s; at least one
  // Throws Error naming the point and the field: no point, more than kMaxTransferPoints, s not
  // finite or not strictly increasing, a colour channel outside [0, 1], τ < 0 or over 1e6.
  void validate() const;
  // (r, g, b, τ) at s (assumes a valid function).
  Eigen::Vector4d at(double s) const;
  double s_min() const { return points.front().s; }
  double s_max() const { return points.back().s; }
};
inline constexpr int kMaxTransferPoints = 4096;

// A pre-integrated segment: associated colour (linear RGB, premultiplied) and opacity.
struct SegmentColour {
  Eigen::Vector3d colour = Eigen::Vector3d::Zero();
  double alpha = 0.0;
};

// Front-to-back compositing of `back` behind `front`.
SegmentColour composite(const SegmentColour& front, const SegmentColour& back);

// The reference: the segment's integral in double. The optical depth is integrated exactly
// (τ is linear in t between the control points the segment crosses, so its integral is a
// quadratic); C by Gauss-Legendre quadrature (5 points a panel) over `panels` panels spread over
// the pieces between control points (at least one a piece). The default gives about 1e-13 on
// τ l <= 20. length >= 0, finite; panels in [1, 1e6]; throws Error otherwise.
SegmentColour preintegrate_exact(const TransferFunction& tf, double s_front, double s_back,
                                 double length, int panels = 256);

// The closed form of a constant scalar: α = 1 - exp(-τ(s) l), C = c(s) α.
SegmentColour preintegrate_constant(const TransferFunction& tf, double s, double length);

// Table sizes: scalar_samples N nodes along s_front and along s_back over [s_min, s_max] (node i
// at s_min + i (s_max - s_min) / (N - 1)), length_samples M nodes along the length over
// [0, max_length] (node k at k Δ, Δ = max_length / (M - 1); node 0 is the empty segment). Each
// entry is RGBA float32 (16 bytes): N² M 16 bytes in all.
struct PreintegrationSizes {
  int scalar_samples = 128;         // N, in [2, 1024]
  int length_samples = 128;         // M, in [2, 1024]
  double s_min = 0.0, s_max = 1.0;  // s_min < s_max, finite
  double max_length = 1.0;          // > 0, finite: object units
};
// The cap on a table's memory.
inline constexpr std::size_t kMaxPreintegrationBytes = std::size_t(512) << 20;

class PreintegrationTable {
 public:
  // Builds the table by incremental pre-integration (Lum, Ma & Clyne 2004): the layer of length
  // k Δ is the slab (s_f, s_m, Δ) in front of the layer k - 1 entry (s_m, s_b), with
  // s_m = s_f + (s_b - s_f) / k read between that layer's s_front nodes by cubic Lagrange
  // interpolation (4 nodes; linear when N < 4). The slab is integrated as preintegrate_exact does
  // with one panel a piece (split at the control points it crosses: 5 transfer function reads a
  // piece). So every entry costs O(1) reads of the layer below (N² M in all) instead of a
  // quadrature over its whole length (N³ M for a direct build at the same sampling). The layers
  // are kept in double while building, stored as float32. Accuracy: see docs/tet_walk.md (about
  // 6e-5 for a smooth transfer function at N = M = 129; near s_front = s_back at a control point
  // with a large slope jump J of τ, about J l h / 16 for node spacing h, as for any table read
  // linearly). Throws Error on a bad transfer function, a size out of range or a table over
  // kMaxPreintegrationBytes, naming the size and the cap.
  PreintegrationTable(const TransferFunction& tf, const PreintegrationSizes& sizes);

  // Trilinear lookup; s clamped to [s_min, s_max] (NaN reads s_min). A length beyond max_length
  // is cut into ceil(l / max_length) equal pieces (s linear along them; at most 1e6 pieces)
  // composited front to back until opaque; a length <= 0 or NaN is empty, an infinite one reads
  // max_length.
  SegmentColour lookup(double s_front, double s_back, double length) const;
  // The stored entry at nodes (i, j, k).
  SegmentColour entry(int i, int j, int k) const;

  const PreintegrationSizes& sizes() const { return sizes_; }
  std::size_t bytes() const { return data_.size() * sizeof(float); }
  double build_seconds() const { return build_seconds_; }
  // RGBA float32, index 4 (i + N (j + N k)): s_front fastest, then s_back, then length (the
  // layout of a 3D texture of N × N × M texels).
  const std::vector<float>& data() const { return data_; }

  // Bytes of a table of these sizes (checks nothing).
  static std::size_t bytes_for(const PreintegrationSizes& sizes);

 private:
  SegmentColour trilinear(double s_front, double s_back, double length) const;
  PreintegrationSizes sizes_;
  std::vector<float> data_;
  double build_seconds_ = 0.0;
};

}  // namespace raywarp
