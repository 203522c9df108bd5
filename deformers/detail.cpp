#include "deformers/detail.h"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "base/error.h"

namespace raywarp {

namespace {

constexpr double kPi = 3.14159265358979323846;
// max |S'(u)| of the smoothstep S(u) = u^2 (3 - 2 u), at u = 1/2.
constexpr double kMaxWindowSlope = 1.5;

// splitmix64 (Steele, Lea & Flood 2014): the same numbers on every platform.
class SplitMix {
 public:
  explicit SplitMix(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1).
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  // Uniform on the unit sphere (Archimedes: z uniform in [-1, 1], the azimuth uniform).
  Eigen::Vector3d direction() {
    const double z = 2.0 * uniform() - 1.0, a = 2.0 * kPi * uniform();
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    return {r * std::cos(a), r * std::sin(a), z};
  }

 private:
  std::uint64_t state_;
};

struct Wave {
  Eigen::Vector3d b;  // amplitude, divided by A
  Eigen::Vector3d c;  // wave vector, 2 pi m / lambda times the direction
  double phase = 0;
};

struct Noise {
  std::array<Wave, kDetailWaves> waves;
  double lipschitz = 0;  // L_N
};

// The largest || sum_k e_k M_k || over signs e_k (e_0 = +1: -e gives the same norm).
template <typename Norm, typename Term>
double max_over_signs(Norm norm, Term term) {
  double best = 0;
  for (unsigned mask = 0; mask < (1u << (kDetailWaves - 1)); ++mask) {
    auto sum = term(0);
    for (int k = 1; k < kDetailWaves; ++k) {
      if (mask & (1u << (k - 1)))
        sum -= term(k);
      else
        sum += term(k);
    }
    best = std::max(best, norm(sum));
  }
  return best;
}

double spectral_norm(const Eigen::Matrix3d& m) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(m.transpose() * m,
                                                           Eigen::EigenvaluesOnly);
  return std::sqrt(std::max(0.0, eig.eigenvalues().maxCoeff()));
}

Noise make_noise(double wavelength, std::uint64_t seed) {
  SplitMix rng(seed);
  Noise n;
  std::array<Eigen::Vector3d, kDetailWaves> a;
  for (int k = 0; k < kDetailWaves; ++k) {
    const Eigen::Vector3d u = rng.direction();
    a[k] = rng.direction();
    const double m = 0.75 + 0.5 * rng.uniform();
    n.waves[k].c = (2.0 * kPi * m / wavelength) * u;
    n.waves[k].phase = 2.0 * kPi * rng.uniform();
  }
  const double amax = max_over_signs([](const Eigen::Vector3d& v) { return v.norm(); },
                                     [&](int k) -> Eigen::Vector3d { return a[k]; });
  for (int k = 0; k < kDetailWaves; ++k) n.waves[k].b = a[k] / amax;
  n.lipschitz = max_over_signs(spectral_norm, [&](int k) -> Eigen::Matrix3d {
    return n.waves[k].b * n.waves[k].c.transpose();
  });
  return n;
}

// x rounded down to 3 significant digits, as text ("0.123"): a value a user may copy.
std::string three_digits_down(double x) {
  if (!(x > 0.0) || !std::isfinite(x)) return shortest_text(x);
  const double unit = std::pow(10.0, std::floor(std::log10(x)) - 2.0);
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", std::floor(x / unit) * unit);
  return buf;
}

std::string three_digits(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return buf;
}

// The window's falloff width along each axis: the wavelength, at most the half extent.
Eigen::Vector3d window_margins(const Eigen::Vector3d& h, double wavelength) {
  return h.cwiseMin(wavelength);
}

double window_slope_bound(const Eigen::Vector3d& margins) {
  return kMaxWindowSlope * margins.cwiseInverse().norm();
}

// The reasons a wavelength is refused, or empty.
std::string wavelength_problem(const Eigen::Vector3d& h, double wavelength) {
  if (!(wavelength > 0.0) || !std::isfinite(wavelength) || wavelength > 1e6 * h.norm())
    return "wavelength = " + shortest_text(wavelength) +
           ": must be > 0 and at most 1e6 |h| = " + shortest_text(1e6 * h.norm());
  return "";
}

class Detail final : public Deformer {
 public:
  Detail(const Eigen::Vector3d& h, double scale, double wavelength, std::uint64_t seed,
         const Noise& noise)
      : h_(h),
        scale_(scale),
        wavelength_(wavelength),
        seed_(seed),
        noise_(noise),
        margin_(window_margins(h, wavelength)),
        tolerance_(1e-14 * h.norm()) {}

  std::string describe() const override {
    return "detail noise of scale " + shortest_text(scale_) + ", wavelength " +
           shortest_text(wavelength_) + ", seed " + std::to_string(seed_);
  }

  Eigen::Vector3d forward(const Eigen::Vector3d& p) const override {
    if (!inside(p)) return p;
    return p + scale_ * window(p) * noise(p);
  }

  Eigen::Matrix3d jacobian(const Eigen::Vector3d& p) const override {
    if (!inside(p)) return Eigen::Matrix3d::Identity();
    Eigen::Vector3d g, dg;
    for (int i = 0; i < 3; ++i) g[i] = ramp(p, i, &dg[i]);
    const Eigen::Vector3d grad_w(dg[0] * g[1] * g[2], g[0] * dg[1] * g[2], g[0] * g[1] * dg[2]);
    const double w = g.prod();
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    Eigen::Matrix3d dn = Eigen::Matrix3d::Zero();
    for (const Wave& wave : noise_.waves) {
      const double arg = wave.c.dot(p) + wave.phase;
      n += std::sin(arg) * wave.b;
      dn += std::cos(arg) * wave.b * wave.c.transpose();
    }
    return Eigen::Matrix3d::Identity() + scale_ * (n * grad_w.transpose() + w * dn);
  }

  Eigen::Vector3d inverse(const Eigen::Vector3d& p_def) const override {
    if (!inside(p_def) || scale_ == 0.0) return p_def;
    Eigen::Vector3d p = p_def;
    for (int i = 0; i < 6; ++i) p = p_def - displacement(p);
    Eigen::Vector3d best = p;
    double best_r = (forward(p) - p_def).norm();
    for (int i = 0; i < 8 && best_r > tolerance_; ++i) {
      p -= jacobian(p).partialPivLu().solve(forward(p) - p_def);
      if (!p.allFinite()) break;
      const double r = (forward(p) - p_def).norm();
      if (r < best_r) {
        best = p;
        best_r = r;
      }
    }
    p = best;
    for (int i = 0; i < 100 && best_r > tolerance_; ++i) {
      p = p_def - displacement(p);
      const double r = (forward(p) - p_def).norm();
      if (r < best_r) {
        best = p;
        best_r = r;
      }
    }
    return best;
  }

  std::array<bool, 6> identity_faces() const override {
    std::array<bool, 6> faces;
    faces.fill(true);
    return faces;
  }

 private:
  bool inside(const Eigen::Vector3d& p) const { return (p.cwiseAbs().array() < h_.array()).all(); }

  // The window's factor along axis i, g(p_i) = S((h_i - |p_i|) / m_i) (1 past the margin), and
  // its derivative dg/dp_i in `slope` when asked.
  double ramp(const Eigen::Vector3d& p, int i, double* slope = nullptr) const {
    const double u = (h_[i] - std::abs(p[i])) / margin_[i];
    if (slope) *slope = 0.0;
    if (u >= 1.0) return 1.0;
    if (!(u > 0.0)) return 0.0;
    if (slope) *slope = (p[i] < 0.0 ? 6.0 : -6.0) * u * (1.0 - u) / margin_[i];
    return u * u * (3.0 - 2.0 * u);
  }

  double window(const Eigen::Vector3d& p) const { return ramp(p, 0) * ramp(p, 1) * ramp(p, 2); }

  Eigen::Vector3d noise(const Eigen::Vector3d& p) const {
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    for (const Wave& wave : noise_.waves) n += std::sin(wave.c.dot(p) + wave.phase) * wave.b;
    return n;
  }

  Eigen::Vector3d displacement(const Eigen::Vector3d& p) const {
    if (!inside(p)) return Eigen::Vector3d::Zero();
    return scale_ * window(p) * noise(p);
  }

  Eigen::Vector3d h_;
  double scale_, wavelength_;
  std::uint64_t seed_;
  Noise noise_;
  Eigen::Vector3d margin_;
  double tolerance_;
};

}  // namespace

double detail_lipschitz(const Eigen::Vector3d& half_extents, double wavelength,
                        std::uint64_t seed) {
  check_half_extents("detail", half_extents);
  if (const std::string problem = wavelength_problem(half_extents, wavelength); !problem.empty())
    throw Error(problem);
  return window_slope_bound(window_margins(half_extents, wavelength)) +
         make_noise(wavelength, seed).lipschitz;
}

double detail_max_scale(const Eigen::Vector3d& half_extents, double wavelength,
                        std::uint64_t seed) {
  return kMaxDetailContraction / detail_lipschitz(half_extents, wavelength, seed);
}

std::unique_ptr<Deformer> make_detail(const Eigen::Vector3d& half_extents, double scale,
                                      double wavelength, std::uint64_t seed) {
  check_half_extents("detail", half_extents);
  if (const std::string problem = wavelength_problem(half_extents, wavelength); !problem.empty())
    throw Error(problem);
  if (seed > 0xffffffffULL)
    throw Error("seed = " + std::to_string(seed) + ": must be an integer in [0, 4294967295]");
  const Noise noise = make_noise(wavelength, seed);
  const double lipschitz =
      window_slope_bound(window_margins(half_extents, wavelength)) + noise.lipschitz;
  const double max_scale = kMaxDetailContraction / lipschitz;
  if (!(scale >= 0.0) || !std::isfinite(scale) || scale * lipschitz > kMaxDetailContraction)
    throw Error("scale = " + shortest_text(scale) + ": must be in [0, " +
                three_digits_down(max_scale) + "] for wavelength " + shortest_text(wavelength) +
                ", seed " + std::to_string(seed) + " and this box: scale times the Lipschitz " +
                "bound " + three_digits(lipschitz) + " of the windowed noise must be at most " +
                shortest_text(kMaxDetailContraction) +
                ", or the detail could fold space (a longer wavelength allows more)");
  return std::make_unique<Detail>(half_extents, scale, wavelength, seed, noise);
}

bool is_detail(const Deformer& d) { return dynamic_cast<const Detail*>(&d) != nullptr; }

}  // namespace raywarp
