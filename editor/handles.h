// The on-screen handles of a deformation box, as geometry: where they lie in the viewport, which
// one the mouse is over, and the box a drag of one makes. No GL and no ImGui here: the window
// draws what these return, and tests check the geometry alone.
//   - a face handle (a dot at the centre of each of the six faces): drag it to move that face
//     along its normal, the opposite face staying where it is;
//   - the centre handle: drag it to move the box in the plane through its centre facing the
//     camera;
//   - a ring per box axis (a circle about the centre, in the plane across that axis): drag it to
//     rotate the box about that axis.
#pragma once
#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "base/box.h"
#include "library/camera.h"

namespace raywarp::editor {

// The viewport: a camera shown in a rectangle of the window (window pixels, y down).
struct ViewMapping {
  Camera camera;
  double x = 0, y = 0, width = 1, height = 1;

  // Window pixel of an object-space point; none behind the eye (perspective) or off the planes.
  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& p) const;
  // The ray through a window pixel.
  Ray ray(const Eigen::Vector2d& pixel) const;
  // Object units per window pixel at point p (its depth), along the screen.
  double units_per_pixel(const Eigen::Vector3d& p) const;
};

struct Handle {
  enum class Kind { Face, Centre, Ring };
  Kind kind = Kind::Centre;
  int axis = 0;  // Face, Ring: the box axis
  int side = 1;  // Face: +1 the upper face, -1 the lower
  // "face+x", "face-y", "centre", "ring.z": the names the status file gives.
  std::string name() const;
  bool operator==(const Handle& o) const {
    return kind == o.kind && axis == o.axis && (kind != Kind::Face || side == o.side);
  }
};

// Every handle of a box with a window pixel to grab it by (the dot, or a point of the ring),
// the handles that are behind the eye left out.
struct PlacedHandle {
  Handle handle;
  Eigen::Vector2d pixel;
};
std::vector<PlacedHandle> place_handles(const Box& box, const ViewMapping& view);

// The ring of `axis` as a closed polyline of window pixels (empty when it is behind the eye).
std::vector<Eigen::Vector2d> ring_polyline(const Box& box, int axis, const ViewMapping& view,
                                           int segments = 64);
// The radius of the ring of `axis`, object units: a little beyond the box's larger half extent
// across that axis.
double ring_radius(const Box& box, int axis);
// The twelve edges of the box, as pairs of object-space corners.
std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> box_edges(const Box& box);

// The handle within `radius_px` of the mouse (dots before rings, nearest first), or none.
std::optional<Handle> pick_handle(const Box& box, const ViewMapping& view,
                                  const Eigen::Vector2d& mouse, double radius_px = 8.0);

// The box that dragging `handle` of `start` from window pixel `from` to `to` makes. Half extents
// stay at least `min_half` (a face cannot pass the opposite one).
Box drag_handle(const Box& start, const Handle& handle, const ViewMapping& view,
                const Eigen::Vector2d& from, const Eigen::Vector2d& to, double min_half);

// Where dragging a point at `start` from window pixel `from` to `to` takes it: it moves in the
// plane through `start` facing the camera.
Eigen::Vector3d drag_point(const Eigen::Vector3d& start, const ViewMapping& view,
                           const Eigen::Vector2d& from, const Eigen::Vector2d& to);

// The point of the surface drawn at window pixel `pixel`, from the viewport's depth image (linear
// eye depth, docs/conventions.md) of the camera `view`: none where the image shows nothing.
std::optional<Eigen::Vector3d> surface_point(const ViewMapping& view,
                                             const std::vector<float>& depth, int width, int height,
                                             const Eigen::Vector2d& pixel);

// The scene's rotation_deg of a rotation (R = Rz * Ry * Rx, degrees), the inverse of the scene
// reader's.
Eigen::Vector3d euler_deg_of(const Eigen::Matrix3d& rotation);

}  // namespace raywarp::editor
