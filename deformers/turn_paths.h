// Paths along which pairs that turn far reach their targets (internal to the from_mesh fit,
// docs/from_mesh.md "Full turns").
//
// A smooth displacement field averages rotations, and the average of a full turn is a collapse:
// fitted in one go, a twist of 360 degrees folds the box. turn_paths finds the line the pairs
// turn about and how far each turns about it and, past a threshold, poses of the pairs between
// sources and targets that turn a step at a time, so that the fit can be made of small steps
// that each fit without folds:
//
//  1. The line: its direction the one the displacements least go along (the least eigenvector of
//     the sum of d d^T), its place the point c across it that keeps the pairs' distances from it
//     best (least squares on |T - c|^2 = |S - c|^2, S and T a pair's source and target across
//     the direction). A twist turns about its axis; a bend about a line near its centre.
//  2. Each pair's turn about the line, in (-pi, pi], unwrapped: the pairs are thinned to one per
//     cube of side `cell` (fewer if they still number more than kTurnPathPairs) and joined to
//     their kTurnNeighbours nearest (by source); starting from the pairs next to the pinned face
//     with the most pairs next to it (held at rest, so unturned), or else from the pair turned
//     least, each takes the whole number of turns that brings it nearest to an unwrapped
//     neighbour's, neighbours in order of agreement (Prim's order on the difference). A twist of
//     360 degrees is then 2 pi at its free end, not 0.
//  3. Steps: ceil(largest turn / step_angle), the largest over the pairs farther than
//     kNearLine of the box diagonal from the line (nearer, the angle means little). The pose at
//     tau = k / steps: about the line, the turn and the distance from it a fraction tau of the
//     way; along it, the move a fraction tau of the way. A twist's poses are the partial twists.
//  4. Points that must end where they start (the pinned faces' lattice samples) follow the same
//     rule with a turn of whole turns: on each pinned face, the median of its nearby pairs'
//     turns rounded to whole turns (a 360-degree twist's far end turns once and comes back).
#pragma once
#include <Eigen/Core>
#include <array>
#include <vector>

#include "base/interrupt.h"

namespace raywarp {

constexpr long kTurnPathPairs = 40000;  // at most this many pairs follow paths
constexpr int kTurnNeighbours = 8;
constexpr double kNearLine = 0.05;  // of the box diagonal: pairs this near the line

struct TurnPaths {
  double largest_angle = 0;  // radians, unwrapped: the largest turn of a pair about the line
  int steps = 1;             // 1: no paths (the turn is below the threshold)
  int start_face = -1;       // the pinned face taken as unturned (-1: none)
  Eigen::Vector3d axis = Eigen::Vector3d::UnitY();   // the line the pairs turn about: direction
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // and the point of it nearest the origin
  std::vector<long> kept;  // the pairs that follow paths (indices into the sources)
  // poses[k][i], k = 0 .. steps: pair kept[i] at tau = k / steps (poses[0]: its source,
  // poses[steps]: its target), then the fixed points. Empty when steps is 1.
  std::vector<std::vector<Eigen::Vector3d>> poses;
};

// sources, targets: the pairs, box frame (box [-h, h]); fixed: points on the pinned faces that
// end where they start; pinned: the faces held at rest, in the order -x, +x, -y, +y, -z, +z;
// cell: the side of the thinning cubes; step_angle: the largest turn of a step (radians);
// threshold: up to this largest turn no paths are made.
TurnPaths turn_paths(const std::vector<Eigen::Vector3d>& sources,
                     const std::vector<Eigen::Vector3d>& targets,
                     const std::vector<Eigen::Vector3d>& fixed, const Eigen::Vector3d& h,
                     const std::array<bool, 6>& pinned, double cell, double step_angle,
                     double threshold, Interrupter* interrupter);

}  // namespace raywarp
