#include "physics/mass_spring.h"

#include <cmath>
#include <string>

#include "base/error.h"

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

Vector MassSpring::forces(const Vector& xs, const Vector& vs) const {
  int n = nodes();
  Vector f(3 * n);
  for (int i = 0; i < n; ++i) f.segment<3>(3 * i) = mass[i] * gravity;
  for (const Spring& s : springs) {
    Eigen::Vector3d d = xs.segment<3>(3 * s.i) - xs.segment<3>(3 * s.j);
    Eigen::Vector3d dv = vs.segment<3>(3 * s.i) - vs.segment<3>(3 * s.j);
    double l = d.norm();
    Eigen::Vector3d fi = Eigen::Vector3d::Zero();
    Eigen::Vector3d u = Eigen::Vector3d::Zero();
    if (l > 0) {
      u = d / l;
      fi = -s.ks * (l - s.rest) * u;
    }
    if (s.kd != 0) {
      if (damping == Damping::relative) {
        fi -= s.kd * dv;
      } else {
        fi -= s.kd * u.dot(dv) * u;
      }
    }
    f.segment<3>(3 * s.i) += fi;
    f.segment<3>(3 * s.j) -= fi;
  }
  return f;
}

Energy MassSpring::energy(const Vector& xs, const Vector& vs) const {
  Energy e;
  for (int i = 0; i < nodes(); ++i) {
    e.kinetic += 0.5 * mass[i] * vs.segment<3>(3 * i).squaredNorm();
    e.gravity -= mass[i] * gravity.dot(xs.segment<3>(3 * i));
  }
  for (const Spring& s : springs) {
    double stretch = (xs.segment<3>(3 * s.i) - xs.segment<3>(3 * s.j)).norm() - s.rest;
    e.spring += 0.5 * s.ks * stretch * stretch;
  }
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
