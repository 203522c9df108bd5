// The box handles' geometry (editor/handles.h): a point's window pixel and the ray back through
// it agree, dragging a face moves that face alone by the mouse's motion along its normal, the
// centre follows the mouse in the plane facing the camera, a ring turns the box about its axis
// by the angle swept on screen, and rotation_deg written back reads as the same rotation.
#include "editor/handles.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "library/scene.h"

namespace raywarp::editor {
namespace {

ViewMapping front_view() {
  ViewMapping v;
  v.camera.eye = Eigen::Vector3d(0.3, 0.8, 9.0);
  v.camera.target = Eigen::Vector3d(0.1, 0.2, 0.0);
  v.camera.fov_y_deg = 35.0;
  v.camera.near_plane = 0.5;
  v.camera.far_plane = 50.0;
  v.x = 360;
  v.y = 0;
  v.width = 900;
  v.height = 700;
  return v;
}

Box sample_box() {
  Box b;
  b.centre = Eigen::Vector3d(0.2, 0.5, -0.3);
  b.half_extents = Eigen::Vector3d(1.5, 1.0, 0.8);
  b.rotation = (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  return b;
}

double distance_to_ray(const Eigen::Vector3d& p, const Ray& r) {
  return (p - r.origin - (p - r.origin).dot(r.direction) * r.direction).norm();
}

TEST(Handles, APointsPixelAndItsRayAgree) {
  for (const bool ortho : {false, true}) {
    ViewMapping v = front_view();
    if (ortho) {
      v.camera.projection = Camera::Projection::Orthographic;
      v.camera.ortho_height = 6.0;
    }
    for (const Eigen::Vector3d& p : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1.2, -0.7, 2.0),
                                     Eigen::Vector3d(-2.0, 1.5, -3.0)}) {
      const auto pixel = v.project(p);
      ASSERT_TRUE(pixel.has_value());
      EXPECT_LT(distance_to_ray(p, v.ray(*pixel)), 1e-9);
    }
  }
  // Behind the eye: no pixel.
  EXPECT_FALSE(front_view().project(Eigen::Vector3d(0, 0, 12)).has_value());
}

TEST(Handles, DraggingAFaceMovesThatFaceAloneAlongItsNormal) {
  const ViewMapping v = front_view();
  const Box start = sample_box();
  for (int axis = 0; axis < 3; ++axis)
    for (const int side : {1, -1}) {
      const Handle face{Handle::Kind::Face, axis, side};
      const Eigen::Vector3d n = start.rotation.col(axis) * double(side);
      Eigen::Vector3d q = Eigen::Vector3d::Zero();
      q[axis] = side * start.half_extents[axis];
      const Eigen::Vector3d f = start.to_object(q);
      const auto from = v.project(f), to = v.project(f + 0.4 * n);
      ASSERT_TRUE(from && to);
      if ((*to - *from).norm() < 5.0) continue;  // the normal points at the eye: no grip
      const Box b = drag_handle(start, face, v, *from, *to, 0.01);
      EXPECT_NEAR(b.half_extents[axis], start.half_extents[axis] + 0.2, 1e-6) << face.name();
      // The opposite face stays.
      const Eigen::Vector3d opposite_before = start.centre - n * start.half_extents[axis];
      const Eigen::Vector3d opposite_after = b.centre - n * b.half_extents[axis];
      EXPECT_LT((opposite_after - opposite_before).norm(), 1e-6) << face.name();
      EXPECT_TRUE(b.rotation.isApprox(start.rotation));
      // A face cannot pass the opposite one.
      const auto past = v.project(f - 5.0 * n);
      ASSERT_TRUE(past.has_value());
      EXPECT_NEAR(drag_handle(start, face, v, *from, *past, 0.01).half_extents[axis], 0.01, 1e-12);
    }
}

TEST(Handles, TheCentreFollowsTheMouseInThePlaneFacingTheCamera) {
  const ViewMapping v = front_view();
  const Box start = sample_box();
  const Eigen::Vector3d f = v.camera.view_direction();
  const Eigen::Vector3d along =
      f.cross(v.camera.up).normalized() * 0.7 + f.cross(v.camera.up).cross(f).normalized() * -0.4;
  const auto from = v.project(start.centre), to = v.project(start.centre + along);
  ASSERT_TRUE(from && to);
  const Box b = drag_handle(start, Handle{Handle::Kind::Centre}, v, *from, *to, 0.01);
  EXPECT_LT((b.centre - (start.centre + along)).norm(), 1e-6);
  EXPECT_TRUE(b.half_extents.isApprox(start.half_extents));
}

TEST(Handles, ARingTurnsTheBoxAboutItsAxisByTheAngleSweptOnScreen) {
  ViewMapping v = front_view();
  v.camera.eye = Eigen::Vector3d(0, 0, 9);
  v.camera.target = Eigen::Vector3d(0, 0, 0);
  Box start;  // axis-aligned: its z axis points at the eye
  start.half_extents = Eigen::Vector3d(1.0, 0.5, 0.5);
  const auto c = v.project(start.centre);
  ASSERT_TRUE(c.has_value());
  // A quarter turn counter-clockwise on screen (y down): from the right to the top.
  const Eigen::Vector2d from = *c + Eigen::Vector2d(100, 0), to = *c + Eigen::Vector2d(0, -100);
  const Box b = drag_handle(start, Handle{Handle::Kind::Ring, 2}, v, from, to, 0.01);
  const Eigen::Matrix3d expected =
      Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_TRUE(b.rotation.isApprox(expected, 1e-9)) << b.rotation;
  EXPECT_TRUE(b.centre.isApprox(start.centre));
  // Seen from behind, the same sweep turns it the other way.
  ViewMapping behind = v;
  behind.camera.eye = Eigen::Vector3d(0, 0, -9);
  const auto cb = behind.project(start.centre);
  const Box back = drag_handle(start, Handle{Handle::Kind::Ring, 2}, behind,
                               *cb + Eigen::Vector2d(100, 0), *cb + Eigen::Vector2d(0, -100), 0.01);
  EXPECT_TRUE(back.rotation.isApprox(expected.transpose(), 1e-9)) << back.rotation;
}

TEST(Handles, PickingFindsTheDotOrTheRingUnderTheMouseAndNothingElsewhere) {
  const ViewMapping v = front_view();
  const Box box = sample_box();
  for (const PlacedHandle& h : place_handles(box, v)) {
    const auto picked = pick_handle(box, v, h.pixel + Eigen::Vector2d(2, -2));
    ASSERT_TRUE(picked.has_value()) << h.handle.name();
    if (h.handle.kind != Handle::Kind::Ring) {
      EXPECT_EQ(picked->name(), h.handle.name());
    }
  }
  EXPECT_FALSE(pick_handle(box, v, Eigen::Vector2d(365, 5)).has_value());
  EXPECT_EQ(place_handles(box, v).size(), 10u);  // centre, six faces, three rings
}

TEST(Handles, RotationDegWrittenBackReadsAsTheSameRotation) {
  const Eigen::Matrix3d r =
      sample_box().rotation * Eigen::AngleAxisd(2.5, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d deg = euler_deg_of(r);
  const nlohmann::json scene = {
      {"mesh", (std::filesystem::path(RAYWARP_SOURCE_DIR) / "examples/meshes/bunny.ply").string()},
      {"boxes",
       {{{"centre", {0, 0, 0}},
         {"half_extents", {1, 1, 1}},
         {"rotation_deg", {deg.x(), deg.y(), deg.z()}},
         {"deformer", {{"type", "twist"}, {"axis", "y"}, {"angle_deg", 30}}}}}}};
  const Scene s = load_scene_json(scene, "scene.json");
  EXPECT_TRUE(s.boxes[0].box.rotation.isApprox(r, 1e-12)) << s.boxes[0].box.rotation << "\n" << r;
}

}  // namespace
}  // namespace raywarp::editor
