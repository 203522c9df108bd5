// The scene being edited: the JSON document `raywarp render` reads, its validated form, and the
// history of edits. An edit is a new document; it is taken only when load_scene_json accepts it
// (its Error, the command line's message naming the field, is returned, and the last good state
// stays), so undo and redo step between documents that each render.
#pragma once
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "library/camera.h"
#include "library/scene.h"

namespace raywarp::editor {

class Document {
 public:
  // Opens a scene file (.json), or a mesh file: then a scene is made beside it (NAME.json) with
  // one box over the mesh's upper half along `up_axis` (0 x, 1 y, 2 z) twisted about it by 90
  // degrees, so that something shows. Throws Error as `raywarp render` would.
  static Document open(const std::filesystem::path& file, int up_axis = 1);

  const std::filesystem::path& path() const { return path_; }
  const nlohmann::json& json() const { return history_[at_]; }
  const Scene& scene() const { return scene_; }

  // Takes `next` as the new state when it is a valid scene and differs from the current one;
  // `merge` replaces the current state instead of adding one to the history (the steps of one
  // slider drag are one edit). Returns "" or the scene reader's message.
  std::string edit(const nlohmann::json& next, bool merge = false);
  bool can_undo() const { return at_ > 0; }
  bool can_redo() const { return at_ + 1 < history_.size(); }
  void undo();
  void redo();
  size_t edits() const { return at_; }  // states before the current one

  // Writes the current document with `camera` inline (at the viewport's size) to `file`
  // atomically, so that `raywarp render FILE` renders the viewport's image.
  void save(const std::filesystem::path& file, const Camera& camera) const;

 private:
  std::filesystem::path path_;
  std::vector<nlohmann::json> history_;
  size_t at_ = 0;
  Scene scene_;
  void reload();
};

// The boxes whose only change from `was` to `now` is a twist's angle (deformer.angle_deg of a
// box whose deformer is one twist), when nothing else differs; none when anything else does or
// nothing changed.
std::optional<std::vector<size_t>> twist_angle_changes(const nlohmann::json& now,
                                                       const nlohmann::json& was);

// A camera that frames `bounds` (object units) from the front, looking at its centre with axis
// `up_axis` up (y up: from +z; z up: from -y), the whole bounding sphere in view.
Camera frame_bounds(const Eigen::AlignedBox3d& bounds, double fov_y_deg = 30.0, int up_axis = 1);

}  // namespace raywarp::editor
