// `raywarp edit` driven as a user drives it: a real X server (Xvfb), real mouse and key events
// (xdotool), screenshots of the screen (ImageMagick's import). The test waits on the state the
// editor publishes (--status-file: "idle" once state N is on screen), never on sleeps, and checks
// the viewport's pixels: dragging a box's face handle changes the deformed region, dragging the
// twist angle shows through the texture map M with no bake (and close to the exact bake that
// follows), undo restores the image, redo brings the edit back, and the saved scene renders
// through `raywarp render` to the viewport's image.
#include <gtest/gtest.h>
#include <signal.h>
#include <stb/stb_image.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "library/bake.h"
#include "library/scene.h"
#include "tests/temp_folder.h"

namespace raywarp {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

bool have(const char* program) {
  return std::system(("command -v " + std::string(program) + " > /dev/null 2>&1").c_str()) == 0;
}

// A child process started through sh, whose pid is its first line of output.
struct Child {
  pid_t pid = -1;
  FILE* out = nullptr;
  std::string first_line;
  explicit Child(const std::string& command) {
    out = popen(("sh -c 'echo $$; exec " + command + "'").c_str(), "r");
    if (!out) return;
    char line[64] = {};
    if (std::fgets(line, sizeof line, out)) pid = std::atoi(line);
  }
  bool running() {
    int status = 0;
    if (pid > 0 && waitpid(pid, &status, WNOHANG) == pid) pid = -1;
    return pid > 0;
  }
  std::string read_line() {
    char line[256] = {};
    return out && std::fgets(line, sizeof line, out) ? std::string(line) : std::string();
  }
  ~Child() {
    if (pid > 0) kill(pid, SIGTERM);
    if (out) pclose(out);
  }
};

struct Screenshot {
  int width = 0, height = 0;
  std::vector<unsigned char> rgb;
};

// The share of pixels of the rectangle [x, y, w, h] whose channels all lie within `tolerance`.
double share_within(const Screenshot& a, const Screenshot& b, const json& rect, int tolerance) {
  const int x0 = rect[0].get<int>(), y0 = rect[1].get<int>(), w = rect[2].get<int>(),
            h = rect[3].get<int>();
  long same = 0, total = 0;
  for (int y = y0; y < y0 + h; ++y)
    for (int x = x0; x < x0 + w; ++x) {
      bool near = true;
      for (int c = 0; c < 3; ++c) {
        const size_t i = (static_cast<size_t>(y) * a.width + x) * 3 + c;
        near = near && std::abs(int(a.rgb[i]) - int(b.rgb[i])) <= tolerance;
      }
      same += near;
      ++total;
    }
  return total ? double(same) / double(total) : 0.0;
}

Screenshot read_rgb(const fs::path& file) {
  Screenshot s;
  int channels = 0;
  unsigned char* data = stbi_load(file.c_str(), &s.width, &s.height, &channels, 3);
  if (data) {
    s.rgb.assign(data, data + static_cast<size_t>(s.width) * s.height * 3);
    stbi_image_free(data);
  }
  return s;
}

class EditorSession {
 public:
  explicit EditorSession(const fs::path& folder) : folder_(folder) {}

  bool start(const fs::path& scene, const std::string& options = "") {
    xvfb_ = std::make_unique<Child>(
        "Xvfb -displayfd 1 -screen 0 1280x800x24 -nolisten tcp 2>/dev/null");
    const std::string display = xvfb_->read_line();
    if (display.empty()) return false;
    display_ = std::string(":").append(std::to_string(std::atoi(display.c_str())));
    status_ = folder_ / "status.json";
    editor_ = std::make_unique<Child>(
        "env DISPLAY=" + display_ + " " + RAYWARP_BINARY + " edit " + scene.string() +
        " --width 1280 --height 800 --no-cache --status-file " + status_.string() +
        " --frame-log " + (folder_ / "frames.log").string() + " " + options + " > " +
        (folder_ / "editor.log").string() + " 2>&1");
    return editor_->pid > 0;
  }

  // Waits (polling the status file) until `ready` holds for it; at most `seconds`.
  json wait_for(const std::function<bool(const json&)>& ready, double seconds = 120) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    json last;
    while (std::chrono::steady_clock::now() < end) {
      if (!editor_->running()) {
        ADD_FAILURE() << "the editor exited; its log: " << log();
        return last;
      }
      std::ifstream in(status_);
      json s = json::parse(in, nullptr, false);
      if (!s.is_discarded()) {
        last = s;
        if (ready(s)) return s;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    ADD_FAILURE() << "the editor did not reach the state; last status: " << last.dump()
                  << "\nits log: " << log();
    return last;
  }

  // Idle with state number > after, and the next frame drawn (two publications apart).
  json wait_idle_after(long after) {
    return wait_for([after](const json& s) {
      return s.value("state", "") == "idle" && s.value("generation", 0L) > after &&
             s.value("shown", -1L) == s.value("generation", 0L);
    });
  }

  // Presses `key` (an X keysym name; `code` its GLFW key code), with `modifier` held, and
  // releases it once the window has seen it held: the panels read some keys (Enter, Tab, Ctrl+A
  // in a text field) as a state sampled once a frame, which a press and release in one frame miss.
  void tap(const std::string& key, int code, const std::string& modifier = "") {
    if (!modifier.empty()) xdotool("keydown " + modifier);
    xdotool("keydown " + key);
    wait_for([code](const json& st) {
      for (const json& k : st.value("keys_held", json::array()))
        if (k.get<int>() == code) return true;
      return false;
    });
    xdotool("keyup " + key);
    if (!modifier.empty()) xdotool("keyup " + modifier);
  }

  void xdotool(const std::string& args) {
    const std::string cmd = "DISPLAY=" + display_ + " xdotool " + args;
    EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  }

  // Into editor_test_images/ of the working folder, kept for a look.
  Screenshot screenshot(const std::string& name) {
    // The editor draws its frame after publishing the state: let one more frame through.
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    fs::create_directories("editor_test_images");
    const fs::path file = fs::absolute("editor_test_images") / (name + ".png");
    const std::string cmd =
        "import -display " + display_ + " -window root PNG24:" + file.string() + " 2>/dev/null";
    EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
    return read_rgb(file);
  }

  std::string log() const {
    std::ifstream in(folder_ / "editor.log");
    return std::string(std::istreambuf_iterator<char>(in), {});
  }

  void stop() { editor_.reset(); }

 private:
  fs::path folder_, status_;
  std::string display_;
  std::unique_ptr<Child> xvfb_, editor_;
};

// The widget's centre in screen coordinates.
std::string centre_of(const json& status, const std::string& widget, int dx = 0) {
  const json& r = status["widgets"][widget];
  const int x = status["window"][0].get<int>() + int(r[0].get<double>() + 0.5 * r[2].get<double>());
  const int y = status["window"][1].get<int>() + int(r[1].get<double>() + 0.5 * r[3].get<double>());
  return std::to_string(x + dx) + " " + std::to_string(y);
}

// A copy of examples/NAME in `dir` (scene.json), its mesh path made absolute and its camera file
// inlined, so that the copy renders as the example does.
fs::path copy_example(const std::string& name, const fs::path& dir) {
  const fs::path examples = fs::path(RAYWARP_SOURCE_DIR) / "examples";
  json scene = json::parse(std::ifstream(examples / name));
  scene["mesh"] = fs::absolute(examples / scene["mesh"].get<std::string>()).string();
  if (scene["camera"].is_string())
    scene["camera"] = json::parse(std::ifstream(examples / scene["camera"].get<std::string>()));
  const fs::path file = dir / "scene.json";
  std::ofstream(file) << scene.dump(2);
  return file;
}

class Editor : public TempFolderTest {};

// GLFW's key codes, as the status file's keys_held gives them.
constexpr int kKeyA = 65, kKeyEnter = 257, kKeyTab = 258;

TEST_F(Editor, DragUndoRedoSaveUnderXvfb) {
  for (const char* tool : {"Xvfb", "xdotool", "import"})
    ASSERT_TRUE(have(tool)) << tool
                            << " is not installed (scripts/setup.sh installs xvfb, "
                               "xdotool and imagemagick)";
  const fs::path file = copy_example("bunny_twist.json", dir_);

  EditorSession editor(dir_);
  ASSERT_TRUE(editor.start(file)) << "cannot start Xvfb or the editor";
  json s = editor.wait_idle_after(0);
  ASSERT_TRUE(s.contains("widgets")) << editor.log();
  const json viewport = s["viewport"];
  const Screenshot before = editor.screenshot("0_opened");
  ASSERT_GT(before.width, 0);

  // Drag the box's top face (its handle) up: one edit, whatever the number of steps.
  const long opened = s["generation"].get<long>();
  const int wx = s["window"][0].get<int>(), wy = s["window"][1].get<int>();
  const int fx = wx + int(s["handles"]["face+y"][0].get<double>()),
            fy = wy + int(s["handles"]["face+y"][1].get<double>());
  auto at = [](int x, int y) { return std::to_string(x) + " " + std::to_string(y); };
  // The press first, seen by the editor (the handle is held), then the moves: a loaded machine
  // must not fold the press and the moves into one frame, which would be a click.
  editor.xdotool("mousemove " + at(fx, fy));
  editor.xdotool("mousedown 1");
  editor.wait_for([](const json& st) { return st.value("active", "") == "handle.face+y"; });
  for (int step = 1; step <= 4; ++step) editor.xdotool("mousemove " + at(fx, fy - 10 * step));
  editor.xdotool("mouseup 1");
  s = editor.wait_idle_after(opened);
  EXPECT_EQ(s["edits"].get<int>(), 1);
  const Screenshot moved = editor.screenshot("1_face_moved");
  const double unmoved = share_within(before, moved, viewport, 2);
  std::printf("[figures] editor: dragging the top face changed %.2f %% of the viewport\n",
              100.0 * (1.0 - unmoved));
  EXPECT_LT(unmoved, 0.99) << "the deformed region did not change";

  // Drag the twist angle's field to the left. Its first step bakes the box at a wider angle;
  // every step after that is shown through the texture map M with no bake at all.
  editor.xdotool("mousemove " + centre_of(s, "param.angle_deg"));
  editor.xdotool("mousedown 1");
  editor.wait_for([](const json& st) { return st.value("active", "") == "param.angle_deg"; });
  editor.xdotool("mousemove " + centre_of(s, "param.angle_deg", -10));
  s = editor.wait_for([](const json& st) {
    return st.value("mapped", false) && st.value("shown", -1L) == st.value("generation", 0L);
  });
  const long mapped_edits = s["mapped_edits"].get<long>(), bakes = s["bakes_shown"].get<long>(),
             generation = s["generation"].get<long>();
  const Screenshot mapped_a = editor.screenshot("2_angle_mapped_a");
  for (int step = 1; step <= 4; ++step)
    editor.xdotool("mousemove " + centre_of(s, "param.angle_deg", -10 - 20 * step));
  // Every move seen (the mouse where the last one put it), and shown through M.
  const double last_x = s["widgets"]["param.angle_deg"][0].get<double>() +
                        0.5 * s["widgets"]["param.angle_deg"][2].get<double>() - 90.0;
  s = editor.wait_for([&](const json& st) {
    return st.value("mapped_edits", 0L) > mapped_edits && st.contains("mouse") &&
           std::abs(st["mouse"][0].get<double>() - int(last_x)) < 1.5;
  });
  const Screenshot mapped_b = editor.screenshot("2_angle_mapped_b");
  s = editor.wait_for([](const json&) { return true; });
  EXPECT_EQ(s["bakes_shown"].get<long>(), bakes) << "a bake was shown while the angle was dragged";
  EXPECT_EQ(s["generation"].get<long>(), generation) << "a bake was submitted during the drag";
  const double still_a = share_within(mapped_a, mapped_b, viewport, 2);
  std::printf(
      "[figures] editor: %ld angle steps shown through M with no bake changed %.2f %% "
      "of the viewport\n",
      s["mapped_edits"].get<long>() - mapped_edits, 100.0 * (1.0 - still_a));
  EXPECT_LT(still_a, 0.99) << "the angle's steps did not show";
  editor.xdotool("mouseup 1");
  // The drag's end bakes the exact angle: the image through M was close to it.
  s = editor.wait_idle_after(generation);
  EXPECT_EQ(s["edits"].get<int>(), 2);
  const Screenshot dragged = editor.screenshot("3_angle_baked");
  const double close = share_within(mapped_b, dragged, viewport, 8);
  std::printf(
      "[figures] editor: the image through M matches the exact bake in %.3f %% of the "
      "viewport within 8/255\n",
      100.0 * close);
  EXPECT_GE(close, 0.99);

  // Undo: the image before the angle's drag again.
  editor.xdotool("mousemove " + centre_of(s, "frame", 0) + " key ctrl+z");
  s = editor.wait_idle_after(s["generation"].get<long>());
  EXPECT_EQ(s["edits"].get<int>(), 1);
  const Screenshot undone = editor.screenshot("4_undone");
  const double restored = share_within(moved, undone, viewport, 2);
  std::printf("[figures] editor: undo restored %.4f %% of the viewport within 2/255\n",
              100.0 * restored);
  EXPECT_GE(restored, 0.999);

  // Redo: the edit again.
  editor.xdotool("key ctrl+shift+z");
  s = editor.wait_idle_after(s["generation"].get<long>());
  EXPECT_EQ(s["edits"].get<int>(), 2);
  const Screenshot redone_with_handles = editor.screenshot("5_redone");
  EXPECT_GE(share_within(dragged, redone_with_handles, viewport, 2), 0.999);

  // The error against the exact ground truth, on request, measured in the background.
  editor.xdotool("mousemove " + centre_of(s, "measure"));
  editor.xdotool("mousedown 1");
  editor.wait_for([](const json& st) { return st.value("active", "") == "measure"; });
  editor.xdotool("mouseup 1");
  const long shown = s["shown"].get<long>();
  s = editor.wait_for([&](const json& st) {
    return st.contains("measured") && st["measured"].value("generation", 0L) == shown;
  });
  const json measured = s["measured"];
  std::printf(
      "[figures] editor: against the exact ground truth IoU %.4f, %.2f %% of pixels over "
      "1 %% of the diagonal, measured in %.2f s\n",
      measured.value("iou", 0.0), measured.value("over_pct", 100.0),
      measured.value("seconds", 0.0));
  EXPECT_EQ(measured.value("error", "?"), "");
  EXPECT_TRUE(measured.value("exact", false));
  EXPECT_GE(measured.value("iou", 0.0), 0.99);
  EXPECT_LT(measured.value("over_pct", 100.0), 2.0);

  // Hide the handles (H): the viewport is then the renderer's image alone.
  editor.xdotool("key h");
  s = editor.wait_for([](const json& st) { return !st.value("show_handles", true); });
  const Screenshot redone = editor.screenshot("6_no_handles");

  // Save, then render the saved scene through the command line at the viewport's size.
  editor.xdotool("key ctrl+s");
  s = editor.wait_for([](const json& st) { return !st.value("saved", "").empty(); }, 30);
  const fs::path rendered = dir_ / "rendered.png";
  const std::string cmd = std::string(RAYWARP_BINARY) + " render " + file.string() + " -o " +
                          rendered.string() + " --no-cache > /dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const Screenshot cli = read_rgb(rendered);
  ASSERT_EQ(cli.width, viewport[2].get<int>());
  ASSERT_EQ(cli.height, viewport[3].get<int>());
  // The command line's image against the viewport's pixels of the last screenshot.
  Screenshot crop;
  crop.width = cli.width;
  crop.height = cli.height;
  const int x0 = s["window"][0].get<int>() + viewport[0].get<int>(),
            y0 = s["window"][1].get<int>() + viewport[1].get<int>();
  for (int y = 0; y < cli.height; ++y)
    for (int x = 0; x < cli.width; ++x)
      for (int c = 0; c < 3; ++c)
        crop.rgb.push_back(
            redone.rgb[(static_cast<size_t>(y0 + y) * redone.width + x0 + x) * 3 + c]);
  const double same = share_within(cli, crop, json::array({0, 0, cli.width, cli.height}), 2);
  std::printf("[figures] editor: the saved scene renders %.4f %% of the viewport within 2/255\n",
              100.0 * same);
  EXPECT_GE(same, 0.999);

  // A still at 320x200, typed into the fields: the command line renders the saved scene at that
  // size to the same image.
  for (const auto& [field, value] : {std::pair{"still.width", "320"}, {"still.height", "200"}}) {
    editor.xdotool("mousemove " + centre_of(s, field));
    editor.xdotool("mousedown 1");
    editor.wait_for([&](const json& st) { return st.value("active", "") == field; });
    editor.xdotool("mouseup 1");
    editor.tap("a", kKeyA, "ctrl");
    editor.xdotool(std::string("type ") + value);
    editor.tap("Return", kKeyEnter);
  }
  editor.xdotool("mousemove " + centre_of(s, "still.render"));
  editor.xdotool("mousedown 1");
  editor.wait_for([](const json& st) { return st.value("active", "") == "still.render"; });
  editor.xdotool("mouseup 1");
  s = editor.wait_for([](const json& st) { return !st.value("still", "").empty(); }, 60);
  const Screenshot still = read_rgb(s.value("still", ""));
  const fs::path small = dir_ / "small.png";
  const std::string small_cmd = std::string(RAYWARP_BINARY) + " render " + file.string() + " -o " +
                                small.string() +
                                " --width 320 --height 200 --no-cache > /dev/null 2>&1";
  ASSERT_EQ(std::system(small_cmd.c_str()), 0) << small_cmd;
  const Screenshot cli_small = read_rgb(small);
  ASSERT_EQ(still.width, 320);
  ASSERT_EQ(still.height, 200);
  ASSERT_EQ(cli_small.width, 320);
  const double still_same = share_within(still, cli_small, json::array({0, 0, 320, 200}), 2);
  std::printf(
      "[figures] editor: the 320x200 still matches the command line's in %.4f %% of its "
      "pixels within 2/255\n",
      100.0 * still_same);
  EXPECT_GE(still_same, 0.999);

  // A box over the first one: the scene reader refuses it in the status line; nothing changes.
  const long saved_generation = s["generation"].get<long>();
  editor.xdotool("mousemove " + centre_of(s, "add_box"));
  editor.xdotool("mousedown 1");
  editor.wait_for([](const json& st) { return st.value("active", "") == "add_box"; });
  editor.xdotool("mouseup 1");
  s = editor.wait_for(
      [](const json& st) { return st.value("message", "").find("overlaps") != std::string::npos; });
  EXPECT_EQ(s["generation"].get<long>(), saved_generation);
  EXPECT_EQ(s["edits"].get<int>(), 2);

  // Shift+F frames the selected box: its centre comes to the middle of the viewport.
  // A status published while the box's handles are not laid out (no "centre" yet) is not framed.
  auto off_centre = [](const json& st) {
    if (!st.contains("handles") || !st["handles"].is_object() ||
        !st["handles"].contains("centre") || !st.contains("viewport") ||
        !st["viewport"].is_array() || st["viewport"].size() < 4)
      return 1e9;
    const json &c = st["handles"]["centre"], &v = st["viewport"];
    return std::hypot(c[0].get<double>() - (v[0].get<double>() + 0.5 * v[2].get<double>()),
                      c[1].get<double>() - (v[1].get<double>() + 0.5 * v[3].get<double>()));
  };
  const double before_framing = off_centre(s);
  editor.xdotool("key shift+f");
  s = editor.wait_for([&](const json& st) { return off_centre(st) < 1.0; });
  std::printf(
      "[figures] editor: Shift+F brought the box's centre from %.1f to %.2f pixels off the "
      "viewport's middle\n",
      before_framing, off_centre(s));
  editor.xdotool("key ctrl+q");
  editor.stop();
}

// Control points picked on the deformed surface: Ctrl + click adds a point whose source is the
// point of the undeformed mesh that shows there (p' + D(p'), p' from the depth image), checked
// against the deformer's exact forward map, and dragging moves its target; undo removes it.
TEST_F(Editor, AControlPointIsPickedOnTheDeformedSurfaceAndDragged) {
  for (const char* tool : {"Xvfb", "xdotool", "import"}) ASSERT_TRUE(have(tool)) << tool;
  const fs::path file = copy_example("bunny_control_points.json", dir_);
  const Scene before_scene = load_scene(file);
  const auto deformer = make_deformer(before_scene, 0);
  const Box& box = before_scene.boxes[0].box;

  EditorSession editor(dir_);
  ASSERT_TRUE(editor.start(file));
  json s = editor.wait_idle_after(0);
  ASSERT_EQ(s["points"].size(), 2u);
  const json viewport = s["viewport"];
  const Screenshot before = editor.screenshot("points_0_opened");
  // Below the box's centre: the first run of 12 pixels of the bunny's body (not the white
  // background), in the deformed part.
  const int wx = s["window"][0].get<int>(), wy = s["window"][1].get<int>();
  const int cx = wx + int(s["handles"]["centre"][0].get<double>());
  int cy = wy + int(s["handles"]["centre"][1].get<double>()) + 10, run = 0;
  for (; cy < before.height && run < 12; ++cy) {
    const unsigned char* px = &before.rgb[(static_cast<size_t>(cy) * before.width + cx) * 3];
    run = (px[0] < 240 || px[1] < 240 || px[2] < 240) ? run + 1 : 0;
  }
  ASSERT_EQ(run, 12) << "no surface below the box's centre";
  auto at = [](int x, int y) { return std::to_string(x) + " " + std::to_string(y); };
  editor.xdotool("mousemove " + at(cx, cy));
  editor.xdotool("keydown ctrl");
  editor.xdotool("mousedown 1");
  editor.wait_for([](const json& st) { return st.value("active", "") == "point.2"; });
  for (int step = 1; step <= 4; ++step)
    editor.xdotool("mousemove " + at(cx - 4 * step, cy - 10 * step));
  editor.xdotool("mouseup 1");
  editor.xdotool("keyup ctrl");
  s = editor.wait_idle_after(s["generation"].get<long>());
  EXPECT_EQ(s["edits"].get<int>(), 1);
  ASSERT_EQ(s["points"].size(), 3u);
  const json& pick = s["last_pick"];
  ASSERT_TRUE(pick.contains("source")) << s.dump();
  auto vec = [](const json& j) {
    return Eigen::Vector3d(j[0].get<double>(), j[1].get<double>(), j[2].get<double>());
  };
  const Eigen::Vector3d source = vec(pick["source"]), deformed = vec(pick["deformed"]);
  EXPECT_TRUE(box.contains(source));
  // The exact forward map of the scene as it was takes the source to the picked point.
  const Eigen::Vector3d mapped = box.to_object(deformer->forward(box.to_local(source)));
  const double error = (mapped - deformed).norm() / box.diagonal();
  std::printf(
      "[figures] editor: the picked source maps to the picked point within %.4f %% of the "
      "box diagonal\n",
      100.0 * error);
  EXPECT_LT(error, 0.005);
  const Screenshot dragged = editor.screenshot("points_1_dragged");
  EXPECT_LT(share_within(before, dragged, viewport, 2), 0.995) << "the surface did not move";

  editor.xdotool("key ctrl+z");
  s = editor.wait_idle_after(s["generation"].get<long>());
  EXPECT_EQ(s["points"].size(), 2u);
  EXPECT_EQ(s["edits"].get<int>(), 0);

  // The Open field: Tab completes a typed path, Enter opens it; a file that does not load is
  // said in the status line and the scene stays.
  auto type_path = [&](const std::string& text) {
    editor.xdotool("mousemove " + centre_of(s, "open.path"));
    editor.xdotool("mousedown 1");
    editor.wait_for([](const json& st) { return st.value("active", "") == "open.path"; });
    editor.xdotool("mouseup 1");
    editor.tap("a", kKeyA, "ctrl");
    editor.xdotool("type '" + text + "'");
  };
  type_path((dir_ / "sce").string());
  editor.tap("Tab", kKeyTab);
  s = editor.wait_for([&](const json& st) { return st.value("open_path", "") == file.string(); });
  EXPECT_FALSE(s["completions"].empty());
  editor.tap("Return", kKeyEnter);
  s = editor.wait_for([&](const json& st) {
    return st.value("message", "") == "opened " + file.string() && st.value("state", "") == "idle";
  });
  EXPECT_EQ(s["scene"].get<std::string>(), file.string());
  type_path((dir_ / "missing.ply").string());
  editor.tap("Return", kKeyEnter);
  s = editor.wait_for([](const json& st) {
    return st.value("message", "").find("missing.ply") != std::string::npos;
  });
  EXPECT_EQ(s["scene"].get<std::string>(), file.string());
  editor.xdotool("key ctrl+q");
  editor.stop();
}

// --shader-dir: the editor reads the shaders from a folder and reloads them when a file changes.
// A file that does not compile is reported in the window with its file and line, the last good
// shaders keep drawing, and the fixed file is taken.
TEST_F(Editor, ShaderFolderReloadsAndShowsCompileErrorsWithFileAndLine) {
  for (const char* tool : {"Xvfb", "import"}) ASSERT_TRUE(have(tool)) << tool;
  const fs::path file = copy_example("bunny_twist.json", dir_);
  const fs::path shaders = dir_ / "shaders";
  fs::copy(fs::path(RAYWARP_SOURCE_DIR) / "shaders", shaders);
  const fs::path shading = shaders / "shading.glsl";
  const std::string original = [&] {
    std::ifstream in(shading);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }();
  const std::string lit = "0.2 + 0.8 * lambert";
  const size_t at = original.find(lit);
  ASSERT_NE(at, std::string::npos) << "shading.glsl has changed: update the test";
  const long line = 1 + std::count(original.begin(), original.begin() + long(at), '\n');
  auto write_shading = [&](const std::string& replacement) {
    std::string text = original;
    text.replace(at, lit.size(), replacement);
    std::ofstream(shading, std::ios::trunc) << text;
  };

  EditorSession editor(dir_);
  ASSERT_TRUE(editor.start(file, "--shader-dir " + shaders.string()));
  json s = editor.wait_idle_after(0);
  EXPECT_EQ(s.value("shader_reloads", 0L), 1);
  EXPECT_EQ(s.value("shader_error", "?"), "");
  editor.xdotool("key h");
  s = editor.wait_for([](const json& st) { return !st.value("show_handles", true); });
  const json viewport = s["viewport"];
  const Screenshot good = editor.screenshot("shaders_0_read");

  write_shading(lit + " +");  // a syntax error
  s = editor.wait_for([](const json& st) { return !st.value("shader_error", "").empty(); }, 60);
  const std::string error = s.value("shader_error", "");
  std::printf("[figures] editor: the broken shader is reported as: %s\n", error.c_str());
  EXPECT_NE(error.find("shading.glsl:" + std::to_string(line)), std::string::npos) << error;
  const Screenshot broken = editor.screenshot("shaders_1_broken");
  EXPECT_GE(share_within(good, broken, viewport, 2), 0.999) << "the last good shaders stopped";

  write_shading("0.5 + 0.5 * lambert");  // brighter
  s = editor.wait_for(
      [](const json& st) {
        return st.value("shader_error", "?").empty() && st.value("shader_reloads", 0L) == 2;
      },
      60);
  const Screenshot brighter = editor.screenshot("shaders_2_fixed");
  const double same = share_within(good, brighter, viewport, 2);
  std::printf("[figures] editor: the reloaded shading changed %.2f %% of the viewport\n",
              100.0 * (1.0 - same));
  EXPECT_LT(same, 0.9);
  editor.xdotool("key ctrl+q");
  editor.stop();
}

TEST_F(Editor, BadInputOrNoDisplayIsAnErrorWithStatus2) {
  const std::string bin = RAYWARP_BINARY;
  std::ofstream(path("broken.json")) << "{\"mesh\": 3}";
  const std::string bad =
      "DISPLAY= " + bin + " edit " + path("broken.json") + " 2> " + path("a.txt");
  int status = std::system(bad.c_str());
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 2) << bad;
  std::ifstream a(path("a.txt"));
  const std::string said((std::istreambuf_iterator<char>(a)), {});
  EXPECT_NE(said.find("broken.json"), std::string::npos) << said;
  EXPECT_NE(said.find("mesh"), std::string::npos) << said;

  const fs::path scene = fs::path(RAYWARP_SOURCE_DIR) / "examples" / "bunny_twist.json";
  const std::string no_shaders = "DISPLAY= " + bin + " edit " + scene.string() + " --shader-dir " +
                                 path("nowhere") + " 2> " + path("c.txt");
  status = std::system(no_shaders.c_str());
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 2) << no_shaders;
  std::ifstream c(path("c.txt"));
  const std::string said_c((std::istreambuf_iterator<char>(c)), {});
  EXPECT_NE(said_c.find("nowhere"), std::string::npos) << said_c;

  const std::string headless = "env -u DISPLAY -u WAYLAND_DISPLAY " + bin + " edit " +
                               scene.string() + " 2> " + path("b.txt");
  status = std::system(headless.c_str());
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 2) << headless;
  std::ifstream b(path("b.txt"));
  const std::string said_b((std::istreambuf_iterator<char>(b)), {});
  EXPECT_NE(said_b.find("no display"), std::string::npos) << said_b;
}

}  // namespace
}  // namespace raywarp
