#include "deformers/control_points.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "base/error.h"

namespace raywarp {

namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();
// Relative tolerances, as fractions of the box diagonal L (see control_points.h).
constexpr double kInsideTolerance = 1e-9;  // sources in the box, on a pinned face
constexpr double kCoincident = 1e-6;       // distinct sources
constexpr double kAffineSpread = 1e-3;     // RMS spread that earns a polynomial direction
constexpr double kMinRcond = 1e-15;        // reciprocal condition of the interpolation system
constexpr double kPoorRcond = 1e-10;       // below this, a warning
constexpr double kSolveResidual = 1e-9;    // of the right-hand side
constexpr double kConverged = 1e-13;       // Newton's residual
constexpr int kNewtonIterations = 50;
constexpr int kHalvings = 10;
constexpr int kStall = 5;

std::string point_name(size_t i) { return "points[" + std::to_string(i) + "]"; }

// The pin mask of one axis: which of its faces are pinned.
enum class Pin { None, Minus, Plus, Both };

class ControlPoints final : public Deformer {
 public:
  static constexpr int kBlock = 16;
  using Block = Eigen::Array<double, kBlock, 1>;
  // kBlock sources and their weights; the bounding sphere of the sources (local kernel culling).
  struct KernelBlock {
    Block sx, sy, sz, wx, wy, wz;
    Eigen::Vector3d centre;
    double reach;
  };
  struct Kernel {
    std::vector<KernelBlock, Eigen::aligned_allocator<KernelBlock>> blocks;
  };

  ControlPoints(const Eigen::Vector3d& h, size_t pairs, double radius, std::array<bool, 6> pinned,
                bool identity, Kernel kernel, const Eigen::Vector3d& c0, const Eigen::Vector3d& mu,
                const Eigen::Matrix3d& linear)
      : h_(h),
        diagonal_(2.0 * h.norm()),
        pairs_(pairs),
        radius_(radius),
        pinned_(pinned),
        identity_(identity),
        k_(std::move(kernel)),
        c0_(c0),
        mu_(mu),
        linear_(linear),
        far_(1e30 * diagonal_) {
    for (int a = 0; a < 3; ++a) {
      const bool minus = pinned[2 * a], plus = pinned[2 * a + 1];
      pin_[a] = minus && plus ? Pin::Both : minus ? Pin::Minus : plus ? Pin::Plus : Pin::None;
    }
    if (!identity_) build_start_table();
  }

  std::string describe() const override {
    std::string text = "control points (" + std::to_string(pairs_) +
                       (pairs_ == 1 ? " pair, " : " pairs, ") +
                       (radius_ > 0.0 ? "radius " + shortest_text(radius_) : "global");
    std::string faces;
    for (int f = 0; f < 6; ++f)
      if (pinned_[f]) {
        faces += ' ';
        faces += face_name(face_of(f));
      }
    if (!faces.empty()) text += ", pinned" + faces;
    return text + ")";
  }

  Eigen::Vector3d forward(const Eigen::Vector3d& p) const override {
    if (identity_) return p;
    return p + displacement(p, nullptr);
  }

  Eigen::Matrix3d jacobian(const Eigen::Vector3d& p) const override {
    Eigen::Matrix3d J = Eigen::Matrix3d::Identity();
    if (!identity_) displacement(p, &J);
    return J;
  }

  Eigen::Vector3d inverse(const Eigen::Vector3d& p_def) const override {
    const Eigen::Vector3d target = p_def.cwiseMax(-far_).cwiseMin(far_);
    if (identity_) return target;
    const double tolerance = kConverged * diagonal_ + 4.0 * kEps * target.cwiseAbs().maxCoeff();
    Root best;
    for (int k = 0; k < 3 && best.rank < 3; ++k) {
      const Eigen::Vector3d start = k == 0   ? table_start(target)
                                    : k == 1 ? target - displacement(target, nullptr)
                                             : target;
      Root root = newton(start, target, tolerance);
      root.rank = rank_of(root);
      if (root.rank > best.rank || (root.rank == best.rank && root.residual < best.residual))
        best = root;
    }
    if (best.converged) return best.p;
    // No root found: p' is taken to have no preimage in the box (as it has none where it lies
    // outside F(box)), so the best iterate is returned just beyond the box face nearest to it if it
    // lies inside: the texel is empty rather than a wrong surface.
    Eigen::Vector3d p = best.p;
    const Eigen::Vector3d margin = h_ - p.cwiseAbs();
    if ((margin.array() >= 0.0).all()) {
      Eigen::Index a = 0;
      margin.minCoeff(&a);
      p[a] = (p[a] < 0.0 ? -1.0 : 1.0) * (h_[a] + kInsideTolerance * diagonal_);
    }
    return p;
  }

  std::array<bool, 6> identity_faces() const override {
    std::array<bool, 6> faces = pinned_;
    if (identity_) faces.fill(true);
    return faces;
  }

 private:
  struct Root {
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    double residual = std::numeric_limits<double>::infinity();
    double det = 0.0;
    bool converged = false;
    int rank = 0;  // see rank_of
  };
  // How much a root is wanted: 3 converged with det > 0 (the search stops at the first), 2
  // converged in the box with det <= 0 (a fold's other branch), 1 any other converged point, 0 not
  // converged.
  int rank_of(const Root& root) const {
    if (!root.converged) return 0;
    if (root.det > 0.0) return 3;
    return (root.p.cwiseAbs().array() <= h_.array()).all() ? 2 : 1;
  }

  // Damped Newton on F(p) = target from `start`.
  Root newton(const Eigen::Vector3d& start, const Eigen::Vector3d& target, double tolerance) const {
    Root root;
    root.p = start;
    Eigen::Matrix3d J = Eigen::Matrix3d::Identity();
    Eigen::Vector3d r = start + displacement(start, &J) - target;
    root.residual = r.norm();
    if (!std::isfinite(root.residual)) {  // cannot happen for clamped finite input; stay safe
      root.p = target;
      return root;
    }
    // Progress check: a start that has not halved its residual in kStall iterations is given up.
    double checkpoint = root.residual;
    for (int it = 0; it < kNewtonIterations && root.residual > tolerance; ++it) {
      if (it > 0 && it % kStall == 0) {
        if (root.residual > 0.5 * checkpoint) break;
        checkpoint = root.residual;
      }
      Eigen::Vector3d step;
      const double det = J.determinant();
      const double size = J.cwiseAbs().maxCoeff();
      if (std::abs(det) > 1e-12 * size * size * size) {
        step = -J.inverse() * r;
      } else {
        // Singular: steepest descent on |r|^2 / 2, the length that zeroes r along it if linear.
        const Eigen::Vector3d g = J.transpose() * r;
        const double jg = (J * g).squaredNorm();
        if (!(jg > 0.0)) break;
        step = -g * (g.squaredNorm() / jg);
      }
      if (!step.allFinite()) break;
      bool accepted = false;
      double alpha = 1.0;
      for (int k = 0; k <= kHalvings; ++k, alpha *= 0.5) {
        const Eigen::Vector3d trial = root.p + alpha * step;
        Eigen::Matrix3d J_trial = Eigen::Matrix3d::Identity();
        const Eigen::Vector3d r_trial = trial + displacement(trial, &J_trial) - target;
        const double n_trial = r_trial.norm();
        if (n_trial < root.residual) {
          root.p = trial;
          root.residual = n_trial;
          r = r_trial;
          J = J_trial;
          accepted = true;
          break;
        }
      }
      if (!accepted) break;
    }
    root.converged = root.residual <= tolerance;
    root.det = J.determinant();
    return root;
  }

  // The displacement F(p) - p: u(q) + J_u(q) (p - q) with q = clamp(p) (see control_points.h).
  // With J non-null, adds its derivative to *J.
  Eigen::Vector3d displacement(const Eigen::Vector3d& p_in, Eigen::Matrix3d* J) const {
    const Eigen::Vector3d p = p_in.cwiseMax(-far_).cwiseMin(far_);
    const Eigen::Vector3d q = p.cwiseMax(-h_).cwiseMin(h_);
    const Eigen::Vector3d w = p - q;  // non-zero only along the axes where p lies beyond a face
    const bool outside = (w.array() != 0.0).any();
    const bool need_jv = J || outside;
    const bool need_hessian = J && outside;
    // The kernel sums, a block of kBlock sources at a time (Eigen vectorises the arithmetic and
    // the square roots; padding has zero weights): v, J_v, and for the Jacobian beyond the box
    // k_ib = sum_j w_ij g2_j (d_j . w) d_jb, with d_j = q - s_j, g = phi'(r) / r and
    // g2 = g'(r) / r (d^2 v_i / dq_b dq_c = sum_j w_ij (g_j delta_bc + g2_j d_jb d_jc)).
    Block v_acc[3], jv_acc[9], k_acc[9];
    for (Block& x : v_acc) x.setZero();
    if (need_jv)
      for (Block& x : jv_acc) x.setZero();
    if (need_hessian)
      for (Block& x : k_acc) x.setZero();
    const bool global = radius_ == 0.0;
    const double inv_l3 = 1.0 / (diagonal_ * diagonal_ * diagonal_);
    const double inv_r = global ? 0.0 : 1.0 / radius_;
    for (const KernelBlock& kb : k_.blocks) {
      // Local kernel: skip a block whose sources all lie R or farther from q.
      if (!global && (q - kb.centre).norm() - kb.reach >= radius_) continue;
      const Block d[3] = {q.x() - kb.sx, q.y() - kb.sy, q.z() - kb.sz};
      const Block r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
      const Block* weight[3] = {&kb.wx, &kb.wy, &kb.wz};
      Block phi, g, g2r;  // phi(r), phi'(r) / r, g'(r) / r
      if (global) {
        // phi = (r / L)^3, g = 3 r / L^3, g2 = 3 / (L^3 r) (its d d^T term vanishes at r = 0).
        phi = r * r * r * inv_l3;
        g = 3.0 * inv_l3 * r;
        if (need_hessian) g2r = (r > 0.0).select((3.0 * inv_l3) / r, 0.0);
      } else {
        // phi = (1 - r/R)^4 (4 r/R + 1), g = -20 (1 - r/R)^3 / R^2, g2 = 60 (1 - r/R)^2 / (R^3 r),
        // all zero for r >= R.
        const Block rho = (r * inv_r).min(1.0);
        const Block t = 1.0 - rho, t2 = t * t;
        phi = t2 * t2 * (4.0 * rho + 1.0);
        g = (-20.0 * inv_r * inv_r) * t2 * t;
        if (need_hessian) g2r = (r > 0.0).select((60.0 * inv_r * inv_r * inv_r) * t2 / r, 0.0);
      }
      for (int i = 0; i < 3; ++i) v_acc[i] += *weight[i] * phi;
      if (need_jv)
        for (int i = 0; i < 3; ++i) {
          const Block wg = *weight[i] * g;
          for (int c = 0; c < 3; ++c) jv_acc[3 * i + c] += wg * d[c];
        }
      if (need_hessian) {
        const Block dw = d[0] * w.x() + d[1] * w.y() + d[2] * w.z();
        for (int i = 0; i < 3; ++i) {
          const Block wk = *weight[i] * g2r * dw;
          for (int c = 0; c < 3; ++c) k_acc[3 * i + c] += wk * d[c];
        }
      }
    }
    // v adds the affine part (zero in the local mode), J_v its linear map.
    const Eigen::Vector3d v =
        Eigen::Vector3d(v_acc[0].sum(), v_acc[1].sum(), v_acc[2].sum()) + c0_ + linear_ * (q - mu_);

    // The pin mask: m = prod_a f_a(q_a), its gradient and its Hessian times w.
    double f[3], df[3], ddf[3];
    for (int a = 0; a < 3; ++a) {
      const double x = q[a] / h_[a];
      switch (pin_[a]) {
        case Pin::None:
          f[a] = 1.0, df[a] = 0.0, ddf[a] = 0.0;
          break;
        case Pin::Minus:
          f[a] = 0.5 * (1.0 + x), df[a] = 0.5 / h_[a], ddf[a] = 0.0;
          break;
        case Pin::Plus:
          f[a] = 0.5 * (1.0 - x), df[a] = -0.5 / h_[a], ddf[a] = 0.0;
          break;
        case Pin::Both:
          f[a] = 1.0 - x * x, df[a] = -2.0 * x / h_[a], ddf[a] = -2.0 / (h_[a] * h_[a]);
          break;
      }
    }
    const double m = f[0] * f[1] * f[2];
    if (!need_jv) return m * v;

    Eigen::Matrix3d Jv;
    for (int k = 0; k < 9; ++k) Jv(k / 3, k % 3) = jv_acc[k].sum();
    Jv += linear_;
    const Eigen::Vector3d grad_m(df[0] * f[1] * f[2], f[0] * df[1] * f[2], f[0] * f[1] * df[2]);
    const Eigen::Matrix3d Ju = v * grad_m.transpose() + m * Jv;  // du/dq
    const Eigen::Vector3d U = m * v + Ju * w;
    if (!J) return U;

    Eigen::Matrix3d JU = Ju;
    if (outside) {
      // d/dq_b of J_u(q) w for the axes b where q_b = p_b (beyond a face, q_a is held):
      // sum_c u_bc w_c = (H_m w)_b v + m_b J_v w + (grad m . w) J_v e_b + m k e_b (w_b = 0).
      Eigen::Vector3d hm_w;  // H_m w, H_m the mask's Hessian
      for (int b = 0; b < 3; ++b) {
        hm_w[b] = 0.0;
        for (int c = 0; c < 3; ++c) {
          double h_bc = 1.0;
          for (int a = 0; a < 3; ++a)
            h_bc *= a == b && a == c ? ddf[a] : a == b || a == c ? df[a] : f[a];
          hm_w[b] += h_bc * w[c];
        }
      }
      Eigen::Matrix3d K;
      for (int k = 0; k < 9; ++k) K(k / 3, k % 3) = k_acc[k].sum();
      const Eigen::Vector3d jv_w = Jv * w;
      const double grad_m_w = grad_m.dot(w);
      for (int b = 0; b < 3; ++b)
        if (w[b] == 0.0)
          JU.col(b) += hm_w[b] * v + grad_m[b] * jv_w + grad_m_w * Jv.col(b) + m * K.col(b);
    }
    *J += JU;
    return U;
  }

  // The start table: F at the nodes of a kStartCells^3 lattice over the box, and a Newton step's
  // worth of inverse there. A start for p' is the nearest node's image's linear inverse.
  static constexpr int kStartCells = 8;
  struct StartNode {
    Eigen::Vector3d p, f;
    Eigen::Matrix3d inverse_jacobian;
  };
  void build_start_table() {
    constexpr int n = kStartCells + 1;
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          StartNode node;
          node.p = h_.cwiseProduct(Eigen::Vector3d(i, j, k) * (2.0 / kStartCells) -
                                   Eigen::Vector3d::Ones());
          Eigen::Matrix3d J = Eigen::Matrix3d::Identity();
          node.f = node.p + displacement(node.p, &J);
          bool invertible = false;
          J.computeInverseWithCheck(node.inverse_jacobian, invertible, 1e-12);
          if (!invertible || !(J.determinant() > 0.0) || !node.inverse_jacobian.allFinite())
            node.inverse_jacobian.setIdentity();
          nodes_.push_back(node);
        }
    for (size_t first = 0; first < nodes_.size(); first += kBlock) {
      NodeBlock nb;
      for (int k = 0; k < kBlock; ++k) {
        const size_t i = first + k;
        const double inf = std::numeric_limits<double>::infinity();
        nb.fx[k] = i < nodes_.size() ? nodes_[i].f.x() : inf;
        nb.fy[k] = i < nodes_.size() ? nodes_[i].f.y() : inf;
        nb.fz[k] = i < nodes_.size() ? nodes_[i].f.z() : inf;
      }
      node_blocks_.push_back(nb);
    }
  }
  Eigen::Vector3d table_start(const Eigen::Vector3d& target) const {
    double best = std::numeric_limits<double>::infinity();
    size_t best_index = 0;
    for (size_t b = 0; b < node_blocks_.size(); ++b) {
      const NodeBlock& nb = node_blocks_[b];
      const Block d2 = (nb.fx - target.x()).square() + (nb.fy - target.y()).square() +
                       (nb.fz - target.z()).square();
      Eigen::Index k = 0;
      const double m = d2.minCoeff(&k);
      if (m < best) best = m, best_index = b * kBlock + static_cast<size_t>(k);
    }
    const StartNode& node = nodes_[best_index];
    return node.p + node.inverse_jacobian * (target - node.f);
  }
  struct NodeBlock {
    Block fx, fy, fz;
  };

  Eigen::Vector3d h_;
  double diagonal_;
  size_t pairs_;
  double radius_;
  std::array<bool, 6> pinned_;
  Pin pin_[3];
  bool identity_;
  Kernel k_;
  Eigen::Vector3d c0_, mu_;
  Eigen::Matrix3d linear_;
  double far_;
  std::vector<StartNode> nodes_;
  std::vector<NodeBlock, Eigen::aligned_allocator<NodeBlock>> node_blocks_;
};

// The pin mask m at q (see control_points.h).
double pin_mask(const Eigen::Vector3d& h, const std::array<bool, 6>& pinned,
                const Eigen::Vector3d& q) {
  double m = 1.0;
  for (int a = 0; a < 3; ++a) {
    const double x = q[a] / h[a];
    const bool minus = pinned[2 * a], plus = pinned[2 * a + 1];
    if (minus && plus)
      m *= 1.0 - x * x;
    else if (minus)
      m *= 0.5 * (1.0 + x);
    else if (plus)
      m *= 0.5 * (1.0 - x);
  }
  return m;
}

// Interleaves the low 10 bits of x into every third bit (a Morton code's axis).
std::uint32_t spread_bits(std::uint32_t x) {
  x &= 0x3ff;
  x = (x | (x << 16)) & 0x030000ff;
  x = (x | (x << 8)) & 0x0300f00f;
  x = (x | (x << 4)) & 0x030c30c3;
  x = (x | (x << 2)) & 0x09249249;
  return x;
}

// The sources (rows of S) and weights in blocks, in Morton order over the box so that a block's
// sources lie close together (its bounding sphere is small, for the local kernel's culling).
ControlPoints::Kernel make_kernel(const Eigen::MatrixXd& S, const Eigen::MatrixXd& weights,
                                  const Eigen::Vector3d& h) {
  constexpr int kBlock = ControlPoints::kBlock;
  const Eigen::Index n = S.rows();
  std::vector<std::pair<std::uint32_t, Eigen::Index>> order;
  for (Eigen::Index i = 0; i < n; ++i) {
    std::uint32_t code = 0;
    for (int a = 0; a < 3; ++a) {
      const double u = std::clamp((S(i, a) + h[a]) / (2.0 * h[a]), 0.0, 1.0);
      code |= spread_bits(static_cast<std::uint32_t>(u * 1023.0)) << a;
    }
    order.emplace_back(code, i);
  }
  std::sort(order.begin(), order.end());
  ControlPoints::Kernel kernel;
  for (Eigen::Index first = 0; first < n; first += kBlock) {
    ControlPoints::KernelBlock kb;
    const Eigen::Index count = std::min<Eigen::Index>(kBlock, n - first);
    const Eigen::Index pad = order[first].second;  // padding: the first source, weight 0
    for (int k = 0; k < kBlock; ++k) {
      const Eigen::Index i = k < count ? order[first + k].second : pad;
      kb.sx[k] = S(i, 0), kb.sy[k] = S(i, 1), kb.sz[k] = S(i, 2);
      const double use = k < count ? 1.0 : 0.0;
      kb.wx[k] = use * weights(i, 0), kb.wy[k] = use * weights(i, 1),
      kb.wz[k] = use * weights(i, 2);
    }
    kb.centre = Eigen::Vector3d(kb.sx.mean(), kb.sy.mean(), kb.sz.mean());
    kb.reach = 0.0;
    for (int k = 0; k < kBlock; ++k)
      kb.reach =
          std::max(kb.reach, (Eigen::Vector3d(kb.sx[k], kb.sy[k], kb.sz[k]) - kb.centre).norm());
    kernel.blocks.push_back(kb);
  }
  return kernel;
}

// Throws the ill-conditioning error, naming the closest pair of sources.
[[noreturn]] void throw_ill_conditioned(double rcond, double residual, size_t a, size_t b,
                                        double distance, double diagonal) {
  std::string text =
      "the control points' interpolation system is ill-conditioned (reciprocal "
      "condition number " +
      shortest_text(rcond) + ", relative residual " + shortest_text(residual) + ")";
  if (a != b)
    text += ": the closest sources, " + point_name(a) + " and " + point_name(b) + ", are " +
            shortest_text(distance) + " apart (" + shortest_text(distance / diagonal) +
            " of the box diagonal); move them apart or merge them";
  throw Error(text);
}

}  // namespace

std::unique_ptr<Deformer> make_control_points(const Eigen::Vector3d& half_extents,
                                              std::vector<ControlPoint> points, double radius,
                                              std::array<bool, 6> pinned,
                                              std::vector<std::string>* warnings) {
  check_half_extents("control points", half_extents);
  const Eigen::Vector3d& h = half_extents;
  const double diagonal = 2.0 * h.norm();
  const double tol = kInsideTolerance * diagonal;
  if (!(radius >= 0.0) || !std::isfinite(radius))
    throw Error("radius = " + shortest_text(radius) +
                ": must be >= 0 and finite (0 = global, > 0 = radius of influence, object units)");
  if (points.empty())
    throw Error(
        "points: none given: a control-point deformer needs at least one source/target "
        "pair");
  if (points.size() > static_cast<size_t>(kMaxControlPoints))
    throw Error("points: " + std::to_string(points.size()) + " pairs: at most " +
                std::to_string(kMaxControlPoints) + " are allowed");
  const size_t n = points.size();

  // Each pair on its own.
  for (size_t i = 0; i < n; ++i) {
    ControlPoint& cp = points[i];
    if (!cp.source.allFinite())
      throw Error(point_name(i) + ".source = " + vector_text(cp.source) +
                  ": coordinates must be finite");
    if (!cp.target.allFinite())
      throw Error(point_name(i) + ".target = " + vector_text(cp.target) +
                  ": coordinates must be finite");
    if (((cp.source.cwiseAbs() - h).array() > tol).any())
      throw Error(point_name(i) + ".source = " + vector_text(cp.source) +
                  ": must lie in the box [" + vector_text(-h) + ", " + vector_text(h) +
                  "] (box frame; targets may leave it)");
    cp.source = cp.source.cwiseMax(-h).cwiseMin(h);  // within tol: onto the face
    for (int f = 0; f < 6; ++f) {
      const int a = f / 2;
      const double face = (f % 2 ? 1.0 : -1.0) * h[a];
      if (pinned[f] && std::abs(cp.source[a] - face) <= tol) {
        const double moved = (cp.target - cp.source).norm();
        if (moved > tol)
          throw Error(point_name(i) + " lies on pinned face " + face_name(face_of(f)) +
                      " (source " + vector_text(cp.source) + ") but its target " +
                      vector_text(cp.target) + " differs from it by " + shortest_text(moved) +
                      ": a point cannot be both pinned and moved");
        cp.source[a] = face;
        cp.target = cp.source;
      }
    }
  }
  // Pairs of sources.
  size_t close_a = 0, close_b = 0;
  double closest = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j) {
      const double d = (points[i].source - points[j].source).norm();
      if (d < closest) closest = d, close_a = i, close_b = j;
    }
  if (closest < kCoincident * diagonal)
    throw Error(point_name(close_a) + " and " + point_name(close_b) + " have coincident sources (" +
                shortest_text(closest) + " apart, closer than 1e-6 of the box diagonal " +
                shortest_text(diagonal) + "): merge them or move them apart");

  std::vector<std::string> notes;
  // Targets outside the box.
  {
    std::vector<size_t> outside;
    for (size_t i = 0; i < n; ++i)
      if (((points[i].target.cwiseAbs() - h).array() > tol).any()) outside.push_back(i);
    if (!outside.empty()) {
      std::string list;
      for (size_t k = 0; k < outside.size() && k < 5; ++k)
        list += (k ? ", " : "") + point_name(outside[k]);
      if (outside.size() > 5) list += ", ...";
      notes.push_back(std::to_string(outside.size()) + " of the " + std::to_string(n) +
                      " targets lie outside the box (" + list +
                      "): the deformed part leaves the box there (rays are cast over the deformed "
                      "bounds, so it still shows)");
    }
  }
  // Sources that move by more than their distance to a pinned face.
  {
    int reported = 0, more = 0;
    for (size_t i = 0; i < n; ++i) {
      const double moved = (points[i].target - points[i].source).norm();
      if (moved == 0.0) continue;
      for (int f = 0; f < 6; ++f) {
        if (!pinned[f]) continue;
        const int a = f / 2;
        const double distance = h[a] - (f % 2 ? 1.0 : -1.0) * points[i].source[a];
        if (moved > distance) {
          if (reported < 5)
            notes.push_back(point_name(i) + " moves by " + shortest_text(moved) + " but lies " +
                            shortest_text(distance) + " from pinned face " + face_name(face_of(f)) +
                            ": the deformation must stretch steeply or fold between them");
          else
            ++more;
          ++reported;
          break;
        }
      }
    }
    if (more > 0)
      notes.push_back("and " + std::to_string(more) +
                      " more points move by more than their distance to a pinned face");
  }

  // The interpolation: v(s_i) = d_i / m(s_i) over the sources off the pinned faces.
  std::vector<size_t> active;
  std::vector<double> mask;
  bool identity = true;
  for (size_t i = 0; i < n; ++i) {
    if (points[i].target != points[i].source) identity = false;
    const double m = pin_mask(h, pinned, points[i].source);
    if (m > 0.0) {
      active.push_back(i);
      mask.push_back(m);
    }
  }
  const Eigen::Index na = static_cast<Eigen::Index>(active.size());
  ControlPoints::Kernel kernel;
  Eigen::Vector3d c0 = Eigen::Vector3d::Zero(), mu = Eigen::Vector3d::Zero();
  Eigen::Matrix3d linear = Eigen::Matrix3d::Zero();
  double rcond = 1.0;
  if (na > 0) {
    Eigen::MatrixXd S(na, 3), values(na, 3);
    for (Eigen::Index k = 0; k < na; ++k) {
      S.row(k) = points[active[k]].source.transpose();
      values.row(k) = ((points[active[k]].target - points[active[k]].source) / mask[k]).transpose();
    }
    // The kernel matrix A_ij = phi(|s_i - s_j|), written into the top left of `out`.
    auto fill_kernel = [&](Eigen::MatrixXd& out) {
      for (Eigen::Index i = 0; i < na; ++i)
        for (Eigen::Index j = 0; j < na; ++j) {
          const double r = (S.row(i) - S.row(j)).norm();
          if (radius == 0.0) {
            const double x = r / diagonal;
            out(i, j) = x * x * x;
          } else {
            const double rho = std::min(r / radius, 1.0), t = 1.0 - rho;
            out(i, j) = t * t * t * t * (4.0 * rho + 1.0);
          }
        }
    };

    Eigen::MatrixXd weights;  // na x 3
    double residual = 0.0;
    const double rhs_size = std::max(values.cwiseAbs().maxCoeff(), 1e-300);
    if (radius == 0.0) {
      // Polynomial directions: principal axes of the sources with an RMS spread >= 1e-3 L.
      mu = S.colwise().mean().transpose();
      const Eigen::MatrixXd Y = (S.rowwise() - mu.transpose()) / diagonal;
      Eigen::JacobiSVD<Eigen::MatrixXd> svd(Y, Eigen::ComputeThinV);
      std::vector<int> directions;
      for (int k = 0; k < 3 && k < na; ++k)
        if (svd.singularValues()[k] / std::sqrt(static_cast<double>(na)) >= kAffineSpread)
          directions.push_back(k);
      const Eigen::Index np = 1 + static_cast<Eigen::Index>(directions.size());
      Eigen::MatrixXd E(3, np - 1);
      for (Eigen::Index k = 0; k + 1 < np; ++k) E.col(k) = svd.matrixV().col(directions[k]);
      Eigen::MatrixXd P(na, np);
      P.col(0).setOnes();
      if (np > 1) P.rightCols(np - 1) = Y * E;
      Eigen::MatrixXd M = Eigen::MatrixXd::Zero(na + np, na + np);
      fill_kernel(M);
      M.topRightCorner(na, np) = P;
      M.bottomLeftCorner(np, na) = P.transpose();
      Eigen::MatrixXd b = Eigen::MatrixXd::Zero(na + np, 3);
      b.topRows(na) = values;
      const Eigen::PartialPivLU<Eigen::MatrixXd> lu(M);
      rcond = lu.rcond();
      Eigen::MatrixXd x = lu.solve(b);
      x += lu.solve(b - M * x);  // one step of iterative refinement
      residual = (M * x - b).cwiseAbs().maxCoeff() / rhs_size;
      if (!(rcond >= kMinRcond) || !x.allFinite() || !(residual <= kSolveResidual))
        throw_ill_conditioned(rcond, residual, close_a, close_b, closest, diagonal);
      weights = x.topRows(na);
      c0 = x.row(na).transpose();
      // v's affine part c0 + C E^T (q - mu) / L, C = x's last np - 1 rows transposed.
      if (np > 1) linear = x.bottomRows(np - 1).transpose() * E.transpose() / diagonal;
    } else {
      Eigen::MatrixXd K(na, na);
      fill_kernel(K);
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(K);
      rcond = ldlt.info() == Eigen::Success ? ldlt.rcond() : 0.0;
      Eigen::MatrixXd x = ldlt.solve(values);
      x += ldlt.solve(values - K * x);
      residual = (K * x - values).cwiseAbs().maxCoeff() / rhs_size;
      if (!ldlt.isPositive() || !(rcond >= kMinRcond) || !x.allFinite() ||
          !(residual <= kSolveResidual))
        throw_ill_conditioned(rcond, residual, close_a, close_b, closest, diagonal);
      weights = x;
    }
    if (rcond < kPoorRcond)
      notes.push_back("the interpolation system is poorly conditioned (reciprocal condition " +
                      shortest_text(rcond) + "): the closest sources, " + point_name(close_a) +
                      " and " + point_name(close_b) + ", are " + shortest_text(closest) +
                      " apart; the field may swing between them");
    kernel = make_kernel(S, weights, h);
  }
  auto deformer = std::make_unique<ControlPoints>(h, n, radius, pinned, identity, std::move(kernel),
                                                  c0, mu, linear);
  // Folds: det(dF/dp) on a lattice that includes the faces, edges and corners, where a field too
  // twisted for its sources folds first (measure_folds samples cell centres only).
  if (warnings && !identity) {
    constexpr int kSamples = 17;
    long folded = 0;
    Eigen::Vector3d first = Eigen::Vector3d::Zero();
    for (int k = 0; k < kSamples; ++k)
      for (int j = 0; j < kSamples; ++j)
        for (int i = 0; i < kSamples; ++i) {
          const Eigen::Vector3d p = h.cwiseProduct(
              Eigen::Vector3d(i, j, k) * (2.0 / (kSamples - 1)) - Eigen::Vector3d::Ones());
          if (!(deformer->jacobian(p).determinant() > 0.0) && folded++ == 0) first = p;
        }
    if (folded > 0)
      notes.push_back("the deformation folds space: det(dF/dp) <= 0 at " + std::to_string(folded) +
                      " of the " + std::to_string(kSamples * kSamples * kSamples) +
                      " points of a " + std::to_string(kSamples) +
                      "^3 lattice over the box, faces included (the first at " +
                      vector_text(first) +
                      "); there points have several preimages or none, and the render may show "
                      "holes or stray surface: add sources or move the targets less");
  }
  if (warnings) warnings->insert(warnings->end(), notes.begin(), notes.end());
  return deformer;
}

}  // namespace raywarp
