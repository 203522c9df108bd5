// The editor's window: GLFW for the window and input, Dear ImGui for the panels, gl::Renderer
// for the viewport (rendered into its own framebuffer, read back and shown as a texture under the
// panels), editor::Baker for the bakes, editor::Document for the scene and its history.
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>
#include <imgui_internal.h>
#include <imgui_stdlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <fstream>
#include <future>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "base/atomic_file.h"
#include "base/error.h"
#include "deformers/registry.h"
#include "editor/baker.h"
#include "editor/document.h"
#include "editor/editor.h"
#include "editor/handles.h"
#include "editor/path_completion.h"
#include "gl/gl_api.h"
#include "gl/renderer.h"
#include "gl/shader_sources.h"
#include "library/mesh.h"
#include "library/texture_map.h"
#include "verify/ground_truth.h"

namespace raywarp::editor {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr float kPanelWidth = 360.0f;
constexpr float kStatusHeight = 28.0f;

struct Rect {
  float x = 0, y = 0, w = 0, h = 0;
  bool contains(double px, double py) const {
    return px >= x && py >= y && px < x + w && py < y + h;
  }
};

struct KeyPress {
  int key, mods;
};

std::deque<KeyPress>& key_queue() {
  static std::deque<KeyPress> q;
  return q;
}

std::vector<std::string>& dropped_files() {
  static std::vector<std::string> files;
  return files;
}

// The keys held down now (GLFW key codes), for the status file: a script that presses a key the
// panels read (Enter, Tab) holds it until the window has seen it.
std::set<int>& held_keys() {
  static std::set<int> keys;
  return keys;
}

void on_key(GLFWwindow*, int key, int, int action, int mods) {
  if (action == GLFW_PRESS || action == GLFW_REPEAT) key_queue().push_back({key, mods});
  if (action == GLFW_PRESS) held_keys().insert(key);
  if (action == GLFW_RELEASE) held_keys().erase(key);
}

void on_drop(GLFWwindow*, int count, const char** paths) {
  for (int i = 0; i < count; ++i) dropped_files().push_back(paths[i]);
}

class Editor {
 public:
  Editor(const EditOptions& options, GLFWwindow* window, Document document)
      : opt_(options), window_(window), start_(std::chrono::steady_clock::now()) {
    std::unique_ptr<BakeCache> cache;
    if (!options.no_cache) {
      const fs::path dir =
          options.cache_dir.empty() ? BakeCache::default_dir() : fs::path(options.cache_dir);
      if (!dir.empty()) cache = std::make_unique<BakeCache>(dir);
    }
    // A finished bake wakes the event loop at once (glfwPostEmptyEvent may be called from any
    // thread).
    baker_ = std::make_unique<Baker>(std::move(cache), [] { glfwPostEmptyEvent(); });
    renderer_ = std::make_unique<gl::Renderer>();
    watch_shaders();
    if (!options.frame_log.empty()) frame_log_.open(options.frame_log, std::ios::trunc);
    show(std::move(document), "opened " + options.input);
  }

  ~Editor() {
    if (texture_) gl::glDeleteTextures(1, &texture_);
  }

  // One turn of the loop: events, results, the viewport, the panels.
  void frame() {
    for (const std::string& file : dropped_files()) open(file);
    dropped_files().clear();
    watch_shaders();
    take_result();
    take_measurement();
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    int fw, fh;
    glfwGetFramebufferSize(window_, &fw, &fh);
    view_ =
        Rect{kPanelWidth, 0, std::max(1.0f, fw - kPanelWidth), std::max(1.0f, fh - kStatusHeight)};
    widgets_.clear();
    active_.clear();
    handle_keys();
    working_ = doc_->json();
    handle_mouse();
    panel(float(fh));
    status_bar(float(fw), float(fh));
    commit_edit();
    const double render_ms = render_viewport();
    draw_handles();
    ImGui::Render();
    gl::glBindFramebuffer(GL_FRAMEBUFFER, 0);
    gl::glViewport(0, 0, fw, fh);
    gl::glClearColor(0.16f, 0.16f, 0.18f, 1.0f);
    gl::glClear(GL_COLOR_BUFFER_BIT);
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    glfwSwapBuffers(window_);
    if (frame_log_) {
      frame_log_ << since_start_ms() << " " << render_ms << " " << (baker_->progress().busy ? 1 : 0)
                 << "\n";
      frame_log_.flush();
    }
    publish();
  }

  // A bake under way or due, or a drag held (its end makes the edit's last step).
  bool busy() const {
    return baker_->progress().busy || shown_ < generation_ || unbaked_ || held_drag_;
  }

 private:
  EditOptions opt_;
  GLFWwindow* window_;
  std::chrono::steady_clock::time_point start_;
  std::unique_ptr<Baker> baker_;
  std::unique_ptr<gl::Renderer> renderer_;
  std::optional<Document> doc_;
  json working_;
  ImGuiID last_edit_id_ = 0;
  long generation_ = 0, shown_ = -1;
  std::shared_ptr<const PreparedScene> prepared_;
  // What a bake was submitted for: the document (or, while a twist's angle is dragged, the
  // document with that angle widened), its scene, and whether D's texels were centred on the
  // lower faces.
  struct Submitted {
    json doc;
    Scene scene;
    bool centred = false;
  };
  std::map<long, Submitted> submitted_;
  std::optional<Submitted> baked_;  // what the shown textures were baked from
  std::vector<size_t> mapped_;      // boxes shown through a texture map M
  bool unbaked_ = false;  // shown through M while a drag goes on; its own bake follows the drag
  long mapped_edits_ = 0, bakes_shown_ = 0;
  const Mesh* renderer_mesh_ = nullptr;
  std::optional<Camera> camera_;
  bool dirty_ = true;
  GLuint texture_ = 0;
  Rect view_;
  Rect image_rect_;  // where the last image lies (its size may lag the viewport's by a frame)
  std::string message_;
  double frame_ms_ = 0, bake_s_ = 0;
  size_t texture_bytes_ = 0;
  std::vector<std::string> warnings_;
  int selected_ = 0;
  std::map<std::string, Rect> widgets_;
  std::string active_;  // the widget held by the mouse (or typed into), by name
  int still_width_ = 1920, still_height_ = 1080;
  std::string still_path_, still_written_;
  // The Open field: its text, its completions (for the text they were listed for), whether the
  // list shows.
  std::string open_path_, completions_for_ = "\n";
  std::vector<std::string> completions_;
  bool completions_open_ = false;
  // The error of the shown state against the scene's ground truth, measured on request in the
  // background (verify/ground_truth.h), at up to 384 pixels wide.
  struct Measurement {
    long generation = 0;
    int width = 0, height = 0;
    double iou = 0, over_pct = 0, mean_depth_pct = 0, seconds = 0;
    bool exact = false;
    std::string kind, error;
  };
  std::future<Measurement> measuring_;
  std::optional<Measurement> measured_;
  std::string published_;
  std::string saved_;
  std::ofstream frame_log_;
  int drag_button_ = -1;
  // --shader-dir: the files' names, times and sizes when last read, the compile error of the
  // last reload ("" none), the reloads that compiled.
  std::string shader_stamp_, shader_error_;
  long shader_reloads_ = 0;
  double next_shader_poll_ms_ = 0;
  // A drag of a box handle: the handle, the box as it was, where the drag began, and whether
  // it has made its edit yet (the later steps merge into it).
  std::optional<Handle> handle_drag_;
  Box handle_start_;
  Eigen::Vector2d handle_from_;
  bool handle_edited_ = false, handle_released_ = false;
  // A drag of a control point's target: the point, where its target was, where the drag began.
  struct PointDrag {
    size_t index = 0;
    Eigen::Vector3d start;
    Eigen::Vector2d from;
  };
  std::optional<PointDrag> point_drag_;
  std::optional<size_t> hovered_point_;
  json last_pick_;  // the last point picked on the surface: where, and its source p' + D(p')
  // The depth image of the viewport's last frame and its camera, for picking.
  std::vector<float> shown_depth_;
  Camera shown_camera_;
  std::optional<Handle> hovered_;
  bool held_drag_ = false;    // the mouse holds a field or a handle
  bool show_handles_ = true;  // the boxes' edges and handles over the viewport (H)

  double since_start_ms() const {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_)
        .count();
  }

  // Opens a scene or a mesh; on failure the message goes to the status line and the current
  // document stays.
  void open(const std::string& file) {
    try {
      show(Document::open(file, opt_.up_axis), "opened " + file);
    } catch (const Error& e) {
      message_ = e.what();
    } catch (const fs::filesystem_error& e) {
      message_ = e.what();
    }
  }

  void show(Document document, const std::string& message) {
    doc_ = std::move(document);
    open_path_ = doc_->path().string();
    camera_ = doc_->scene().camera;
    selected_ = 0;
    message_ = message;
    submit();
  }

  // Bakes the document as it is.
  // Reloads the shaders from --shader-dir when a file there changed (polled every 250 ms). A
  // file that does not compile leaves the shaders as they were and its error, with file and
  // line, in the panel.
  void watch_shaders() {
    if (opt_.shader_dir.empty() || since_start_ms() < next_shader_poll_ms_) return;
    next_shader_poll_ms_ = since_start_ms() + 250.0;
    std::string stamp;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(opt_.shader_dir, ec)) {
      if (e.path().extension() != ".glsl") continue;
      stamp += e.path().filename().string() + " " +
               std::to_string(e.last_write_time(ec).time_since_epoch().count()) + " " +
               std::to_string(e.file_size(ec)) + "\n";
    }
    if (stamp == shader_stamp_) return;
    shader_stamp_ = stamp;
    try {
      renderer_->set_shader_files(gl::read_shader_folder(opt_.shader_dir));
      shader_error_.clear();
      ++shader_reloads_;
      message_ = "shaders read from " + opt_.shader_dir;
      dirty_ = true;
    } catch (const Error& e) {
      shader_error_ = e.what();
    }
  }

  void submit() {
    unbaked_ = false;
    submit_scene(doc_->json(), doc_->scene(), false);
  }

  void submit_scene(const json& document, const Scene& scene, bool centred) {
    ++generation_;
    submitted_[generation_] = Submitted{document, scene, centred};
    baker_->submit(scene, generation_, centred);
  }

  // While a twist's angle is dragged: bake the box at a wider angle of the same sign, texel
  // centres on its lower faces, so that every angle from 0 to that one is then shown through
  // the texture map M with no bake (try_map). False when the edit is not only twist angles.
  bool submit_widened() {
    if (!baked_ || doc_->scene().render.sampling == Sampling::Bounded) return false;
    const auto changed = twist_angle_changes(doc_->json(), baked_->doc);
    if (!changed) return false;
    json document = doc_->json();
    Scene scene = doc_->scene();
    for (size_t i : *changed)  // cylindrical textures are not read through M: bake as edited
      if (scene.boxes[i].mapping.cylindrical) return false;
    for (size_t i : *changed) {
      const double now = scene.boxes[i].deformer.angle_deg;
      const double was = baked_->scene.boxes[i].deformer.angle_deg;
      const double sign = now != 0.0 ? (now > 0.0 ? 1.0 : -1.0) : (now >= was ? 1.0 : -1.0);
      const double wide = now + sign * std::max(90.0, 0.5 * std::abs(now));
      scene.boxes[i].deformer.angle_deg = wide;
      document["boxes"][i]["deformer"]["angle_deg"] = wide;
    }
    submit_scene(document, scene, true);
    return true;
  }

  // Shows the document through the shown textures when it differs from what they were baked
  // for only in twist angles within the baked ones: each such box's texture is read through the
  // map M of library/texture_map.h, no texel uploaded again. False when it cannot.
  bool try_map() {
    if (!prepared_ || !baked_ || doc_->scene().render.sampling == Sampling::Bounded) return false;
    std::vector<size_t> changed;
    if (doc_->json() != baked_->doc) {
      if (!baked_->centred) return false;
      const auto c = twist_angle_changes(doc_->json(), baked_->doc);
      if (!c) return false;
      changed = *c;
    }
    std::vector<TextureMapping> maps;
    try {
      for (size_t i : changed)
        maps.push_back(twist_angle_mapping(doc_->scene().boxes[i], prepared_->boxes[i].textures,
                                           baked_->scene.boxes[i].deformer.angle_deg));
    } catch (const Error&) {
      return false;  // beyond the baked angle, or of the other sign
    }
    try {
      for (size_t i : mapped_) {
        const BoxTextures& t = prepared_->boxes[i].textures;
        renderer_->set_texture_map(i, t.texture_map, t.region, t.lipschitz);
      }
      for (size_t k = 0; k < changed.size(); ++k)
        renderer_->set_texture_map(changed[k], maps[k].map, maps[k].region, maps[k].lipschitz);
    } catch (const Error& e) {
      message_ = e.what();
      return false;
    }
    mapped_ = changed;
    if (!changed.empty()) ++mapped_edits_;
    dirty_ = true;
    return true;
  }

  void take_result() {
    std::optional<Baker::Result> r = baker_->take();
    if (!r || r->generation <= shown_) return;
    bake_s_ = r->seconds;
    if (!r->prepared) {
      message_ = r->error;
      shown_ = r->generation;  // that state is done: it failed, the last good image stays
      return;
    }
    prepared_ = r->prepared;
    baked_.reset();
    if (auto it = submitted_.find(r->generation); it != submitted_.end()) baked_ = it->second;
    submitted_.erase(submitted_.begin(), submitted_.upper_bound(r->generation));
    mapped_.clear();
    ++bakes_shown_;
    warnings_.clear();
    for (const BakedBox& b : prepared_->boxes)
      for (const std::string& w : b.report.warning_messages()) warnings_.push_back(w);
    try {
      if (renderer_mesh_ != &prepared_->mesh()) {
        renderer_->set_mesh(prepared_->mesh());
        renderer_mesh_ = &prepared_->mesh();
      }
      std::vector<const BoxTextures*> textures;
      for (const BakedBox& b : prepared_->boxes) textures.push_back(&b.textures);
      renderer_->set_boxes(textures);
      texture_bytes_ = renderer_->texture_bytes();
    } catch (const Error& e) {
      message_ = e.what();
    }
    if (!camera_) camera_ = frame_bounds(mesh_bounds(prepared_->mesh()));
    shown_ = r->generation;
    dirty_ = true;
    // Baked wider than the document (a twist's angle being dragged): show the document.
    if (baked_ && baked_->doc != doc_->json()) try_map();
  }

  Camera view_camera() const {
    Camera c = *camera_;
    c.width = int(view_.w);
    c.height = int(view_.h);
    return c;
  }

  // Renders the viewport when something changed; returns the frame time (0 when not rendered).
  double render_viewport() {
    if (!prepared_ || !camera_) return 0.0;
    const bool resized = int(image_rect_.w) != int(view_.w) || int(image_rect_.h) != int(view_.h);
    if (!dirty_ && !resized) {
      draw_image();
      return 0.0;
    }
    dirty_ = false;
    const Camera c = view_camera();
    try {
      gl::FrameStats stats;
      const Image image = renderer_->render(c, c.width, c.height, doc_->scene().render, &stats);
      frame_ms_ = stats.milliseconds;
      shown_depth_ = image.depth;
      shown_camera_ = c;
      if (!texture_) {
        gl::glGenTextures(1, &texture_);
        gl::glBindTexture(GL_TEXTURE_2D, texture_);
        gl::glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        gl::glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
      }
      gl::glBindTexture(GL_TEXTURE_2D, texture_);
      gl::glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
      gl::glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, image.width, image.height, 0, GL_RGBA,
                       GL_UNSIGNED_BYTE, image.rgba.data());
      image_rect_ = Rect{view_.x, view_.y, float(image.width), float(image.height)};
    } catch (const Error& e) {
      message_ = e.what();
    }
    draw_image();
    return frame_ms_;
  }

  void draw_image() {
    if (!texture_) return;
    ImGui::GetBackgroundDrawList()->AddImage(
        reinterpret_cast<ImTextureID>(static_cast<intptr_t>(texture_)),
        ImVec2(image_rect_.x, image_rect_.y),
        ImVec2(image_rect_.x + image_rect_.w, image_rect_.y + image_rect_.h));
  }

  void undo() {
    if (!doc_->can_undo()) return;
    doc_->undo();
    message_ = "undo";
    try_map();
    submit();
  }
  void redo() {
    if (!doc_->can_redo()) return;
    doc_->redo();
    message_ = "redo";
    try_map();
    submit();
  }
  void save() {
    try {
      doc_->save(doc_->path(), view_camera());
      saved_ = doc_->path().string();
      message_ = "saved " + saved_;
    } catch (const Error& e) {
      message_ = e.what();
    }
  }
  // Frames the mesh, or (`selection`) the selected box, keeping the direction of view.
  void frame_view(bool selection = false) {
    if (!prepared_ || !camera_) return;
    Eigen::AlignedBox3d bounds = mesh_bounds(prepared_->mesh());
    if (const Box* box = selected_box(); selection && box) {
      bounds.setEmpty();
      for (const auto& [a, b] : box_edges(*box)) bounds.extend(a).extend(b);
    }
    const Camera f = frame_bounds(bounds, camera_->fov_y_deg);
    const double distance = (f.eye - f.target).norm();
    const Eigen::Vector3d dir = (camera_->eye - camera_->target).normalized();
    camera_->target = f.target;
    camera_->eye = f.target + distance * dir;
    camera_->near_plane = f.near_plane;
    camera_->far_plane = f.far_plane;
    dirty_ = true;
  }

  void handle_keys() {
    const bool typing = ImGui::GetIO().WantTextInput;
    for (const KeyPress& k : key_queue()) {
      const bool ctrl = k.mods & GLFW_MOD_CONTROL, shift = k.mods & GLFW_MOD_SHIFT;
      if (ctrl && k.key == GLFW_KEY_Z && shift)
        redo();
      else if (ctrl && k.key == GLFW_KEY_Z)
        undo();
      else if (ctrl && k.key == GLFW_KEY_Y)
        redo();
      else if (ctrl && k.key == GLFW_KEY_S)
        save();
      else if (ctrl && k.key == GLFW_KEY_Q)
        glfwSetWindowShouldClose(window_, GLFW_TRUE);
      else if (!typing && !ctrl && k.key == GLFW_KEY_F)
        frame_view(shift);
      else if (!typing && !ctrl && k.key == GLFW_KEY_H)
        show_handles_ = !show_handles_;
    }
    key_queue().clear();
  }

  // Orbit (left drag), pan (middle drag, or Shift + left), dolly (right drag, wheel).
  void handle_mouse() {
    ImGuiIO& io = ImGui::GetIO();
    if (!camera_) return;
    const Eigen::Vector2d mouse(io.MousePos.x, io.MousePos.y);
    const bool in_view = !io.WantCaptureMouse && view_.contains(mouse.x(), mouse.y());
    hovered_.reset();
    hovered_point_.reset();
    if (handle_drag_) {
      drag_box_handle(mouse);
      return;
    }
    if (point_drag_) {
      drag_control_point(mouse);
      return;
    }
    if (drag_button_ < 0 && in_view) {
      if (json* points = selected_points()) {
        if (ImGui::IsMouseClicked(0) && io.KeyCtrl) {
          add_control_point(*points, mouse);
          return;
        }
        if (show_handles_) hovered_point_ = pick_target(*points, mouse);
        if (hovered_point_ && ImGui::IsMouseClicked(0) && !io.KeyShift) {
          const json& to = (*points)[*hovered_point_]["to"];
          point_drag_ = PointDrag{
              *hovered_point_,
              Eigen::Vector3d(to[0].get<double>(), to[1].get<double>(), to[2].get<double>()),
              mouse};
          handle_edited_ = false;
          return;
        }
      }
      if (const Box* box = selected_box(); box && show_handles_ && !hovered_point_)
        hovered_ = pick_handle(*box, view_mapping(), mouse);
      if (hovered_ && ImGui::IsMouseClicked(0) && !io.KeyShift) {
        handle_drag_ = hovered_;
        handle_start_ = *selected_box();
        handle_from_ = mouse;
        handle_edited_ = false;
        return;
      }
      if (ImGui::IsMouseClicked(0) && select_box_at(mouse)) return;
      for (int b = 0; b < 3; ++b)
        if (ImGui::IsMouseClicked(b)) drag_button_ = b;
      if (io.MouseWheel != 0.0f) dolly(std::pow(0.9, io.MouseWheel));
    }
    if (drag_button_ >= 0 && !ImGui::IsMouseDown(drag_button_)) drag_button_ = -1;
    if (drag_button_ < 0) return;
    const double dx = io.MouseDelta.x, dy = io.MouseDelta.y;
    if (dx == 0.0 && dy == 0.0) return;
    Camera& c = *camera_;
    const Eigen::Vector3d up = c.up.normalized();
    Eigen::Vector3d offset = c.eye - c.target;
    const Eigen::Vector3d forward = -offset.normalized();
    const Eigen::Vector3d right = forward.cross(up).normalized();
    const Eigen::Vector3d screen_up = right.cross(forward);
    if (drag_button_ == 2) {
      dolly(std::exp(0.01 * dy));
      return;
    }
    if (drag_button_ == 1 || io.KeyShift) {
      const double scale =
          2.0 * offset.norm() * std::tan(0.5 * c.fov_y_deg * M_PI / 180.0) / view_.h;
      const Eigen::Vector3d move = (-dx * right + dy * screen_up) * scale;
      c.eye += move;
      c.target += move;
    } else {
      // Turntable: about the up axis, then about the right axis, never over the pole.
      offset = Eigen::AngleAxisd(-0.008 * dx, up) * offset;
      const Eigen::Vector3d r = (-offset).cross(up).normalized();
      const Eigen::Vector3d tilted = Eigen::AngleAxisd(-0.008 * dy, r) * offset;
      if (std::abs(tilted.normalized().dot(up)) < 0.995) offset = tilted;
      c.eye = c.target + offset;
    }
    dirty_ = true;
  }

  ViewMapping view_mapping() const {
    return ViewMapping{view_camera(), view_.x, view_.y, std::max(1.0f, view_.w),
                       std::max(1.0f, view_.h)};
  }

  const Box* selected_box() const {
    const Scene& scene = doc_->scene();
    return selected_ >= 0 && selected_ < int(scene.boxes.size()) ? &scene.boxes[selected_].box
                                                                 : nullptr;
  }

  // A click on another box's centre dot selects that box.
  bool select_box_at(const Eigen::Vector2d& mouse) {
    const ViewMapping view = view_mapping();
    const Scene& scene = doc_->scene();
    for (size_t i = 0; i < scene.boxes.size(); ++i) {
      const auto c = view.project(scene.boxes[i].box.centre);
      if (int(i) != selected_ && c && (*c - mouse).norm() <= 8.0) {
        selected_ = int(i);
        return true;
      }
    }
    return false;
  }

  // One step of a handle drag: the box it makes replaces the selected box's placement in the
  // working document (as centre, half_extents and rotation_deg).
  void drag_box_handle(const Eigen::Vector2d& mouse) {
    // The release may come in the frame of the last move: that move counts, then the drag ends
    // (commit_edit).
    if (!ImGui::IsMouseDown(0)) handle_released_ = true;
    hovered_ = handle_drag_;
    active_ = "handle." + handle_drag_->name();
    json& boxes = working_["boxes"];
    if (selected_ >= int(boxes.size()) || !prepared_) return;
    const double min_half = 2e-3 * mesh_bounds(prepared_->mesh()).diagonal().norm();
    const Box b =
        drag_handle(handle_start_, *handle_drag_, view_mapping(), handle_from_, mouse, min_half);
    json& box = boxes[selected_];
    for (const char* key : {"min", "max", "center", "centre", "half_extents"}) box.erase(key);
    box["centre"] = {b.centre.x(), b.centre.y(), b.centre.z()};
    box["half_extents"] = {b.half_extents.x(), b.half_extents.y(), b.half_extents.z()};
    if (box.contains("rotation_deg") || !b.rotation.isIdentity(1e-12)) {
      const Eigen::Vector3d r = euler_deg_of(b.rotation);
      box["rotation_deg"] = {r.x(), r.y(), r.z()};
    }
  }

  // The control points of the selected box in the working document, when its deformer is
  // control_points (a list of pairs); else null.
  json* selected_points() {
    json& boxes = working_["boxes"];
    if (!boxes.is_array() || selected_ < 0 || selected_ >= int(boxes.size())) return nullptr;
    json& d = boxes[selected_]["deformer"];
    if (!d.is_object() || d.value("type", "") != "control_points" || !d.contains("points") ||
        !d["points"].is_array())
      return nullptr;
    return &d["points"];
  }

  // Box i's "deformer" in the document (null when there is none).
  const json& deformer_json(size_t i) const {
    static const json none;
    const json& doc = doc_->json();
    const auto boxes = doc.find("boxes");
    if (boxes == doc.end() || !boxes->is_array() || i >= boxes->size() || !(*boxes)[i].is_object())
      return none;
    const auto d = (*boxes)[i].find("deformer");
    return d == (*boxes)[i].end() ? none : *d;
  }

  static std::optional<Eigen::Vector3d> point_of(const json& j) {
    if (!j.is_array() || j.size() != 3) return std::nullopt;
    for (const json& v : j)
      if (!v.is_number()) return std::nullopt;
    return Eigen::Vector3d(j[0].get<double>(), j[1].get<double>(), j[2].get<double>());
  }

  // The control point whose target's dot is within 8 pixels of the mouse.
  std::optional<size_t> pick_target(const json& points, const Eigen::Vector2d& mouse) const {
    const ViewMapping view = view_mapping();
    for (size_t i = 0; i < points.size(); ++i)
      if (const auto to = point_of(points[i].value("to", json())))
        if (const auto p = view.project(*to); p && (*p - mouse).norm() <= 8.0) return i;
    return std::nullopt;
  }

  // Ctrl + click on the deformed surface: a control point from the point of the undeformed mesh
  // that shows there (p' + D(p'), p' read from the depth image) to p' itself, its target then
  // dragged while the button is held.
  void add_control_point(json& points, const Eigen::Vector2d& mouse) {
    const std::string box_name = "box " + std::to_string(selected_);
    if (busy() || !prepared_ || selected_ >= int(prepared_->boxes.size())) {
      message_ = "control points: the bake is not finished; pick again when it is";
      return;
    }
    const ViewMapping shown{shown_camera_, image_rect_.x, image_rect_.y, image_rect_.w,
                            image_rect_.h};
    const auto deformed =
        surface_point(shown, shown_depth_, int(image_rect_.w), int(image_rect_.h), mouse);
    if (!deformed) {
      message_ = "control points: no surface under the mouse";
      return;
    }
    const BoxTextures& t = prepared_->boxes[selected_].textures;
    std::optional<Eigen::Vector3d> source = texture_preimage(t, *deformed);
    if (!source) {
      message_ = "control points: the surface there is not " + box_name +
                 "'s deformed part; Ctrl + click inside it";
      return;
    }
    // Within the box, as the scene reader asks of every source (interpolation may overshoot).
    const Eigen::Vector3d h = t.box.half_extents * (1.0 - 1e-9);
    *source = t.box.to_object(t.box.to_local(*source).cwiseMax(-h).cwiseMin(h));
    auto j3 = [](const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); };
    points.push_back({{"from", j3(*source)}, {"to", j3(*deformed)}});
    last_pick_ = {{"deformed", j3(*deformed)}, {"source", j3(*source)}};
    point_drag_ = PointDrag{points.size() - 1, *deformed, mouse};
    handle_edited_ = false;
  }

  void drag_control_point(const Eigen::Vector2d& mouse) {
    if (!ImGui::IsMouseDown(0)) handle_released_ = true;
    hovered_point_ = point_drag_->index;
    active_ = "point." + std::to_string(point_drag_->index);
    json* points = selected_points();
    if (!points || point_drag_->index >= points->size()) return;
    const Eigen::Vector3d to =
        drag_point(point_drag_->start, view_mapping(), point_drag_->from, mouse);
    (*points)[point_drag_->index]["to"] = {to.x(), to.y(), to.z()};
  }

  // The boxes' edges, the selected box's handles, over the viewport's image.
  void draw_handles() {
    if (!camera_ || !doc_ || !show_handles_) return;
    ImDrawList* draw = ImGui::GetBackgroundDrawList();
    draw->PushClipRect(ImVec2(view_.x, view_.y), ImVec2(view_.x + view_.w, view_.y + view_.h));
    const ViewMapping view = view_mapping();
    const Scene& scene = doc_->scene();
    auto im = [](const Eigen::Vector2d& p) { return ImVec2(float(p.x()), float(p.y())); };
    const ImU32 axis_colour[3] = {IM_COL32(230, 80, 80, 255), IM_COL32(90, 200, 90, 255),
                                  IM_COL32(90, 140, 240, 255)};
    for (size_t i = 0; i < scene.boxes.size(); ++i) {
      const Box& box = scene.boxes[i].box;
      const bool selected = int(i) == selected_;
      const ImU32 edge = selected ? IM_COL32(255, 220, 90, 220) : IM_COL32(200, 200, 200, 110);
      for (const auto& [a, b] : box_edges(box)) {
        const auto pa = view.project(a), pb = view.project(b);
        if (pa && pb) draw->AddLine(im(*pa), im(*pb), edge, selected ? 1.5f : 1.0f);
      }
      if (!selected) {
        if (const auto c = view.project(box.centre))
          draw->AddCircle(im(*c), 5.0f, IM_COL32(220, 220, 220, 160), 12, 1.5f);
        continue;
      }
      for (int a = 0; a < 3; ++a) {
        const std::vector<Eigen::Vector2d> ring = ring_polyline(box, a, view);
        if (ring.empty()) continue;
        std::vector<ImVec2> points;
        for (const Eigen::Vector2d& p : ring) points.push_back(im(p));
        const bool hot = hovered_ && *hovered_ == Handle{Handle::Kind::Ring, a};
        draw->AddPolyline(points.data(), int(points.size()),
                          hot ? IM_COL32(255, 255, 255, 255) : axis_colour[a], ImDrawFlags_Closed,
                          hot ? 3.0f : 1.5f);
      }
      const json& d = deformer_json(i);
      if (d.is_object() && d.value("type", "") == "control_points" && d.contains("points")) {
        size_t k = 0;
        for (const json& pt : d["points"]) {
          const auto from = point_of(pt.value("from", json())),
                     to = point_of(pt.value("to", json()));
          const auto a = from ? view.project(*from) : std::nullopt;
          const auto b = to ? view.project(*to) : std::nullopt;
          const bool hot = hovered_point_ && *hovered_point_ == k++;
          if (a && b) draw->AddLine(im(*a), im(*b), IM_COL32(240, 90, 220, 200), 1.5f);
          if (a) draw->AddCircle(im(*a), 4.0f, IM_COL32(240, 240, 240, 220), 12, 1.5f);
          if (b) draw->AddCircleFilled(im(*b), hot ? 7.0f : 5.0f, IM_COL32(240, 90, 220, 255), 16);
        }
      }
      for (const PlacedHandle& h : place_handles(box, view)) {
        if (h.handle.kind == Handle::Kind::Ring) continue;
        const bool hot = hovered_ && *hovered_ == h.handle;
        const ImU32 fill = h.handle.kind == Handle::Kind::Centre ? IM_COL32(240, 240, 240, 255)
                                                                 : axis_colour[h.handle.axis];
        draw->AddCircleFilled(im(h.pixel), hot ? 7.0f : 5.0f, fill, 16);
        draw->AddCircle(im(h.pixel), hot ? 7.0f : 5.0f, IM_COL32(20, 20, 20, 255), 16, 1.0f);
      }
    }
    draw->PopClipRect();
  }

  void dolly(double factor) {
    Camera& c = *camera_;
    const double before = (c.eye - c.target).norm();
    c.eye = c.target + (c.eye - c.target) * factor;
    const double after = before * factor;
    // Keep the mesh between the planes: they move with the eye.
    c.near_plane = std::max(c.near_plane + (after - before), after * 1e-3);
    c.far_plane = std::max(c.far_plane + (after - before), c.near_plane * 2.0);
    dirty_ = true;
  }

  void remember(const std::string& name) {
    const ImVec2 a = ImGui::GetItemRectMin(), b = ImGui::GetItemRectMax();
    widgets_[name] = Rect{a.x, a.y, b.x - a.x, b.y - a.y};
    if (ImGui::IsItemActive()) active_ = name;
  }

  // The parameters of one deformer object (JSON `d`) of `type`, read from and written to `d`;
  // the values shown when a key is absent are the parsed spec's (the defaults).
  void deformer_fields(json& d, const DeformerType& type, const DeformerSpec& spec,
                       const std::string& prefix) {
    for (const ParamDecl& p : type.params) {
      const std::string label = p.key + "##" + prefix;
      if (p.kind == ParamKind::Number && std::holds_alternative<double DeformerSpec::*>(p.field)) {
        double v = d.contains(p.key) && d[p.key].is_number()
                       ? d[p.key].get<double>()
                       : spec.*std::get<double DeformerSpec::*>(p.field);
        bool changed;
        if (std::isfinite(p.range.lo) && std::isfinite(p.range.hi) && !p.range.hi_is_sanity_limit)
          changed = ImGui::SliderScalar(label.c_str(), ImGuiDataType_Double, &v, &p.range.lo,
                                        &p.range.hi, "%.4g");
        else
          changed = ImGui::DragScalar(label.c_str(), ImGuiDataType_Double, &v,
                                      float(std::max(std::abs(v), 1e-3) * 0.005), nullptr, nullptr,
                                      "%.4g");
        remember(prefix + p.key);
        if (changed) d[p.key] = v;
      } else if (p.kind == ParamKind::Axis &&
                 std::holds_alternative<int DeformerSpec::*>(p.field)) {
        int axis = spec.*std::get<int DeformerSpec::*>(p.field);
        const char* names[] = {"x", "y", "z"};
        if (ImGui::Combo(label.c_str(), &axis, names, 3)) d[p.key] = names[axis];
        remember(prefix + p.key);
      } else if (p.kind == ParamKind::Points && d.contains(p.key) && d[p.key].is_array()) {
        ImGui::Text("%zu control points", d[p.key].size());
        ImGui::SameLine();
        ImGui::BeginDisabled(d[p.key].size() <= 1);
        if (ImGui::Button("Remove last") && d[p.key].size() > 1)
          d[p.key].erase(d[p.key].size() - 1);
        ImGui::EndDisabled();
        remember(prefix + "remove_point");
        ImGui::TextWrapped(
            "Ctrl + click the deformed surface to add a point there; drag a magenta dot to move "
            "its target.");
      } else if (d.contains(p.key)) {
        ImGui::TextDisabled("%s: %s", p.key.c_str(), d[p.key].dump().c_str());
      }
    }
  }

  // Add a box (a quarter of the mesh's bounds about their centre, twisted), delete the selected
  // one, or fit it to the mesh's bounds. The scene reader refuses what overlaps, in the status
  // line.
  void box_buttons(json& boxes) {
    const bool have_mesh = prepared_ != nullptr;
    ImGui::BeginDisabled(!have_mesh);
    if (ImGui::Button("Add box") && have_mesh) {
      const Eigen::AlignedBox3d b = mesh_bounds(prepared_->mesh());
      const Eigen::Vector3d c = b.center(), h = 0.25 * b.sizes();
      boxes.push_back({{"centre", {c.x(), c.y(), c.z()}},
                       {"half_extents", {h.x(), h.y(), h.z()}},
                       {"deformer", {{"type", "twist"}, {"axis", "y"}, {"angle_deg", 90}}}});
      selected_ = int(boxes.size()) - 1;
    }
    remember("add_box");
    ImGui::SameLine();
    if (ImGui::Button("Snap to mesh") && have_mesh && selected_ < int(boxes.size())) {
      const Eigen::AlignedBox3d b = mesh_bounds(prepared_->mesh());
      json& box = boxes[selected_];
      for (const char* key : {"centre", "half_extents", "rotation_deg"}) box.erase(key);
      // A hair larger than the bounds, so that no vertex lies on a face.
      const Eigen::Vector3d pad = Eigen::Vector3d::Constant(1e-3 * b.diagonal().norm());
      const Eigen::Vector3d lo = b.min() - pad, hi = b.max() + pad;
      box["min"] = {lo.x(), lo.y(), lo.z()};
      box["max"] = {hi.x(), hi.y(), hi.z()};
    }
    remember("snap_box");
    ImGui::EndDisabled();
    ImGui::SameLine();
    ImGui::BeginDisabled(boxes.empty());
    if (ImGui::Button("Delete box") && selected_ < int(boxes.size())) {
      boxes.erase(boxes.begin() + selected_);
      selected_ = std::max(0, selected_ - 1);
    }
    ImGui::EndDisabled();
    remember("delete_box");
  }

  // Tab in the Open field: the path extended by what its completions share.
  static int complete_on_tab(ImGuiInputTextCallbackData* data) {
    if (data->EventFlag != ImGuiInputTextFlags_CallbackCompletion) return 0;
    const std::string typed(data->Buf, size_t(data->BufTextLen));
    const std::string completed = complete_path(typed);
    if (completed != typed) {
      data->DeleteChars(0, data->BufTextLen);
      data->InsertChars(0, completed.c_str());
    }
    return 0;
  }

  // Open a scene or a mesh by its path: Tab completes it, the matches are listed under the field
  // (a folder's opens it in the list, a file's opens the file), Enter or Open opens it.
  void open_field() {
    ImGui::SetNextItemWidth(-50.0f);
    const bool enter = ImGui::InputText(
        "##open", &open_path_,
        ImGuiInputTextFlags_EnterReturnsTrue | ImGuiInputTextFlags_CallbackCompletion,
        complete_on_tab);
    const bool field_active = ImGui::IsItemActive();
    remember("open.path");
    ImGui::SameLine();
    const bool clicked = ImGui::Button("Open");
    remember("open");
    if (enter || clicked) {
      completions_open_ = false;
      open(open_path_);
      return;
    }
    if (field_active) completions_open_ = true;
    if (!completions_open_) return;
    if (completions_for_ != open_path_) {
      completions_ = path_completions(open_path_, 32);
      completions_for_ = open_path_;
    }
    if (completions_.empty()) {
      if (!field_active) completions_open_ = false;
      return;
    }
    const float rows = float(std::min<size_t>(completions_.size(), 8));
    ImGui::BeginChild("completions", ImVec2(0, rows * ImGui::GetTextLineHeightWithSpacing() + 8),
                      true);
    std::string chosen;
    for (const std::string& c : completions_) {
      const fs::path p(c);
      const std::string label =
          c.back() == '/' ? p.parent_path().filename().string() + "/" : p.filename().string();
      if (ImGui::Selectable(label.c_str())) chosen = c;
    }
    const bool hovered = ImGui::IsWindowHovered();
    ImGui::EndChild();
    if (!chosen.empty()) {
      open_path_ = chosen;
      if (chosen.back() != '/') {
        completions_open_ = false;
        open(chosen);
        return;
      }
    }
    if (!field_active && !hovered) completions_open_ = false;
  }

  // Renders the view at up to 384 pixels wide here, then measures it against the ground truth in
  // the background.
  void measure_error() {
    if (busy() || !prepared_ || !camera_ || measuring_.valid()) return;
    const int w = std::min(384, int(view_.w));
    const int h = std::max(1, int(std::lround(w * double(view_.h) / view_.w)));
    Camera c = view_camera();
    c.width = w;
    c.height = h;
    Image image;
    try {
      image = renderer_->render(c, w, h, doc_->scene().render);
    } catch (const Error& e) {
      message_ = e.what();
      return;
    }
    const Scene scene = doc_->scene();
    const std::shared_ptr<const PreparedScene> prepared = prepared_;
    const long generation = shown_;
    measuring_ = std::async(std::launch::async, [=, image = std::move(image)] {
      Measurement m;
      m.generation = generation;
      m.width = w;
      m.height = h;
      const auto start = std::chrono::steady_clock::now();
      try {
        const Truth truth = ground_truth(scene, *prepared, c, w, h);
        const ImageComparison cmp = compare_images(image, truth.image, 0.01 * truth.diagonal);
        m.iou = cmp.iou;
        m.over_pct = 100.0 * cmp.fraction_over;
        m.mean_depth_pct = 100.0 * cmp.mean_depth_error / truth.diagonal;
        m.kind = truth.kind;
        m.exact = truth.kind.rfind("exact", 0) == 0;
      } catch (const std::exception& e) {
        m.error = e.what();
      }
      m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      return m;
    });
  }

  void take_measurement() {
    if (!measuring_.valid() ||
        measuring_.wait_for(std::chrono::seconds(0)) != std::future_status::ready)
      return;
    measured_ = measuring_.get();
    if (!measured_->error.empty()) message_ = "ground truth: " + measured_->error;
  }

  static json twist_example() { return {{"type", "twist"}, {"axis", "y"}, {"angle_deg", 45}}; }

  // A list of deformers, applied in order (continuous ones only: the scene reader refuses a cut
  // in a list): each one's type and parameters, Remove, and Then add.
  void deformer_list(json& d, const BoxSpec& spec) {
    std::vector<const DeformerType*> types;
    std::vector<const char*> names;
    for (const DeformerType& t : deformer_types())
      if (!t.cuts) {
        types.push_back(&t);
        names.push_back(t.name.c_str());
      }
    std::optional<size_t> remove;
    for (size_t k = 0; k < d.size(); ++k) {
      if (!d[k].is_object()) continue;
      ImGui::PushID(int(k));
      ImGui::Separator();
      const DeformerType* type = find_deformer_type(d[k].value("type", ""));
      int current = 0;
      for (size_t t = 0; t < types.size(); ++t)
        if (types[t] == type) current = int(t);
      const std::string label = "deformer " + std::to_string(k);
      if (ImGui::Combo(label.c_str(), &current, names.data(), int(names.size()))) {
        json fresh =
            types[current]->examples.empty() ? json::object() : types[current]->examples.front();
        fresh["type"] = types[current]->name;
        d[k] = fresh;
        type = nullptr;
      }
      remember("deformer." + std::to_string(k));
      const DeformerSpec* parsed = k == 0                     ? &spec.deformer
                                   : k - 1 < spec.then.size() ? &spec.then[k - 1]
                                                              : nullptr;
      if (type && parsed && parsed->type == type->name)
        deformer_fields(d[k], *type, *parsed, "param." + std::to_string(k) + ".");
      if (ImGui::Button("Remove")) remove = k;
      remember("remove_deformer." + std::to_string(k));
      ImGui::PopID();
    }
    if (remove) {
      d.erase(*remove);
      if (d.size() == 1) d = d[0];  // one deformer: the plain form
    }
    if (d.is_array() && ImGui::Button("Then add a deformer")) d.push_back(twist_example());
    remember("then_add");
  }

  // A texture resolution: "auto" (the automatic layout within its budget) or texels along the
  // longest side. Writes obj[key] (and drops max_mib, which only the automatic one reads).
  void resolution_combo(json& obj, const char* label, int current) {
    static const int choices[] = {kAutoResolution, 32, 48, 64, 96, 128, 192, 256, 384, 512};
    std::string shown = current == kAutoResolution ? "auto" : std::to_string(current);
    if (ImGui::BeginCombo(label, shown.c_str())) {
      for (int c : choices) {
        const std::string name = c == kAutoResolution ? "auto" : std::to_string(c);
        if (ImGui::Selectable(name.c_str(), c == current) && c != current) {
          if (!obj.is_object()) obj = json::object();
          if (c == kAutoResolution) {
            obj["resolution"] = "auto";
          } else {
            obj["resolution"] = c;
            obj.erase("max_mib");
          }
        }
      }
      ImGui::EndCombo();
    }
    remember(label);
  }

  // The box's implicit representation and the resolutions of its textures.
  void texture_fields(json& box, const BoxSpec& spec, bool cuts) {
    if (!ImGui::CollapsingHeader("Textures", ImGuiTreeNodeFlags_DefaultOpen)) return;
    const char* kinds[] = {"sdf", "depth_cube"};
    int kind = spec.implicit.type == "depth_cube" ? 1 : 0;
    if (ImGui::Combo("implicit", &kind, kinds, 2)) {
      json& implicit = box["implicit"];
      if (!implicit.is_object()) implicit = json::object();
      implicit["type"] = kinds[kind];
      // The distance grid's band and margin mean nothing to a depth cube.
      if (kind == 1)
        for (const char* key : {"band_voxels", "margin_voxels"}) implicit.erase(key);
    }
    remember("implicit");
    // How D and A are stored: over (x, y, z), or over (angle, radius, height) about an axis.
    const char* mappings[] = {"cartesian", "cylindrical x", "cylindrical y", "cylindrical z"};
    int mapping = spec.mapping.cylindrical ? 1 + spec.mapping.axis : 0;
    if (ImGui::Combo("mapping", &mapping, mappings, 4)) {
      if (mapping == 0) {
        box.erase("mapping");
      } else {
        json& m = box["mapping"];
        if (!m.is_object()) m = json::object();
        m["type"] = "cylindrical";
        m["axis"] = std::string(1, char('x' + mapping - 1));
      }
    }
    remember("mapping");
    resolution_combo(box["implicit"], "implicit.resolution", spec.implicit.resolution);
    resolution_combo(box["deformation"], "deformation.resolution", spec.deformation_resolution);
    if (cuts) resolution_combo(box["alpha"], "alpha.resolution", spec.alpha_resolution);
    for (const char* key : {"implicit", "deformation", "alpha"})
      if (box.contains(key) && box[key].is_null()) box.erase(key);
  }

  // Render a still of the current view at any size to a PNG (the view's aspect follows the size).
  void still_fields() {
    if (still_path_.empty()) {
      fs::path p = doc_->path();
      still_path_ = (p.parent_path() / (p.stem().string() + "_still.png")).string();
    }
    ImGui::InputInt("width##still", &still_width_);
    remember("still.width");
    ImGui::InputInt("height##still", &still_height_);
    remember("still.height");
    still_width_ = std::clamp(still_width_, 1, 8192);
    still_height_ = std::clamp(still_height_, 1, 8192);
    ImGui::InputText("file##still", &still_path_);
    remember("still.path");
    ImGui::BeginDisabled(!prepared_ || !camera_);
    if (ImGui::Button("Render still") && prepared_ && camera_) {
      try {
        gl::FrameStats stats;
        const Image image =
            renderer_->render(*camera_, still_width_, still_height_, doc_->scene().render, &stats);
        write_png(still_path_, image);
        message_ = "wrote " + still_path_ + " (" + std::to_string(still_width_) + "x" +
                   std::to_string(still_height_) + ", " + std::to_string(int(stats.milliseconds)) +
                   " ms)";
        still_written_ = still_path_;
      } catch (const Error& e) {
        message_ = e.what();
      }
    }
    ImGui::EndDisabled();
    remember("still.render");
  }

  void panel(float height) {
    ImGui::SetNextWindowPos(ImVec2(0, 0));
    ImGui::SetNextWindowSize(ImVec2(kPanelWidth, height - kStatusHeight));
    ImGui::Begin("raywarp", nullptr,
                 ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse |
                     ImGuiWindowFlags_NoTitleBar);
    open_field();
    if (!shader_error_.empty()) {
      ImGui::PushStyleColor(ImGuiCol_Text, IM_COL32(255, 110, 100, 255));
      ImGui::TextWrapped("Shaders not reloaded: %s", shader_error_.c_str());
      ImGui::PopStyleColor();
    }
    ImGui::BeginDisabled(!doc_->can_undo());
    if (ImGui::Button("Undo")) undo();
    ImGui::EndDisabled();
    remember("undo");
    ImGui::SameLine();
    ImGui::BeginDisabled(!doc_->can_redo());
    if (ImGui::Button("Redo")) redo();
    ImGui::EndDisabled();
    remember("redo");
    ImGui::SameLine();
    if (ImGui::Button("Save")) save();
    remember("save");
    ImGui::SameLine();
    if (ImGui::Button("Frame")) frame_view();
    remember("frame");
    ImGui::SameLine();
    ImGui::Checkbox("Handles", &show_handles_);
    remember("handles");
    ImGui::Separator();

    json& boxes = working_["boxes"];
    const Scene& scene = doc_->scene();
    if (selected_ >= int(boxes.size())) selected_ = 0;
    for (size_t i = 0; i < boxes.size() && i < scene.boxes.size(); ++i) {
      const std::string name =
          "box " + std::to_string(i) + ": " + describe_spec(scene.boxes[i].deformer);
      if (ImGui::Selectable(name.c_str(), selected_ == int(i))) selected_ = int(i);
      remember("box." + std::to_string(i));
    }
    box_buttons(boxes);
    if (!boxes.empty() && selected_ < int(scene.boxes.size()) && selected_ < int(boxes.size())) {
      ImGui::Separator();
      json& box = boxes[selected_];
      const BoxSpec& spec = scene.boxes[selected_];
      for (const char* key : {"centre", "half_extents", "rotation_deg", "min", "max"}) {
        if (!box.contains(key) || !box[key].is_array() || box[key].size() != 3) continue;
        double v[3];
        for (int k = 0; k < 3; ++k) v[k] = box[key][k].get<double>();
        const double extent = std::max(1e-3, spec.box.half_extents.maxCoeff());
        if (ImGui::DragScalarN(key, ImGuiDataType_Double, v, 3,
                               std::string(key) == "rotation_deg" ? 0.5f : float(0.005 * extent),
                               nullptr, nullptr, "%.4g"))
          box[key] = {v[0], v[1], v[2]};
        remember(std::string("box.") + key);
      }
      json& d = box["deformer"];
      if (d.is_object()) {
        const DeformerType* type = find_deformer_type(d.value("type", ""));
        int current = 0;
        std::vector<const char*> names;
        for (size_t t = 0; t < deformer_types().size(); ++t) {
          names.push_back(deformer_types()[t].name.c_str());
          if (type == &deformer_types()[t]) current = int(t);
        }
        if (ImGui::Combo("deformer", &current, names.data(), int(names.size()))) {
          const DeformerType& chosen = deformer_types()[current];
          json fresh = chosen.examples.empty() ? json::object() : chosen.examples.front();
          fresh["type"] = chosen.name;
          d = fresh;
          if (!chosen.cuts)  // the scene reader refuses a cut's settings on other deformers
            for (const char* key : {"cut_mode", "shell_thickness", "alpha"}) box.erase(key);
          type = nullptr;  // its fields follow next frame, once parsed
        }
        remember("deformer");
        if (type) {
          deformer_fields(d, *type, spec.deformer, "param.");
          if (type->cuts) {
            const char* modes[] = {"hollow", "solid", "thick_shell"};
            int mode = spec.cut_mode == CutMode::Hollow  ? 0
                       : spec.cut_mode == CutMode::Solid ? 1
                                                         : 2;
            if (ImGui::Combo("cut_mode", &mode, modes, 3)) {
              box["cut_mode"] = modes[mode];
              if (mode == 2 && !box.contains("shell_thickness"))
                box["shell_thickness"] = 0.1 * spec.box.half_extents.minCoeff();
              if (mode != 2) box.erase("shell_thickness");
            }
            remember("cut_mode");
            if (spec.cut_mode == CutMode::ThickShell) {
              double tau = spec.shell_thickness;
              const double lo = 1e-4 * spec.box.half_extents.minCoeff(),
                           hi = spec.box.half_extents.minCoeff();
              if (ImGui::SliderScalar("shell_thickness", ImGuiDataType_Double, &tau, &lo, &hi,
                                      "%.4g", ImGuiSliderFlags_Logarithmic))
                box["shell_thickness"] = tau;
              remember("shell_thickness");
            }
          }
        }
        if (type && !type->cuts && ImGui::Button("Then add a deformer"))
          d = json::array({d, twist_example()});
        remember("then_add");
      } else if (d.is_array()) {
        deformer_list(d, spec);
      }
      texture_fields(
          box, spec,
          find_deformer_type(spec.deformer.type) && find_deformer_type(spec.deformer.type)->cuts);
    }
    ImGui::Separator();
    json& render = working_["render"];
    const char* methods[] = {"threshold", "linear", "jacobian", "bounded"};
    int method = 0;
    for (int m = 0; m < 4; ++m)
      if (sampling_name(scene.render.sampling) == std::string_view(methods[m])) method = m;
    if (ImGui::Combo("sampling", &method, methods, 4)) render["sampling"] = methods[method];
    remember("sampling");
    if (render.is_null()) working_.erase("render");
    ImGui::BeginDisabled(busy() || measuring_.valid());
    if (ImGui::Button(measuring_.valid() ? "Measuring..." : "Measure error")) measure_error();
    ImGui::EndDisabled();
    remember("measure");
    if (measured_ && measured_->error.empty()) {
      ImGui::TextWrapped(
          "State #%ld against the %s ground truth (%dx%d, %.1f s): IoU %.4f, %.2f %% of pixels "
          "over 1 %% of the diagonal in depth, mean depth error %.3f %%%s",
          measured_->generation, measured_->exact ? "exact" : "sampled", measured_->width,
          measured_->height, measured_->seconds, measured_->iou, measured_->over_pct,
          measured_->mean_depth_pct, measured_->generation == shown_ ? "" : " (an earlier state)");
      if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", measured_->kind.c_str());
    }
    ImGui::Separator();
    still_fields();
    ImGui::Separator();
    ImGui::TextWrapped(
        "Orbit: left drag. Pan: middle drag or Shift + left drag. Zoom: wheel or right drag. "
        "F: frame the mesh, Shift+F the box. Box handles (H shows or hides them): drag a face's "
        "dot to move that "
        "face, the white centre dot to move the box, a ring to rotate it; click another box's "
        "centre to select it. Ctrl+Z undo, Ctrl+Shift+Z redo, Ctrl+S save, Ctrl+Q quit. Drop a "
        "scene or mesh file to open it.");
    ImGui::End();
  }

  // Takes the panel's changes as one edit; the steps of one drag of a widget are one edit.
  void commit_edit() {
    const ImGuiID active = ImGui::GetActiveID();
    const bool viewport_drag = handle_drag_ || point_drag_;
    const bool dragging = active != 0 || (viewport_drag && !handle_released_);
    if (working_ != doc_->json()) {
      const bool merge =
          (active != 0 && active == last_edit_id_) || (viewport_drag && handle_edited_);
      if (viewport_drag) handle_edited_ = true;
      const std::string error = doc_->edit(working_, merge);
      if (error.empty()) {
        message_.clear();
        // A twist's angle shows at once through M; while it is dragged, the bake of the exact
        // angle waits for the drag's end.
        if (try_map() && dragging)
          unbaked_ = true;
        else if (dragging && submit_widened())
          unbaked_ = true;
        else
          submit();
      } else {
        message_ = error;
      }
      last_edit_id_ = active;
    }
    if (active == 0) last_edit_id_ = 0;
    // A drag that has made an edit and is still held (not a button pressed).
    held_drag_ = ImGui::IsMouseDown(0) &&
                 ((active != 0 && active == last_edit_id_) || (viewport_drag && !handle_released_));
    if (unbaked_ && !dragging) submit();
    if (handle_released_) {
      handle_drag_.reset();
      point_drag_.reset();
      handle_released_ = false;
    }
  }

  void status_bar(float width, float height) {
    ImGui::SetNextWindowPos(ImVec2(0, height - kStatusHeight));
    ImGui::SetNextWindowSize(ImVec2(width, kStatusHeight));
    ImGui::Begin("status", nullptr,
                 ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse |
                     ImGuiWindowFlags_NoTitleBar | ImGuiWindowFlags_NoScrollbar);
    const Baker::Progress p = baker_->progress();
    if (p.busy) {
      ImGui::ProgressBar(float(p.fraction), ImVec2(160, 0),
                         p.stage.empty() ? "baking" : p.stage.c_str());
      ImGui::SameLine();
    }
    ImGui::Text("frame %.1f ms | bake %.2f s | textures %.1f MiB%s%s%s", frame_ms_, bake_s_,
                texture_bytes_ / double(1 << 20), warnings_.empty() ? "" : " | ",
                warnings_.empty() ? "" : warnings_.front().c_str(),
                message_.empty() ? "" : (" | " + message_).c_str());
    ImGui::End();
  }

  // The window's title and the status file say where the editor is: "idle #N" once state N (the
  // count of states submitted) is on screen.
  void publish() {
    const bool is_busy = busy();
    json status = {{"state", is_busy ? "baking" : "idle"},
                   {"generation", generation_},
                   {"shown", shown_},
                   {"edits", doc_->edits()},
                   {"can_undo", doc_->can_undo()},
                   {"can_redo", doc_->can_redo()},
                   {"scene", doc_->path().string()},
                   {"saved", saved_},
                   {"still", still_written_},
                   {"message", message_},
                   {"frame_ms", frame_ms_},
                   {"bake_s", bake_s_},
                   {"texture_mib", texture_bytes_ / double(1 << 20)},
                   {"cancelled", baker_->cancelled()},
                   {"mapped", !mapped_.empty()},
                   {"shader_error", shader_error_},
                   {"shader_reloads", shader_reloads_},
                   {"mapped_edits", mapped_edits_},
                   {"bakes_shown", bakes_shown_},
                   {"active", active_},
                   {"viewport", {image_rect_.x, image_rect_.y, image_rect_.w, image_rect_.h}}};
    for (const auto& [name, r] : widgets_) status["widgets"][name] = {r.x, r.y, r.w, r.h};
    status["selected"] = selected_;
    status["show_handles"] = show_handles_;
    status["keys_held"] = std::vector<int>(held_keys().begin(), held_keys().end());
    status["mouse"] = {ImGui::GetIO().MousePos.x, ImGui::GetIO().MousePos.y};
    status["measuring"] = measuring_.valid();
    if (measured_)
      status["measured"] = {
          {"generation", measured_->generation}, {"iou", measured_->iou},
          {"over_pct", measured_->over_pct},     {"mean_depth_pct", measured_->mean_depth_pct},
          {"exact", measured_->exact},           {"kind", measured_->kind},
          {"seconds", measured_->seconds},       {"error", measured_->error}};
    status["open_path"] = open_path_;
    status["completions"] = completions_open_ ? completions_ : std::vector<std::string>();
    status["last_pick"] = last_pick_;
    if (const json& d = deformer_json(size_t(std::max(0, selected_)));
        d.is_object() && d.contains("points") && d["points"].is_array())
      for (const json& pt : d["points"]) {
        const auto from = point_of(pt.value("from", json())), to = point_of(pt.value("to", json()));
        const auto a = from ? view_mapping().project(*from) : std::nullopt;
        const auto b = to ? view_mapping().project(*to) : std::nullopt;
        if (a && b) status["points"].push_back({a->x(), a->y(), b->x(), b->y()});
      }
    if (const Box* box = selected_box())
      for (const PlacedHandle& h : place_handles(*box, view_mapping()))
        status["handles"][h.handle.name()] = {h.pixel.x(), h.pixel.y()};
    int wx = 0, wy = 0;
    glfwGetWindowPos(window_, &wx, &wy);
    status["window"] = {wx, wy};  // where window coordinates (all the rectangles) start on screen
    const std::string text = status.dump();
    if (text == published_) return;
    published_ = text;
    const std::string title = "raywarp edit: " + doc_->path().filename().string() + ": " +
                              (is_busy ? "baking" : "idle") + " #" + std::to_string(generation_);
    glfwSetWindowTitle(window_, title.c_str());
    if (!opt_.status_file.empty()) {
      try {
        write_file_atomic(opt_.status_file, text + "\n");
      } catch (const Error& e) {
        message_ = e.what();
      }
    }
  }
};

void glfw_error(int code, const char* text) {
  (void)code;
  (void)text;  // glfwInit's and glfwCreateWindow's failures are reported by their callers
}

}  // namespace

int run_editor(const EditOptions& options) {
  // A bad file is said before any window.
  Document document = Document::open(options.input, options.up_axis);
  if (!options.shader_dir.empty()) gl::read_shader_folder(options.shader_dir);
  glfwSetErrorCallback(glfw_error);
  if (!glfwInit())
    throw Error(
        "edit: cannot open a window: no display (is DISPLAY set? under no X server, run "
        "it in xvfb-run)");
  struct Terminate {
    ~Terminate() { glfwTerminate(); }
  } terminate;
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  GLFWwindow* window =
      glfwCreateWindow(options.width, options.height, "raywarp edit", nullptr, nullptr);
  if (!window) throw Error("edit: cannot make an OpenGL 4.5 core window on this display");
  glfwMakeContextCurrent(window);
  glfwSwapInterval(0);
  gl::load_gl([](const char* name) { return reinterpret_cast<void*>(glfwGetProcAddress(name)); });
  glfwSetKeyCallback(window, on_key);
  glfwSetDropCallback(window, on_drop);

  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini in the user's folder
  ImGui::StyleColorsDark();
  ImGui_ImplGlfw_InitForOpenGL(window, true);  // chains to the callbacks above
  ImGui_ImplOpenGL3_Init("#version 450");
  int code = 0;
  {
    Editor editor(options, window, std::move(document));
    while (!glfwWindowShouldClose(window)) {
      // While a bake runs, wake often for its progress; otherwise wait for input.
      if (editor.busy())
        glfwWaitEventsTimeout(0.03);
      else
        glfwWaitEventsTimeout(0.25);
      editor.frame();
    }
  }
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  glfwDestroyWindow(window);
  return code;
}

}  // namespace raywarp::editor
