// The implicit integrator's linear system (internal to physics/): a symmetric matrix over the
// free nodes stored as 3 x 3 blocks, a fixed pattern built once per set of springs and pins and
// refilled each step, and the Jacobi-preconditioned conjugate gradient on it.
//
// Layout: block row r is free node node[r]; its blocks are [start[r], start[r + 1]), the
// diagonal block first, then one block per free neighbour in the order of the node's springs
// (SpringAdjacency), col[b] the neighbour's row. A block is symmetric and stored as its upper
// triangle, 6 values: xx, xy, xz, yy, yz, zz. slot[k] maps adjacency entry k to the block of its
// spring in the row of the entry's node (-1 when the other end is pinned); two springs between
// the same nodes share one block.
//
// Threads: every product and refill is a gather by block row and every dot product a chunked sum
// (physics/parallel.h), so the results are the same for any thread count.
#pragma once
#include <cstdint>
#include <memory>
#include <vector>

#include "physics/mass_spring.h"

namespace raywarp::physics::detail {

struct Sym3 {
  double xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz = 0;
};

class BlockSystem {
 public:
  // Builds the pattern for `system`'s springs (its adjacency `a`) and pins, if it has not got it.
  void prepare(const MassSpring& system, const std::shared_ptr<const SpringAdjacency>& a);
  // The matrix diag(m) + Σ_s c_s in the spring pattern: A_ii = m_i I + Σ_{s at i} c_s,
  // A_ij = -Σ_{s between i and j} c_s, over the free nodes; c has one Sym3 per spring.
  void fill(const MassSpring& system, const std::vector<Sym3>& c);
  int rows() const { return rows_; }
  int node(int row) const { return node_[row]; }
  int row_of(int node) const { return row_of_[node]; }
  // y = A p (3 rows per block row).
  void multiply(const Eigen::VectorXd& p, Eigen::VectorXd& y) const;

  struct CgResult {
    int products = 0;     // matrix-vector products (the iterations)
    double residual = 0;  // the recurrence's |r| / |b|
    bool converged = true;
  };
  // Jacobi-preconditioned CG from x = 0, Eigen's ConjugateGradient step for step (it stops when
  // |r|² < tolerance² |b|², or after max_iterations products).
  CgResult solve(const Eigen::VectorXd& b, Eigen::VectorXd& x, double tolerance,
                 int max_iterations);

 private:
  std::shared_ptr<const SpringAdjacency> adjacency_;
  std::vector<std::uint8_t> pinned_;
  int rows_ = 0;
  std::vector<int> node_, row_of_, start_, col_, slot_;
  std::vector<Sym3> value_;
  Eigen::VectorXd inv_diag_, r_, p_, q_;
};

double dot(const Eigen::VectorXd& a, const Eigen::VectorXd& b);

}  // namespace raywarp::physics::detail
