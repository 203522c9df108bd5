#include "physics/spectrum.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "base/error.h"
#include "physics/parallel.h"

namespace raywarp::physics {

namespace {

double dot(const Vector& a, const Vector& b) {
  return detail::chunked_sum(a.size(), [&](std::ptrdiff_t s, std::ptrdiff_t e) {
    double sum = 0;
    for (std::ptrdiff_t k = s; k < e; ++k) sum += a[k] * b[k];
    return sum;
  });
}

}  // namespace

OmegaMax omega_max(const MassSpring& s, double tolerance, int max_iterations) {
  const int n = s.nodes();
  std::vector<int> row(n, -1), node;
  for (int i = 0; i < n; ++i) {
    if (!(s.mass[i] > 0)) throw Error("physics: omega_max: node " + std::to_string(i) + " mass");
    if (!s.is_pinned(i)) {
      row[i] = static_cast<int>(node.size());
      node.push_back(i);
    }
  }
  const int rows = static_cast<int>(node.size());
  if (rows == 0) throw Error("physics: omega_max: no free node");
  // Each spring's block K_s = ks u uᵀ + ks (1 - L/l)(I - u uᵀ) (zero when l = 0), row-major.
  const std::ptrdiff_t m = static_cast<std::ptrdiff_t>(s.springs.size());
  std::vector<Eigen::Matrix3d> k(m);
  detail::for_each_index(m, 1024, [&](std::ptrdiff_t b, std::ptrdiff_t e) {
    for (std::ptrdiff_t q = b; q < e; ++q) {
      const Spring& sp = s.springs[q];
      Eigen::Vector3d d = s.x.segment<3>(3 * sp.i) - s.x.segment<3>(3 * sp.j);
      double l = d.norm();
      k[q].setZero();
      if (l > 0) {
        Eigen::Vector3d u = d / l;
        Eigen::Matrix3d uu = u * u.transpose();
        k[q] = sp.ks * uu + sp.ks * (1.0 - sp.rest / l) * (Eigen::Matrix3d::Identity() - uu);
      }
    }
  });
  const std::shared_ptr<const SpringAdjacency> adj = s.adjacency();
  Vector inv_sqrt_m(3 * rows);
  for (int r = 0; r < rows; ++r)
    inv_sqrt_m.segment<3>(3 * r).setConstant(1 / std::sqrt(s.mass[node[r]]));
  // y = M^{-1/2} K M^{-1/2} p on the free rows; (K w)_i = Σ_s K_s (w_i - w_o), w = 0 on pins.
  Vector w(3 * rows);
  auto apply = [&](const Vector& p, Vector& y) {
    w = p.cwiseProduct(inv_sqrt_m);
    y.resize(3 * rows);
    detail::for_each_index(rows, 256, [&](std::ptrdiff_t b, std::ptrdiff_t e) {
      for (std::ptrdiff_t r = b; r < e; ++r) {
        const int i = node[r];
        const Eigen::Vector3d wi = w.segment<3>(3 * r);
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        for (int a = adj->start[i]; a < adj->start[i + 1]; ++a) {
          const int o = row[adj->other[a]];
          Eigen::Vector3d dw = o >= 0 ? Eigen::Vector3d(wi - w.segment<3>(3 * o)) : wi;
          sum += k[adj->spring[a]] * dw;
        }
        y.segment<3>(3 * r) = sum.cwiseProduct(inv_sqrt_m.segment<3>(3 * r));
      }
    });
  };
  // Lanczos: A q_k = β_{k-1} q_{k-1} + α_k q_k + β_k q_{k+1}.
  const int dim = 3 * rows;
  Vector q(dim), q_prev = Vector::Zero(dim), z(dim);
  std::mt19937 gen(20260u);
  for (int e = 0; e < dim; ++e) q[e] = gen() / 4294967296.0 - 0.5;
  q /= std::sqrt(dot(q, q));
  std::vector<double> alpha, beta;
  OmegaMax out;
  out.dimension = dim;
  double beta_prev = 0;
  const int cap = std::min(max_iterations, dim);
  for (int it = 1; it <= cap; ++it) {
    apply(q, z);
    const double a = dot(q, z);
    z -= a * q;
    z -= beta_prev * q_prev;
    const double b = std::sqrt(dot(z, z));
    alpha.push_back(a);
    out.iterations = it;
    const bool breakdown = !(b > 1e-14 * std::abs(a));  // an invariant subspace: exact
    if (it % 10 == 0 || it == cap || breakdown) {
      Eigen::VectorXd diag = Eigen::Map<Eigen::VectorXd>(alpha.data(), it);
      Eigen::VectorXd sub = it > 1
                                ? Eigen::VectorXd(Eigen::Map<Eigen::VectorXd>(beta.data(), it - 1))
                                : Eigen::VectorXd();
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es;
      es.computeFromTridiagonal(diag, sub, Eigen::ComputeEigenvectors);
      const double theta = es.eigenvalues()[it - 1];
      const double last = es.eigenvectors()(it - 1, it - 1);
      out.eigenvalue = theta;
      out.residual = breakdown ? 0.0 : std::abs(b * last);
      if (out.residual <= tolerance * std::abs(theta)) {
        out.converged = true;
        break;
      }
    }
    if (breakdown) break;
    beta.push_back(b);
    q_prev.swap(q);
    q = z / b;
    beta_prev = b;
  }
  out.omega = std::sqrt(std::max(0.0, out.eigenvalue));
  return out;
}

}  // namespace raywarp::physics
