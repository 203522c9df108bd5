#include "library/camera.h"

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "base/error.h"
#include "base/json_reader.h"

namespace raywarp {

namespace {

// Sizes in pixels beyond which an image is refused (the memory budget of one frame).
constexpr int kMaxImageSide = 8192;

Eigen::Vector3d read_vec3(const nlohmann::json& j, const std::string& where, const char* key) {
  const auto& v = j.at(key);
  if (!v.is_array() || v.size() != 3)
    throw Error(where + "." + key + " = " + v.dump() + ": must be an array of 3 numbers");
  Eigen::Vector3d out;
  for (int i = 0; i < 3; ++i) {
    if (!v[i].is_number() || !std::isfinite(v[i].get<double>()))
      throw Error(where + "." + key + "[" + std::to_string(i) + "] = " + v[i].dump() +
                  ": must be a finite number");
    out[i] = v[i].get<double>();
  }
  return out;
}

double read_number(const nlohmann::json& j, const std::string& where, const char* key, double lo,
                   double hi, bool lo_open, bool hi_open) {
  const auto& v = j.at(key);
  double x = v.is_number() ? v.get<double>() : NAN;
  bool ok = std::isfinite(x) && (lo_open ? x > lo : x >= lo) && (hi_open ? x < hi : x <= hi);
  if (!ok) {
    std::string range = std::string(lo_open ? "(" : "[") + nlohmann::json(lo).dump() + ", " +
                        nlohmann::json(hi).dump() + (hi_open ? ")" : "]");
    throw Error(where + "." + key + " = " + v.dump() + ": must be a number in " + range);
  }
  return x;
}

}  // namespace

Eigen::Matrix4d Camera::view() const {
  // gluLookAt
  Eigen::Vector3d f = (target - eye).normalized();
  Eigen::Vector3d s = f.cross(up).normalized();
  Eigen::Vector3d u = s.cross(f);
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.row(0).head<3>() = s;
  m.row(1).head<3>() = u;
  m.row(2).head<3>() = -f;
  m(0, 3) = -s.dot(eye);
  m(1, 3) = -u.dot(eye);
  m(2, 3) = f.dot(eye);
  return m;
}

Eigen::Matrix4d Camera::projection_matrix(double aspect) const {
  Eigen::Matrix4d p = Eigen::Matrix4d::Zero();
  double n = near_plane, f = far_plane;
  if (projection == Projection::Perspective) {
    // gluPerspective
    double c = 1.0 / std::tan(0.5 * fov_y_deg * M_PI / 180.0);
    p(0, 0) = c / aspect;
    p(1, 1) = c;
    p(2, 2) = (f + n) / (n - f);
    p(2, 3) = 2.0 * f * n / (n - f);
    p(3, 2) = -1.0;
  } else {
    // glOrtho(-h*aspect/2, h*aspect/2, -h/2, h/2, n, f)
    double t = 0.5 * ortho_height, r = t * aspect;
    p(0, 0) = 1.0 / r;
    p(1, 1) = 1.0 / t;
    p(2, 2) = -2.0 / (f - n);
    p(2, 3) = -(f + n) / (f - n);
    p(3, 3) = 1.0;
  }
  return p;
}

Ray Camera::pixel_ray(int x, int y, int W, int H) const { return ray_at(x + 0.5, y + 0.5, W, H); }

Ray Camera::ray_at(double x, double y, int W, int H) const {
  // The point in normalised device coordinates; row 0 is the top of the image.
  double ndc_x = x / W * 2.0 - 1.0;
  double ndc_y = 1.0 - y / H * 2.0;
  double aspect = static_cast<double>(W) / H;
  Eigen::Vector3d f = view_direction();
  Eigen::Vector3d s = f.cross(up).normalized();
  Eigen::Vector3d u = s.cross(f);
  Ray ray;
  if (projection == Projection::Perspective) {
    double th = std::tan(0.5 * fov_y_deg * M_PI / 180.0);
    Eigen::Vector3d d = f + s * (ndc_x * th * aspect) + u * (ndc_y * th);
    double len = d.norm();
    ray.origin = eye;
    ray.direction = d / len;
    // Eye depth along the ray grows by 1/len per unit t.
    ray.t_min = near_plane * len;
    ray.t_max = far_plane * len;
  } else {
    double h = 0.5 * ortho_height;
    ray.origin = eye + s * (ndc_x * h * aspect) + u * (ndc_y * h);
    ray.direction = f;
    ray.t_min = near_plane;
    ray.t_max = far_plane;
  }
  return ray;
}

Camera camera_from_json(const nlohmann::json& j, const std::string& where) {
  if (!j.is_object()) throw Error(where + " = " + j.dump() + ": must be a JSON object");
  static const char* known[] = {"projection",   "eye",   "target", "up",   "fov_y_deg",
                                "ortho_height", "width", "height", "near", "far"};
  for (const auto& [key, value] : j.items()) {
    bool ok = false;
    for (const char* k : known) ok = ok || key == k;
    if (!ok)
      throw Error(where + "." + key +
                  ": unknown field; allowed: projection, eye, target, up, "
                  "fov_y_deg, ortho_height, width, height, near, far");
  }
  Camera c;
  if (j.contains("projection")) {
    const auto& p = j["projection"];
    if (p == "perspective")
      c.projection = Camera::Projection::Perspective;
    else if (p == "orthographic")
      c.projection = Camera::Projection::Orthographic;
    else
      throw Error(where + ".projection = " + p.dump() +
                  ": must be \"perspective\" or \"orthographic\"");
  }
  for (const char* key : {"eye", "target"})
    if (!j.contains(key)) throw Error(where + "." + key + ": missing; give a point [x, y, z]");
  c.eye = read_vec3(j, where, "eye");
  c.target = read_vec3(j, where, "target");
  if (j.contains("up")) c.up = read_vec3(j, where, "up");
  if ((c.target - c.eye).norm() <= 1e-12 * (1.0 + c.eye.norm()))
    throw Error(where + ".target: equals eye " + j["eye"].dump() + "; they must differ");
  if (c.up.norm() == 0.0 || c.up.normalized().cross(c.view_direction()).norm() < 1e-6)
    throw Error(where + ".up = " +
                nlohmann::json(std::vector<double>{c.up.x(), c.up.y(), c.up.z()}).dump() +
                ": must be non-zero and not parallel to target - eye");
  if (j.contains("fov_y_deg")) c.fov_y_deg = read_number(j, where, "fov_y_deg", 0, 180, true, true);
  if (j.contains("ortho_height"))
    c.ortho_height = read_number(j, where, "ortho_height", 0, 1e30, true, false);
  for (const char* key : {"width", "height"}) {
    if (!j.contains(key)) continue;
    const auto& v = j[key];
    if (!v.is_number_integer() || v.get<long>() < 1 || v.get<long>() > kMaxImageSide)
      throw Error(where + "." + key + " = " + v.dump() + ": must be an integer in [1, " +
                  std::to_string(kMaxImageSide) + "]");
    (std::string(key) == "width" ? c.width : c.height) = v.get<int>();
  }
  if (j.contains("near")) c.near_plane = read_number(j, where, "near", 0, 1e30, true, false);
  if (j.contains("far")) c.far_plane = read_number(j, where, "far", 0, 1e30, true, false);
  if (!(c.far_plane > c.near_plane))
    throw Error(where + ".far = " + nlohmann::json(c.far_plane).dump() +
                ": must be greater than near (" + nlohmann::json(c.near_plane).dump() + ")");
  return c;
}

Camera load_camera(const std::string& path) {
  return camera_from_json(read_json_file(path, "camera file"), path + ": camera");
}

nlohmann::json camera_to_json(const Camera& c) {
  auto v = [](const Eigen::Vector3d& x) { return std::vector<double>{x.x(), x.y(), x.z()}; };
  nlohmann::json j = {
      {"projection",
       c.projection == Camera::Projection::Perspective ? "perspective" : "orthographic"},
      {"eye", v(c.eye)},
      {"target", v(c.target)},
      {"up", v(c.up)},
      {"near", c.near_plane},
      {"far", c.far_plane}};
  if (c.projection == Camera::Projection::Perspective)
    j["fov_y_deg"] = c.fov_y_deg;
  else
    j["ortho_height"] = c.ortho_height;
  if (c.width > 0) j["width"] = c.width;
  if (c.height > 0) j["height"] = c.height;
  return j;
}

}  // namespace raywarp
