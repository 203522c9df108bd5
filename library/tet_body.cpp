#include "library/tet_body.h"

#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <cmath>

#include "base/error.h"
#include "base/parallel.h"
#include "library/triangle_bvh.h"

namespace raywarp {

int choose_tet_refine(const SimulationBody& body, double voxel) {
  const double cell = body.spacing.maxCoeff();
  int k = 1;
  if (voxel > 0.0 && std::isfinite(voxel))
    k = static_cast<int>(std::ceil(cell / (kTetAutoCellVoxels * voxel) - 1e-9));
  k = std::clamp(k, 1, 8);
  while (k > 1 && refined_tet_count(body, k) > kMaxRenderTets) --k;
  return k;
}

TetBody build_tet_body(const BakedBox& box, const Mesh& mesh, const TetDisplaySpec& spec,
                       Interrupter* interrupter) {
  const auto started = std::chrono::steady_clock::now();
  if (!box.report.simulation || !box.report.simulation->lattice || !box.deformer)
    throw Error("render.route \"tets\": the box has no simulated body");
  const SimulationBody& lattice = *box.report.simulation->lattice;
  const Box& frame = box.textures.box;
  TetBody out;
  out.refine = spec.refine == kAutoResolution
                   ? choose_tet_refine(lattice, implicit_spacing(box.textures))
                   : spec.refine;
  SimulationBody fine = refine_body(lattice, out.refine, kMaxRenderTets);
  out.tets = std::move(fine.tets);
  out.rest = std::move(fine.rest);
  const size_t n = out.rest.size();
  out.positions.resize(n);
  out.f.resize(n);
  const bool strain = spec.mode == "volume" && spec.scalar == "strain";
  if (strain) out.strain.resize(n);

  // f: exact within two refined cell diagonals; beyond, only its sign matters (a tetrahedron
  // whose f changes sign has all its nodes within one diagonal of the surface).
  const double bound = 2.0 * fine.spacing.norm();
  const TriangleBvh bvh(mesh);
  const Deformer& F = *box.deformer;
  constexpr long kChunk = 256;
  const long chunks = (static_cast<long>(n) + kChunk - 1) / kChunk;
  parallel_for(
      chunks,
      [&](long c) {
        const size_t end = std::min(n, static_cast<size_t>((c + 1) * kChunk));
        for (size_t i = static_cast<size_t>(c * kChunk); i < end; ++i) {
          const Eigen::Vector3d& q = out.rest[i];
          out.positions[i] = frame.to_object(F.forward(q));
          const double d = bvh.nearest_distance(frame.to_object(q), bound);
          out.f[i] = implicit_value(box.textures, q) > 0.0 ? d : -d;
          if (strain) {
            const Eigen::JacobiSVD<Eigen::Matrix3d> svd(F.jacobian(q));
            const Eigen::Vector3d s = svd.singularValues();
            out.strain[i] = (s.array() - 1.0).abs().maxCoeff();
          }
        }
      },
      interrupter, "tetrahedra");
  for (const auto& t : out.tets)
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b)
        out.longest_edge = std::max(out.longest_edge,
                                    (out.positions[static_cast<size_t>(t[static_cast<size_t>(a)])] -
                                     out.positions[static_cast<size_t>(t[static_cast<size_t>(b)])])
                                        .norm());
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return out;
}

const std::vector<double>& shown_scalar(const TetBody& body, const TetDisplaySpec& spec) {
  if (spec.mode == "volume" && spec.scalar == "strain") return body.strain;
  return body.f;
}

TransferFunction default_transfer_function(const std::vector<double>& values,
                                           const std::string& scalar, double diagonal) {
  // hi: the 95th percentile of the finite values, so that a few extreme nodes (a dragged
  // corner's strain) do not wash the ramp out over the rest of the body.
  std::vector<double> finite;
  for (double v : values)
    if (std::isfinite(v)) finite.push_back(v);
  double hi = 0.0;
  if (!finite.empty()) {
    const size_t at = std::min(finite.size() - 1, static_cast<size_t>(0.95 * finite.size()));
    std::nth_element(finite.begin(), finite.begin() + static_cast<long>(at), finite.end());
    hi = finite[at];
  }
  if (!(hi > 1e-9)) hi = 1e-9;
  const double d = diagonal > 0.0 && std::isfinite(diagonal) ? diagonal : 1.0;
  TransferFunction tf;
  const Eigen::Vector3d blue(0.15, 0.3, 0.9), green(0.2, 0.8, 0.3), red(0.9, 0.2, 0.1);
  tf.points.push_back({0.0, blue, scalar == "strain" ? 0.5 / d : 0.0});
  tf.points.push_back({0.5 * hi, green, 2.0 / d});
  tf.points.push_back({hi, red, 8.0 / d});
  for (TransferPoint& p : tf.points) p.tau = std::min(p.tau, 1e6);
  return tf;
}

PreintegrationSizes tet_table_sizes(const TetBody& body, const TetDisplaySpec& spec,
                                    const TransferFunction& tf) {
  PreintegrationSizes sizes;
  sizes.scalar_samples = spec.scalar_samples;
  sizes.length_samples = spec.length_samples;
  sizes.s_min = tf.s_min();
  sizes.s_max = tf.points.size() > 1 ? tf.s_max() : tf.s_min() + 1.0;
  sizes.max_length = body.longest_edge > 0.0 ? body.longest_edge : 1.0;
  return sizes;
}

}  // namespace raywarp
