#include "deformers/turn_paths.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <queue>
#include <unordered_map>
#include <utility>

#include "base/error.h"
#include "base/parallel.h"

namespace raywarp {

namespace {

constexpr const char* kStage = "from mesh fit";
constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2.0 * kPi;

// Cubes of side `side` over the box, each a key.
struct Cubes {
  Eigen::Vector3d low;
  double side;
  Eigen::Vector3i of(const Eigen::Vector3d& p) const {
    return ((p - low) / side).array().floor().cast<int>().matrix();
  }
  static std::int64_t key(const Eigen::Vector3i& c) {
    constexpr std::int64_t kBias = std::int64_t(1) << 20;
    return (c.x() + kBias) | ((c.y() + kBias) << 21) | ((c.z() + kBias) << 42);
  }
};

// One pair per cube (the first), the cube's side grown until at most kTurnPathPairs remain.
std::vector<long> thin(const std::vector<Eigen::Vector3d>& sources, const Eigen::Vector3d& h,
                       double& cell) {
  for (;;) {
    const Cubes cubes{-h, cell};
    std::unordered_map<std::int64_t, long> first;
    std::vector<long> kept;
    for (size_t i = 0; i < sources.size(); ++i)
      if (first.emplace(Cubes::key(cubes.of(sources[i])), static_cast<long>(i)).second)
        kept.push_back(static_cast<long>(i));
    if (static_cast<long>(kept.size()) <= kTurnPathPairs) return kept;
    cell *= 1.26;
  }
}

// The k nearest of each point (itself excluded): by rings of cubes of side `cell` (at most one
// point per cube after thinning) out to kRings cubes, and for a point with fewer than k within
// that reach, over all the points.
std::vector<std::vector<int>> nearest(const std::vector<Eigen::Vector3d>& points,
                                      const Eigen::Vector3d& h, double cell, int k,
                                      Interrupter* interrupter) {
  constexpr int kRings = 4;
  const Cubes cubes{-h, cell};
  std::unordered_map<std::int64_t, std::vector<int>> buckets;
  for (size_t i = 0; i < points.size(); ++i)
    buckets[Cubes::key(cubes.of(points[i]))].push_back(static_cast<int>(i));
  const int want = std::min(k, static_cast<int>(points.size()) - 1);
  std::vector<std::vector<int>> out(points.size());
  parallel_for(
      static_cast<long>(points.size()),
      [&](long i) {
        std::vector<std::pair<double, int>> best;  // a max-heap on distance
        auto offer = [&](int j) {
          if (j == i) return;
          const double d = (points[j] - points[i]).squaredNorm();
          if (static_cast<int>(best.size()) < want) {
            best.emplace_back(d, j);
            std::push_heap(best.begin(), best.end());
          } else if (d < best.front().first) {
            std::pop_heap(best.begin(), best.end());
            best.back() = {d, j};
            std::push_heap(best.begin(), best.end());
          }
        };
        const Eigen::Vector3i c = cubes.of(points[i]);
        bool found = false;
        for (int r = 0; r <= kRings && !found; ++r) {
          for (int dz = -r; dz <= r; ++dz)
            for (int dy = -r; dy <= r; ++dy)
              for (int dx = -r; dx <= r; ++dx) {
                if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) != r) continue;
                const auto it = buckets.find(Cubes::key(c + Eigen::Vector3i(dx, dy, dz)));
                if (it != buckets.end())
                  for (int j : it->second) offer(j);
              }
          // Points beyond ring r are at least r cubes away.
          found = static_cast<int>(best.size()) == want &&
                  (want == 0 || best.front().first <= (r * cell) * (r * cell));
        }
        if (!found) {
          best.clear();
          for (int j = 0; j < static_cast<int>(points.size()); ++j) offer(j);
        }
        for (const auto& b : best) out[i].push_back(b.second);
      },
      interrupter, kStage);
  return out;
}

// The angle from a to b (2D), in (-pi, pi].
double angle_between(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b));
}

// The angle `turn` taken a whole number of turns towards `near`.
double unwrap(double turn, double near) {
  return turn + kTwoPi * std::round((near - turn) / kTwoPi);
}

}  // namespace

TurnPaths turn_paths(const std::vector<Eigen::Vector3d>& sources,
                     const std::vector<Eigen::Vector3d>& targets,
                     const std::vector<Eigen::Vector3d>& fixed, const Eigen::Vector3d& h,
                     const std::array<bool, 6>& pinned, double cell, double step_angle,
                     double threshold, Interrupter* interrupter) {
  TurnPaths out;
  if (sources.size() < 4) return out;
  out.kept = thin(sources, h, cell);
  const long m = static_cast<long>(out.kept.size());
  if (m < 4) {
    out.kept.clear();
    return out;
  }
  std::vector<Eigen::Vector3d> s(m), t(m);
  for (long i = 0; i < m; ++i) {
    s[i] = sources[out.kept[i]];
    t[i] = targets[out.kept[i]];
  }
  const double diagonal = 2.0 * h.norm();

  // The axis: the direction the displacements least go along.
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (long i = 0; i < m; ++i) scatter += (t[i] - s[i]) * (t[i] - s[i]).transpose();
  if (!(scatter.trace() > 1e-18 * diagonal * diagonal * static_cast<double>(m))) {
    out.kept.clear();
    return out;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> spread(scatter);
  const Eigen::Vector3d axis = spread.eigenvectors().col(0).normalized();
  const Eigen::Vector3d u = axis.unitOrthogonal(), v = axis.cross(u);
  auto across = [&](const Eigen::Vector3d& p) { return Eigen::Vector2d(u.dot(p), v.dot(p)); };
  // Its place: the point c across it that keeps every pair's distance from the line best, by
  // least squares on |T - c|^2 = |S - c|^2, that is 2 (T - S) . c = |T|^2 - |S|^2.
  Eigen::Matrix2d normal = Eigen::Matrix2d::Zero();
  Eigen::Vector2d right = Eigen::Vector2d::Zero();
  for (long i = 0; i < m; ++i) {
    const Eigen::Vector2d S = across(s[i]), T = across(t[i]);
    const Eigen::Vector2d row = 2.0 * (T - S);
    normal += row * row.transpose();
    right += row * (T.squaredNorm() - S.squaredNorm());
  }
  const Eigen::Vector2d centre = normal.ldlt().solve(right);
  if (!centre.allFinite() || centre.norm() > 100.0 * diagonal) {
    out.kept.clear();
    return out;
  }
  out.axis = axis;
  out.centre = centre.x() * u + centre.y() * v;

  // Each pair's turn about the line, in (-pi, pi], and its distance from it.
  std::vector<double> turn(m), radius(m);
  for (long i = 0; i < m; ++i) {
    const Eigen::Vector2d a = across(s[i]) - centre, b = across(t[i]) - centre;
    turn[i] = angle_between(a, b);
    radius[i] = std::min(a.norm(), b.norm());
    if (!std::isfinite(turn[i])) turn[i] = 0.0;
  }

  // Joined to their neighbours, both ways.
  const std::vector<std::vector<int>> near = nearest(s, h, cell, kTurnNeighbours, interrupter);
  std::vector<std::vector<int>> joined(m);
  for (long i = 0; i < m; ++i)
    for (int j : near[i]) {
      joined[i].push_back(j);
      joined[j].push_back(static_cast<int>(i));
    }

  // Unwrapped in Prim's order, from the pairs next to the pinned face with the most pairs next
  // to it (a pinned face may be turned a whole number of times: a twist of 360 degrees holds
  // both its ends, so only one is taken as unturned), or else from the pair turned least.
  std::vector<char> done(m, 0);
  using Entry = std::pair<double, std::pair<int, int>>;  // difference, (pair, from)
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
  auto seed = [&](long i) {
    done[i] = 1;
    for (int j : joined[i])
      if (!done[j])
        queue.push({std::abs(unwrap(turn[j], turn[i]) - turn[i]), {j, static_cast<int>(i)}});
  };
  auto grow = [&] {
    while (!queue.empty()) {
      const auto link = queue.top().second;
      queue.pop();
      if (done[link.first]) continue;
      turn[link.first] = unwrap(turn[link.first], turn[link.second]);
      seed(link.first);
    }
  };
  auto next_to = [&](long i, int f) {
    const int a = f / 2;
    return std::abs(s[i][a] - ((f % 2) ? h[a] : -h[a])) <= 1.5 * cell;
  };
  long most = 0;
  for (int f = 0; f < 6; ++f) {
    if (!pinned[static_cast<size_t>(f)]) continue;
    long count = 0;
    for (long i = 0; i < m; ++i) count += next_to(i, f) ? 1 : 0;
    if (count > most) {
      most = count;
      out.start_face = f;
    }
  }
  if (out.start_face >= 0)
    for (long i = 0; i < m; ++i)
      if (next_to(i, out.start_face) && !done[i]) seed(i);
  grow();
  for (;;) {
    long start = -1;
    for (long i = 0; i < m; ++i)
      if (!done[i] && (start < 0 || std::abs(turn[i]) < std::abs(turn[start]))) start = i;
    if (start < 0) break;
    seed(start);
    grow();
  }
  poll(interrupter, kStage, 0.0);
  // The largest turn, of the pairs not next to the line (there the angle means little).
  for (long i = 0; i < m; ++i)
    if (radius[i] > kNearLine * diagonal)
      out.largest_angle = std::max(out.largest_angle, std::abs(turn[i]));
  if (!(out.largest_angle > threshold)) {
    out.kept.clear();
    return out;
  }
  out.steps = static_cast<int>(std::ceil(out.largest_angle / step_angle));

  // The fixed points (on the pinned faces) turn by whole turns: on each face, the pairs next to
  // it (or else the pair nearest to it) rounded to whole turns, their median.
  std::array<double, 6> whole{};
  for (int f = 0; f < 6; ++f) {
    if (!pinned[static_cast<size_t>(f)]) continue;
    const int a = f / 2;
    const double plane = (f % 2) ? h[a] : -h[a];
    std::vector<double> near_turns;
    long closest = 0;
    for (long i = 0; i < m; ++i) {
      if (next_to(i, f)) near_turns.push_back(std::round(turn[i] / kTwoPi));
      if (std::abs(s[i][a] - plane) < std::abs(s[closest][a] - plane)) closest = i;
    }
    if (near_turns.empty()) near_turns.push_back(std::round(turn[closest] / kTwoPi));
    std::nth_element(near_turns.begin(), near_turns.begin() + near_turns.size() / 2,
                     near_turns.end());
    whole[static_cast<size_t>(f)] = kTwoPi * near_turns[near_turns.size() / 2];
  }
  std::vector<Eigen::Vector3d> all_s = s, all_t = t;
  all_s.insert(all_s.end(), fixed.begin(), fixed.end());
  all_t.insert(all_t.end(), fixed.begin(), fixed.end());
  for (const Eigen::Vector3d& q : fixed) {
    double on = 0.0;
    for (int f = 0; f < 6; ++f) {
      const int a = f / 2;
      if (pinned[static_cast<size_t>(f)] &&
          std::abs(q[a] - ((f % 2) ? h[a] : -h[a])) <= 1e-9 * diagonal) {
        on = whole[static_cast<size_t>(f)];
        break;
      }
    }
    turn.push_back(on);
  }

  // The poses: about the line, the turn and the distance from it a fraction of the way; along
  // it, the move a fraction of the way.
  out.poses.assign(static_cast<size_t>(out.steps) + 1, {});
  for (int k = 0; k <= out.steps; ++k) {
    const double tau = static_cast<double>(k) / out.steps;
    std::vector<Eigen::Vector3d>& pose = out.poses[static_cast<size_t>(k)];
    pose.resize(all_s.size());
    for (size_t i = 0; i < all_s.size(); ++i) {
      if (k == 0 || k == out.steps) {
        pose[i] = k == 0 ? all_s[i] : all_t[i];
        continue;
      }
      const Eigen::Vector2d a = across(all_s[i]) - centre, b = across(all_t[i]) - centre;
      const double ra = a.norm(), rb = b.norm();
      const double start = ra > 0.0 ? std::atan2(a.y(), a.x()) : std::atan2(b.y(), b.x());
      const double angle = start + tau * turn[i];
      const double r = (1.0 - tau) * ra + tau * rb;
      const Eigen::Vector2d q = centre + r * Eigen::Vector2d(std::cos(angle), std::sin(angle));
      pose[i] = q.x() * u + q.y() * v +
                ((1.0 - tau) * axis.dot(all_s[i]) + tau * axis.dot(all_t[i])) * axis;
    }
  }
  return out;
}

}  // namespace raywarp
