#include "editor/document.h"

#include <algorithm>
#include <cmath>

#include "base/atomic_file.h"
#include "base/error.h"
#include "library/mesh.h"

namespace raywarp::editor {

namespace fs = std::filesystem;

namespace {

bool is_scene_file(const fs::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext == ".json";
}

// NAME.json beside a mesh file NAME.ply (NAME.ply.xz: also NAME.json).
fs::path scene_beside(const fs::path& mesh) {
  fs::path stem = mesh.filename();
  while (stem.has_extension()) stem = stem.stem();
  return mesh.parent_path() / (stem.string() + ".json");
}

}  // namespace

using json = nlohmann::json;

std::optional<std::vector<size_t>> twist_angle_changes(const json& now, const json& was) {
  if (!now.is_object() || !was.is_object()) return std::nullopt;
  json rest_now = now, rest_was = was;
  rest_now.erase("boxes");
  rest_was.erase("boxes");
  if (rest_now != rest_was) return std::nullopt;
  const json &a = now.value("boxes", json::array()), &b = was.value("boxes", json::array());
  if (!a.is_array() || !b.is_array() || a.size() != b.size()) return std::nullopt;
  std::vector<size_t> changed;
  for (size_t i = 0; i < a.size(); ++i) {
    if (a[i] == b[i]) continue;
    auto twist = [](const json& box) {
      return box.is_object() && box.contains("deformer") && box["deformer"].is_object() &&
             box["deformer"].value("type", "") == "twist";
    };
    if (!twist(a[i]) || !twist(b[i])) return std::nullopt;
    json x = a[i], y = b[i];
    x["deformer"].erase("angle_deg");
    y["deformer"].erase("angle_deg");
    if (x != y) return std::nullopt;
    changed.push_back(i);
  }
  if (changed.empty()) return std::nullopt;
  return changed;
}

Camera frame_bounds(const Eigen::AlignedBox3d& bounds, double fov_y_deg, int up_axis) {
  Camera c;
  const Eigen::Vector3d centre = bounds.center();
  const double radius = std::max(0.5 * bounds.diagonal().norm(), 1e-6);
  const double distance = 1.1 * radius / std::sin(0.5 * fov_y_deg * M_PI / 180.0);
  c.fov_y_deg = fov_y_deg;
  c.target = centre;
  // The front: from +z with y up (or x up), from -y with z up.
  c.eye = centre + distance * (up_axis == 2 ? Eigen::Vector3d(0, -1, 0) : Eigen::Vector3d(0, 0, 1));
  c.up = Eigen::Vector3d::Unit(std::clamp(up_axis, 0, 2));
  c.near_plane = std::max(distance - 2.0 * radius, distance * 1e-3);
  c.far_plane = distance + 2.0 * radius;
  return c;
}

Document Document::open(const fs::path& file, int up_axis) {
  if (up_axis < 0 || up_axis > 2) throw Error("edit: --up: must be x, y or z");
  Document d;
  if (is_scene_file(file)) {
    d.path_ = file;
    d.history_.push_back(read_scene_document(file));
  } else {
    const Mesh mesh = load_mesh(file.string());
    const Eigen::AlignedBox3d b = mesh_bounds(mesh);
    // A little larger than the upper half, so that the box holds the part's outline.
    const Eigen::Vector3d pad = 0.02 * b.diagonal();
    Eigen::Vector3d lo = b.min() - pad;
    const Eigen::Vector3d hi = b.max() + pad;
    lo[up_axis] = b.center()[up_axis];
    const char* axes[] = {"x", "y", "z"};
    d.path_ = scene_beside(file);
    d.history_.push_back(nlohmann::json{
        {"mesh", file.filename().string()},
        {"boxes",
         {{{"min", {lo.x(), lo.y(), lo.z()}},
           {"max", {hi.x(), hi.y(), hi.z()}},
           {"deformer", {{"type", "twist"}, {"axis", axes[up_axis]}, {"angle_deg", 90}}}}}},
        {"camera", camera_to_json(frame_bounds(b, 30.0, up_axis))}});
  }
  d.reload();
  return d;
}

void Document::reload() { scene_ = load_scene_json(history_[at_], path_); }

std::string Document::edit(const nlohmann::json& next, bool merge) {
  if (next == history_[at_]) return "";
  try {
    Scene scene = load_scene_json(next, path_);
    if (merge && at_ > 0) {
      history_[at_] = next;
      history_.resize(at_ + 1);
    } else {
      history_.resize(at_ + 1);
      history_.push_back(next);
      ++at_;
    }
    scene_ = std::move(scene);
    return "";
  } catch (const Error& e) {
    return e.what();
  }
}

void Document::undo() {
  if (!can_undo()) return;
  --at_;
  reload();
}

void Document::redo() {
  if (!can_redo()) return;
  ++at_;
  reload();
}

void Document::save(const fs::path& file, const Camera& camera) const {
  nlohmann::json out = json();
  out["camera"] = camera_to_json(camera);
  // The mesh path is relative to the scene's folder: rewrite it for another folder.
  const fs::path mesh = scene_.mesh;
  const fs::path folder = fs::absolute(file).parent_path();
  out["mesh"] = fs::relative(fs::absolute(mesh), folder).generic_string();
  write_file_atomic(file.string(), out.dump(2) + "\n");
}

}  // namespace raywarp::editor
