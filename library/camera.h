// Cameras (docs/conventions.md#camera-and-eye-space), so that another renderer can check images:
// view = gluLookAt(eye, target, up); projection = gluPerspective(fov_y_deg, W/H, near, far) or
// glOrtho(-h*W/H/2, h*W/H/2, -h/2, h/2, near, far) with h = ortho_height. Images are stored
// row 0 = top, each pixel sampled once at its centre. Depth is linear eye-space depth along the
// view axis, dot(p - eye, normalize(target - eye)), in mesh units, +inf where nothing is hit.
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <nlohmann/json_fwd.hpp>
#include <string>

namespace raywarp {

struct Ray {
  Eigen::Vector3d origin, direction;  // direction is unit length
  double t_min = 0.0;                 // the near plane along this ray
  double t_max = 0.0;                 // the far plane along this ray
};

struct Camera {
  enum class Projection { Perspective, Orthographic };
  Projection projection = Projection::Perspective;
  Eigen::Vector3d eye{0, 0, 5}, target{0, 0, 0}, up{0, 1, 0};
  double fov_y_deg = 45.0;    // full vertical field of view (perspective)
  double ortho_height = 2.0;  // full vertical extent (orthographic)
  int width = 0, height = 0;  // 0: not given by the camera
  double near_plane = 0.01, far_plane = 1000.0;

  Eigen::Vector3d view_direction() const { return (target - eye).normalized(); }
  Eigen::Matrix4d view() const;
  Eigen::Matrix4d projection_matrix(double aspect) const;
  // The ray through the centre of pixel (x, y) of a W x H image, row 0 at the top.
  Ray pixel_ray(int x, int y, int W, int H) const;
  // The ray through the point (x, y) of a W x H image, in pixels from its top-left corner (a
  // pixel's centre is at (x + 0.5, y + 0.5)).
  Ray ray_at(double x, double y, int W, int H) const;
  double depth_of(const Eigen::Vector3d& p) const { return (p - eye).dot(view_direction()); }
};

// Reads a camera object; `where` prefixes messages ("cam.json" or "scene.json: camera").
// Throws Error naming the field, the value and what is allowed.
Camera camera_from_json(const nlohmann::json& j, const std::string& where);
Camera load_camera(const std::string& path);
nlohmann::json camera_to_json(const Camera& c);

}  // namespace raywarp
