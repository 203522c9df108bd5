#include "physics/mass_spring.h"

#include <atomic>
#include <cmath>
#include <string>

#include "base/error.h"
#include "physics/parallel.h"

namespace raywarp::physics {

namespace {

using Triplets = std::vector<Eigen::Triplet<double>>;

// Adds the block pattern of one spring: -B on (i, i) and (j, j), +B on (i, j) and (j, i).
void add_spring_block(Triplets& t, int i, int j, const Eigen::Matrix3d& b) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      double e = b(r, c);
      if (e == 0) continue;
      t.emplace_back(3 * i + r, 3 * i + c, -e);
      t.emplace_back(3 * j + r, 3 * j + c, -e);
      t.emplace_back(3 * i + r, 3 * j + c, e);
      t.emplace_back(3 * j + r, 3 * i + c, e);
    }
  }
}

SparseMatrix from_triplets(int n, const Triplets& t) {
  SparseMatrix m(3 * n, 3 * n);
  m.setFromTriplets(t.begin(), t.end());  // duplicates summed in the order given
  return m;
}

}  // namespace

int MassSpring::add_node(const Eigen::Vector3d& position, double m) {
  if (!(m > 0) || !std::isfinite(m)) {
    throw Error("physics: node mass " + std::to_string(m) + ": must be finite and > 0");
  }
  if (!position.allFinite()) throw Error("physics: node position must be finite");
  int n = nodes();
  x.conservativeResize(3 * n + 3);
  v.conservativeResize(3 * n + 3);
  mass.conservativeResize(n + 1);
  x.segment<3>(3 * n) = position;
  v.segment<3>(3 * n).setZero();
  mass[n] = m;
  pinned.push_back(0);
  return n;
}

int MassSpring::add_spring(int i, int j, double ks, double kd, double rest) {
  int n = nodes();
  if (i < 0 || j < 0 || i >= n || j >= n || i == j) {
    throw Error("physics: spring (" + std::to_string(i) + ", " + std::to_string(j) +
                "): nodes must be distinct and in [0, " + std::to_string(n) + ")");
  }
  if (!(ks >= 0) || !(kd >= 0) || !std::isfinite(ks) || !std::isfinite(kd)) {
    throw Error("physics: spring ks, kd must be finite and >= 0");
  }
  Spring s{i, j, rest, ks, kd};
  if (rest < 0) s.rest = (position(i) - position(j)).norm();
  springs.push_back(s);
  return static_cast<int>(springs.size()) - 1;
}

void MassSpring::pin(int node, bool p) {
  if (node < 0 || node >= nodes()) throw Error("physics: pin: no node " + std::to_string(node));
  pinned[node] = p ? 1 : 0;
  if (p) v.segment<3>(3 * node).setZero();
}

void MassSpring::move_pinned(const std::vector<int>& which,
                             const std::vector<Eigen::Vector3d>& positions) {
  if (which.size() != positions.size()) throw Error("physics: move_pinned: sizes differ");
  for (size_t k = 0; k < which.size(); ++k) {
    int node = which[k];
    if (node < 0 || node >= nodes() || !pinned[node]) {
      throw Error("physics: move_pinned: node " + std::to_string(node) + " is not pinned");
    }
    if (!positions[k].allFinite()) throw Error("physics: move_pinned: position not finite");
    x.segment<3>(3 * node) = positions[k];
  }
}

SpringAdjacency spring_adjacency(int n, const std::vector<Spring>& springs) {
  SpringAdjacency a;
  a.nodes = n;
  a.start.assign(static_cast<size_t>(n) + 1, 0);
  for (const Spring& s : springs) {
    a.start[s.i + 1] += 1;
    a.start[s.j + 1] += 1;
  }
  for (int i = 0; i < n; ++i) a.start[i + 1] += a.start[i];
  a.spring.resize(2 * springs.size());
  a.other.resize(2 * springs.size());
  a.first.resize(2 * springs.size());
  a.ends.resize(springs.size());
  std::vector<int> fill(a.start.begin(), a.start.end() - 1);
  // Springs in increasing index, so each node's list is increasing too.
  for (size_t k = 0; k < springs.size(); ++k) {
    const Spring& s = springs[k];
    a.ends[k] = {s.i, s.j};
    a.spring[fill[s.i]] = static_cast<int>(k);
    a.first[fill[s.i]] = 1;
    a.other[fill[s.i]++] = s.j;
    a.spring[fill[s.j]] = static_cast<int>(k);
    a.first[fill[s.j]] = 0;
    a.other[fill[s.j]++] = s.i;
  }
  return a;
}

bool MassSpring::adjacency_matches(const SpringAdjacency& a) const {
  if (a.nodes != nodes() || a.ends.size() != springs.size()) return false;
  for (size_t k = 0; k < springs.size(); ++k) {
    if (a.ends[k][0] != springs[k].i || a.ends[k][1] != springs[k].j) return false;
  }
  return true;
}

std::shared_ptr<const SpringAdjacency> MassSpring::adjacency() const {
  std::shared_ptr<const SpringAdjacency> a = adjacency_.get();
  if (a && adjacency_matches(*a)) return a;
  a = std::make_shared<const SpringAdjacency>(spring_adjacency(nodes(), springs));
  adjacency_.set(a);
  return a;
}

namespace {

// Spring s's force on its end i: f_i = -ks (l - L) u - damping (mass_spring.h); f_j = -f_i.
inline Eigen::Vector3d spring_force(const Spring& sp, Damping damping, const Vector& xs,
                                    const Vector& vs) {
  Eigen::Vector3d d = xs.segment<3>(3 * sp.i) - xs.segment<3>(3 * sp.j);
  double l = d.norm();
  Eigen::Vector3d fi = Eigen::Vector3d::Zero();
  Eigen::Vector3d u = Eigen::Vector3d::Zero();
  if (l > 0) {
    u = d / l;
    fi = -sp.ks * (l - sp.rest) * u;
  }
  if (sp.kd != 0) {
    Eigen::Vector3d dv = vs.segment<3>(3 * sp.i) - vs.segment<3>(3 * sp.j);
    if (damping == Damping::relative) {
      fi -= sp.kd * dv;
    } else {
      fi -= sp.kd * u.dot(dv) * u;
    }
  }
  return fi;
}

}  // namespace

// Two passes: each spring's f_i once (in parallel over springs), then each node's sum over its
// springs in increasing index, f_i added at i and subtracted at j: the bits of the serial loop
// f[i] += f_i, f[j] -= f_i over the springs.
void MassSpring::forces(const Vector& xs, const Vector& vs, Vector& f, bool per_mass) const {
  const int n = nodes();
  if (xs.size() != 3 * n || vs.size() != 3 * n) {
    throw Error("physics: forces: x and v must have 3 n = " + std::to_string(3 * n) + " entries");
  }
  f.resize(3 * n);
  std::shared_ptr<const SpringAdjacency> a = adjacency_.get();
  const std::ptrdiff_t m = static_cast<std::ptrdiff_t>(springs.size());
  if (!a || a->nodes != n || static_cast<std::ptrdiff_t>(a->ends.size()) != m) a = adjacency();
  std::unique_ptr<double[]> per_spring(new double[3 * static_cast<size_t>(m) + 1]);
  for (int attempt = 0; attempt < 2; ++attempt) {
    std::atomic<bool> stale{false};
    detail::for_each_index(m, 1024, [&](std::ptrdiff_t b, std::ptrdiff_t e) {
      bool same = true;
      for (std::ptrdiff_t k = b; k < e; ++k) {
        const Spring& sp = springs[k];
        same = same && a->ends[k][0] == sp.i && a->ends[k][1] == sp.j;
        Eigen::Map<Eigen::Vector3d>(per_spring.get() + 3 * k) = spring_force(sp, damping, xs, vs);
      }
      if (!same) stale = true;
    });
    if (stale) {
      a = adjacency();  // rebuilt: the springs' ends changed
      continue;
    }
    const double* fs = per_spring.get();
    detail::for_each_index(n, 256, [&](std::ptrdiff_t b, std::ptrdiff_t e) {
      for (std::ptrdiff_t i = b; i < e; ++i) {
        Eigen::Vector3d fi = mass[i] * gravity;
        for (int k = a->start[i]; k < a->start[i + 1]; ++k) {
          const double* g = fs + 3 * static_cast<std::ptrdiff_t>(a->spring[k]);
          if (a->first[k]) {
            fi += Eigen::Vector3d(g[0], g[1], g[2]);
          } else {
            fi -= Eigen::Vector3d(g[0], g[1], g[2]);
          }
        }
        if (per_mass) {
          if (pinned[i]) {
            fi.setZero();
          } else {
            fi /= mass[i];
          }
        }
        f.segment<3>(3 * i) = fi;
      }
    });
    return;
  }
  throw Error("physics: forces: the spring adjacency does not match the springs");
}

Vector MassSpring::forces(const Vector& xs, const Vector& vs) const {
  Vector f;
  forces(xs, vs, f);
  return f;
}

Energy MassSpring::energy(const Vector& xs, const Vector& vs) const {
  Energy e;
  const std::ptrdiff_t n = nodes();
  e.kinetic = detail::chunked_sum(n, [&](std::ptrdiff_t b, std::ptrdiff_t end) {
    double k = 0;
    for (std::ptrdiff_t i = b; i < end; ++i)
      k += 0.5 * mass[i] * vs.segment<3>(3 * i).squaredNorm();
    return k;
  });
  e.gravity = detail::chunked_sum(n, [&](std::ptrdiff_t b, std::ptrdiff_t end) {
    double g = 0;
    for (std::ptrdiff_t i = b; i < end; ++i) g -= mass[i] * gravity.dot(xs.segment<3>(3 * i));
    return g;
  });
  e.spring = detail::chunked_sum(
      static_cast<std::ptrdiff_t>(springs.size()), [&](std::ptrdiff_t b, std::ptrdiff_t end) {
        double sum = 0;
        for (std::ptrdiff_t k = b; k < end; ++k) {
          const Spring& s = springs[k];
          double stretch = (xs.segment<3>(3 * s.i) - xs.segment<3>(3 * s.j)).norm() - s.rest;
          sum += 0.5 * s.ks * stretch * stretch;
        }
        return sum;
      });
  return e;
}

Eigen::Vector3d MassSpring::momentum() const {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (int i = 0; i < nodes(); ++i) p += mass[i] * v.segment<3>(3 * i);
  return p;
}

SparseMatrix MassSpring::dfdx(const Vector& xs, bool clamp_compressed) const {
  Triplets t;
  t.reserve(springs.size() * 36);
  for (const Spring& s : springs) {
    Eigen::Vector3d d = xs.segment<3>(3 * s.i) - xs.segment<3>(3 * s.j);
    double l = d.norm();
    if (!(l > 0)) continue;  // no direction: no elastic force, no derivative
    Eigen::Vector3d u = d / l;
    Eigen::Matrix3d uu = u * u.transpose();
    double transverse = 1.0 - s.rest / l;
    if (clamp_compressed && transverse < 0) transverse = 0;
    Eigen::Matrix3d b = s.ks * uu + s.ks * transverse * (Eigen::Matrix3d::Identity() - uu);
    add_spring_block(t, s.i, s.j, b);
  }
  return from_triplets(nodes(), t);
}

SparseMatrix MassSpring::dfdv(const Vector& xs) const {
  Triplets t;
  t.reserve(springs.size() * 36);
  for (const Spring& s : springs) {
    if (s.kd == 0) continue;
    Eigen::Matrix3d b;
    if (damping == Damping::relative) {
      b = s.kd * Eigen::Matrix3d::Identity();
    } else {
      Eigen::Vector3d d = xs.segment<3>(3 * s.i) - xs.segment<3>(3 * s.j);
      double l = d.norm();
      if (!(l > 0)) continue;
      Eigen::Vector3d u = d / l;
      b = s.kd * u * u.transpose();
    }
    add_spring_block(t, s.i, s.j, b);
  }
  return from_triplets(nodes(), t);
}

Vector MassSpring::mass_diagonal() const {
  Vector m(3 * nodes());
  for (int i = 0; i < nodes(); ++i) m.segment<3>(3 * i).setConstant(mass[i]);
  return m;
}

}  // namespace raywarp::physics
