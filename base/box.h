// A deformation box: centre, half extents and a rotation, in object space (docs/conventions.md).
// Its local frame has the origin at the box centre and axes along the box edges (the columns
// of `rotation`), in object units; every deformer and texture of the box lives in that frame,
// where the box is [-half_extents, +half_extents].
#pragma once
#include <Eigen/Geometry>

namespace raywarp {

// A half-space n . p <= offset (n unit), in some box's local frame.
struct HalfSpace {
  Eigen::Vector3d normal;
  double offset = 0.0;
};

struct Box {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d half_extents = Eigen::Vector3d::Ones();
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // local -> object, orthonormal

  Eigen::Vector3d to_local(const Eigen::Vector3d& p) const {
    return rotation.transpose() * (p - centre);
  }
  Eigen::Vector3d to_object(const Eigen::Vector3d& q) const { return centre + rotation * q; }
  Eigen::Vector3d direction_to_local(const Eigen::Vector3d& v) const {
    return rotation.transpose() * v;
  }
  Eigen::Vector3d direction_to_object(const Eigen::Vector3d& v) const { return rotation * v; }
  bool contains_local(const Eigen::Vector3d& q) const {
    return (q.cwiseAbs().array() <= half_extents.array()).all();
  }
  bool contains(const Eigen::Vector3d& p) const { return contains_local(to_local(p)); }
  Eigen::Vector3d lower() const { return -half_extents; }  // local frame
  Eigen::Vector3d upper() const { return half_extents; }   // local frame
  double diagonal() const { return 2.0 * half_extents.norm(); }
  // 4x4 local -> object transform.
  Eigen::Matrix4d local_to_object() const {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = rotation;
    m.topRightCorner<3, 1>() = centre;
    return m;
  }
};

}  // namespace raywarp
