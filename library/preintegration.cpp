#include "library/preintegration.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

#include "base/error.h"
#include "base/parallel.h"

namespace raywarp {

namespace {

using Vec3 = Eigen::Vector3d;
using Vec4 = Eigen::Vector4d;

std::string num(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.9g", v);
  return buffer;
}

// 5-point Gauss-Legendre on [-1, 1].
constexpr double kGaussX[5] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831,
                               0.9061798459386640};
constexpr double kGaussW[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889,
                               0.4786286704993665, 0.2369268850561891};

// Optical depth beyond which a segment's colour is not integrated further (exp(-50) ≈ 2e-22).
constexpr double kDepthCutoff = 50.0;

// 1 - exp(-x) without cancellation for small x.
double opacity_of(double optical_depth) { return -std::expm1(-optical_depth); }

void check_length(const char* who, double length) {
  if (!std::isfinite(length) || length < 0.0)
    throw Error(std::string(who) + ": length " + num(length) + ": must be finite and >= 0");
}

// The segment's integral: split at the control points the scalar crosses (found by binary
// search), so that colour and τ are linear in t on each piece and the optical depth is exact
// (a quadratic); C by 5-point Gauss-Legendre on max(1, round(panels · piece / length)) panels a
// piece, and at least one panel per unit of the piece's optical depth up to kDepthCutoff (where
// the integration stops). No checks.
SegmentColour integrate_segment(const TransferFunction& tf, double s_front, double s_back,
                                double length, int panels) {
  SegmentColour out;
  if (!(length > 0.0)) return out;
  const std::vector<TransferPoint>& points = tf.points;
  const auto by_s = [](const TransferPoint& p, double v) { return p.s < v; };
  const auto s_below = [](double v, const TransferPoint& p) { return v < p.s; };
  const double lo = std::min(s_front, s_back), hi = std::max(s_front, s_back);
  // The control points with lo < s < hi: [first, last).
  const auto first = std::upper_bound(points.begin(), points.end(), lo, s_below);
  const auto last = std::lower_bound(points.begin(), points.end(), hi, by_s);
  const long inside = std::max(0L, static_cast<long>(last - first));
  const bool rising = s_back > s_front;

  double depth = 0.0;  // optical depth from 0 to the start of the piece
  double a = 0.0;
  Vec4 va = tf.at(s_front);
  for (long c = 0; c <= inside; ++c) {
    double b;
    Vec4 vb;
    if (c < inside) {
      const TransferPoint& p = rising ? first[c] : last[-1 - c];
      b = std::clamp(length * ((p.s - s_front) / (s_back - s_front)), a, length);
      vb = Vec4(p.colour[0], p.colour[1], p.colour[2], p.tau);
    } else {
      b = length;
      vb = tf.at(s_back);
    }
    const double w = b - a;
    if (depth > kDepthCutoff) break;  // what lies behind adds less than exp(-kDepthCutoff)
    if (w > 0.0) {
      const double tau_a = va[3], tau_b = vb[3];
      // An optically thick piece: integrate only to where the depth reaches the cut-off, on at
      // least one panel per unit of optical depth, so that 5-point Gauss-Legendre resolves
      // exp(-∫τ) however large τ is.
      const double piece_depth = 0.5 * w * (tau_a + tau_b);
      const double to_cover = std::min(piece_depth, kDepthCutoff);
      double span = w;
      if (to_cover < piece_depth) {
        // ∫_a^{a+x} τ = tau_a x + (tau_b - tau_a) x² / (2 w) = to_cover, solved stably.
        const double root =
            std::sqrt(std::max(0.0, tau_a * tau_a + 2.0 * (tau_b - tau_a) * to_cover / w));
        span = tau_a + root > 0.0 ? std::min(w, 2.0 * to_cover / (tau_a + root)) : w;
      }
      const int n = std::max({1, static_cast<int>(std::lround(panels * (w / length))),
                              static_cast<int>(std::ceil(to_cover))});
      const double h = span / n;
      for (int q = 0; q < n; ++q) {
        const double p0 = a + q * h;
        for (int g = 0; g < 5; ++g) {
          const double t = p0 + 0.5 * h * (kGaussX[g] + 1.0);
          const double u = (t - a) / w;
          const Vec4 v = (1.0 - u) * va + u * vb;
          // ∫_a^t τ: τ is linear on the piece.
          const double d = depth + (t - a) * (tau_a + 0.5 * (tau_b - tau_a) * u);
          out.colour += (0.5 * h * kGaussW[g] * v[3] * std::exp(-d)) * v.head<3>();
        }
      }
      depth += 0.5 * w * (tau_a + tau_b);
    }
    a = b;
    va = vb;
  }
  out.alpha = opacity_of(depth);
  return out;
}

}  // namespace

void TransferFunction::validate() const {
  if (points.empty()) throw Error("transfer function: no control point: give at least one");
  if (points.size() > static_cast<size_t>(kMaxTransferPoints))
    throw Error("transfer function: " + std::to_string(points.size()) +
                " control points: at most " + std::to_string(kMaxTransferPoints));
  for (size_t i = 0; i < points.size(); ++i) {
    const TransferPoint& p = points[i];
    const std::string where = "transfer function: points[" + std::to_string(i) + "]";
    if (!std::isfinite(p.s)) throw Error(where + ".s = " + num(p.s) + ": must be finite");
    if (i > 0 && !(p.s > points[i - 1].s))
      throw Error(where + ".s = " + num(p.s) + ": must be greater than points[" +
                  std::to_string(i - 1) + "].s = " + num(points[i - 1].s));
    for (int c = 0; c < 3; ++c)
      if (!(p.colour[c] >= 0.0 && p.colour[c] <= 1.0))
        throw Error(where + ".colour[" + std::to_string(c) + "] = " + num(p.colour[c]) +
                    ": must be in [0, 1]");
    if (!(p.tau >= 0.0 && p.tau <= 1e6))
      throw Error(where + ".tau = " + num(p.tau) + ": must be in [0, 1e6] per object unit");
  }
}

Eigen::Vector4d TransferFunction::at(double s) const {
  const auto to_vec = [](const TransferPoint& p) {
    return Vec4(p.colour[0], p.colour[1], p.colour[2], p.tau);
  };
  if (!(s > points.front().s)) return to_vec(points.front());
  if (!(s < points.back().s)) return to_vec(points.back());
  const auto hi = std::upper_bound(points.begin(), points.end(), s,
                                   [](double v, const TransferPoint& p) { return v < p.s; });
  const TransferPoint& b = *hi;
  const TransferPoint& a = *(hi - 1);
  const double w = (s - a.s) / (b.s - a.s);
  return (1.0 - w) * to_vec(a) + w * to_vec(b);
}

SegmentColour composite(const SegmentColour& front, const SegmentColour& back) {
  SegmentColour out;
  const double through = 1.0 - front.alpha;
  out.colour = front.colour + through * back.colour;
  out.alpha = front.alpha + through * back.alpha;
  return out;
}

SegmentColour preintegrate_exact(const TransferFunction& tf, double s_front, double s_back,
                                 double length, int panels) {
  check_length("preintegrate_exact", length);
  if (!std::isfinite(s_front) || !std::isfinite(s_back))
    throw Error("preintegrate_exact: scalar (" + num(s_front) + ", " + num(s_back) +
                "): must be finite");
  if (panels < 1 || panels > 1000000)
    throw Error("preintegrate_exact: panels = " + std::to_string(panels) + ": must be in [1, 1e6]");
  return integrate_segment(tf, s_front, s_back, length, panels);
}

SegmentColour preintegrate_constant(const TransferFunction& tf, double s, double length) {
  check_length("preintegrate_constant", length);
  const Vec4 v = tf.at(s);
  SegmentColour out;
  out.alpha = opacity_of(v[3] * length);
  out.colour = v.head<3>() * out.alpha;
  return out;
}

std::size_t PreintegrationTable::bytes_for(const PreintegrationSizes& sizes) {
  return static_cast<std::size_t>(std::max(0, sizes.scalar_samples)) *
         static_cast<std::size_t>(std::max(0, sizes.scalar_samples)) *
         static_cast<std::size_t>(std::max(0, sizes.length_samples)) * 4 * sizeof(float);
}

PreintegrationTable::PreintegrationTable(const TransferFunction& tf,
                                         const PreintegrationSizes& sizes)
    : sizes_(sizes) {
  const auto start = std::chrono::steady_clock::now();
  tf.validate();
  const int n = sizes.scalar_samples, m = sizes.length_samples;
  if (n < 2 || n > 1024)
    throw Error("pre-integration table: scalar_samples = " + std::to_string(n) +
                ": must be in [2, 1024]");
  if (m < 2 || m > 1024)
    throw Error("pre-integration table: length_samples = " + std::to_string(m) +
                ": must be in [2, 1024]");
  if (!std::isfinite(sizes.s_min) || !std::isfinite(sizes.s_max) || !(sizes.s_min < sizes.s_max))
    throw Error("pre-integration table: scalar range [" + num(sizes.s_min) + ", " +
                num(sizes.s_max) + "]: must be finite with s_min < s_max");
  if (!std::isfinite(sizes.max_length) || !(sizes.max_length > 0.0))
    throw Error("pre-integration table: max_length = " + num(sizes.max_length) +
                ": must be finite and > 0");
  const std::size_t bytes = bytes_for(sizes);
  if (bytes > kMaxPreintegrationBytes)
    throw Error("pre-integration table: " + std::to_string(n) + " x " + std::to_string(n) + " x " +
                std::to_string(m) + " entries need " + std::to_string(bytes >> 20) +
                " MiB: at most " + std::to_string(kMaxPreintegrationBytes >> 20) + " MiB");

  const std::size_t layer = static_cast<std::size_t>(n) * n;
  data_.assign(layer * m * 4, 0.0f);  // layer 0: the empty segment
  const double ds = (sizes.s_max - sizes.s_min) / (n - 1);
  const double dl = sizes.max_length / (m - 1);
  const auto node_s = [&](int i) { return sizes.s_min + i * ds; };

  // The previous layer in double, so that rounding to float does not accumulate.
  std::vector<SegmentColour> previous(layer), current(layer);
  for (int k = 1; k < m; ++k) {
    parallel_for(n, [&](long jl) {
      const int j = static_cast<int>(jl);
      const double s_back = node_s(j);
      for (int i = 0; i < n; ++i) {
        const double s_front = node_s(i);
        SegmentColour value;
        if (k == 1) {
          value = integrate_segment(tf, s_front, s_back, dl, 1);
        } else {
          // The slab in front, then the rest of the segment from the layer below, read at s_mid
          // between its s_front nodes by cubic Lagrange interpolation (4 nodes; linear when
          // N < 4), so that the reads' errors, which add up over the M layers, stay small.
          const double s_mid = s_front + (s_back - s_front) / k;
          const double x = std::clamp((s_mid - sizes.s_min) / ds, 0.0, double(n - 1));
          const SegmentColour* row = &previous[static_cast<std::size_t>(j) * n];
          SegmentColour rest;
          if (n < 4) {
            const int i0 = std::min(static_cast<int>(x), n - 2);
            const double f = x - i0;
            rest.colour = (1.0 - f) * row[i0].colour + f * row[i0 + 1].colour;
            rest.alpha = (1.0 - f) * row[i0].alpha + f * row[i0 + 1].alpha;
          } else {
            const int i1 = std::clamp(static_cast<int>(x), 1, n - 3);
            const double t = x - i1;
            const double w[4] = {-t * (t - 1.0) * (t - 2.0) / 6.0,
                                 (t + 1.0) * (t - 1.0) * (t - 2.0) / 2.0,
                                 -(t + 1.0) * t * (t - 2.0) / 2.0, (t + 1.0) * t * (t - 1.0) / 6.0};
            for (int q = 0; q < 4; ++q) {
              rest.colour += w[q] * row[i1 - 1 + q].colour;
              rest.alpha += w[q] * row[i1 - 1 + q].alpha;
            }
          }
          value = composite(integrate_segment(tf, s_front, s_mid, dl, 1), rest);
        }
        current[static_cast<std::size_t>(j) * n + i] = value;
        float* out = &data_[4 * (layer * k + static_cast<std::size_t>(j) * n + i)];
        for (int c = 0; c < 3; ++c) out[c] = static_cast<float>(value.colour[c]);
        out[3] = static_cast<float>(value.alpha);
      }
    });
    std::swap(previous, current);
  }
  build_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

SegmentColour PreintegrationTable::entry(int i, int j, int k) const {
  const int n = sizes_.scalar_samples;
  const float* e = &data_[4 * (static_cast<std::size_t>(k) * n * n +
                               static_cast<std::size_t>(j) * n + static_cast<std::size_t>(i))];
  SegmentColour out;
  out.colour = Vec3(e[0], e[1], e[2]);
  out.alpha = e[3];
  return out;
}

SegmentColour PreintegrationTable::trilinear(double s_front, double s_back, double length) const {
  const int n = sizes_.scalar_samples, m = sizes_.length_samples;
  const double ds = (sizes_.s_max - sizes_.s_min) / (n - 1);
  const double dl = sizes_.max_length / (m - 1);
  const auto cell = [](double x, int count, int& i0) {
    x = std::isnan(x) ? 0.0 : std::clamp(x, 0.0, double(count - 1));
    i0 = std::min(static_cast<int>(x), count - 2);
    return x - i0;
  };
  int i0, j0, k0;
  const double fx = cell((s_front - sizes_.s_min) / ds, n, i0);
  const double fy = cell((s_back - sizes_.s_min) / ds, n, j0);
  const double fz = cell(length / dl, m, k0);
  Vec4 sum = Vec4::Zero();
  for (int c = 0; c < 8; ++c) {
    const int di = c & 1, dj = (c >> 1) & 1, dk = (c >> 2) & 1;
    const double w = (di ? fx : 1.0 - fx) * (dj ? fy : 1.0 - fy) * (dk ? fz : 1.0 - fz);
    if (w == 0.0) continue;
    const float* e =
        &data_[4 * (static_cast<std::size_t>(k0 + dk) * n * n +
                    static_cast<std::size_t>(j0 + dj) * n + static_cast<std::size_t>(i0 + di))];
    sum += w * Vec4(e[0], e[1], e[2], e[3]);
  }
  SegmentColour out;
  out.colour = sum.head<3>();
  out.alpha = sum[3];
  return out;
}

SegmentColour PreintegrationTable::lookup(double s_front, double s_back, double length) const {
  if (!(length > 0.0)) return {};
  if (length <= sizes_.max_length) return trilinear(s_front, s_back, length);
  if (!std::isfinite(length)) return trilinear(s_front, s_back, sizes_.max_length);
  const double pieces = std::ceil(length / sizes_.max_length);
  const int count = static_cast<int>(std::min(pieces, 1e6));
  SegmentColour out;
  for (int p = 0; p < count && out.alpha < 1.0; ++p) {
    const double a = static_cast<double>(p) / count, b = static_cast<double>(p + 1) / count;
    out = composite(out, trilinear(s_front + (s_back - s_front) * a,
                                   s_front + (s_back - s_front) * b, length / count));
  }
  return out;
}

}  // namespace raywarp
