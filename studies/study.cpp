#include "studies/study.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <ostream>
#include <sstream>
#include <thread>
#include <unordered_map>

#include "base/error.h"
#include "base/format.h"
#include "deformers/box_cut.h"
#include "gl/frame_timing.h"
#include "gl/renderer.h"
#include "library/image.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "studies/chart.h"
#include "verify/ground_truth.h"
#include "verify/reference.h"

namespace raywarp {

namespace {

// One point of the sweep.
struct Point {
  std::string method = "linear";
  double step = 0.5, fine = 0.25, threshold = 2.0, epsilon = 0.02;
  int refine = 8;
  double resolution_scale = 1.0;  // of the scene's distance grid and deformation resolutions
  double band = 0;                // narrow band, voxels (0: the scene's)
  int bits = 32;
  int levels = -1;  // object-space subdivision levels
};

// The sweep: about ten points per method around the scene's own settings. Cuts have no bounded
// tracer (D jumps) and no object-space peer (a mapped mesh cannot open); a deformer that moves
// nothing reads no D, so jacobian is linear there.
std::vector<Point> sweep(bool continuous, bool moves_nothing, bool quick) {
  std::vector<Point> points;
  auto add = [&](Point p) { points.push_back(p); };
  auto with = [](std::string method, double step) {
    Point p;
    p.method = std::move(method);
    p.step = step;
    return p;
  };
  if (quick) {
    add(with("linear", 0.5));
    add(with("linear", 2.0));
    add(with("threshold", 2.0));
    if (!moves_nothing) add(with("jacobian", 1.0));
    if (continuous) {
      add(with("bounded", 0));
      Point o = with("object-space", 0);
      o.levels = 1;
      add(o);
    }
    return points;
  }
  for (double s : {0.25, 0.5, 1.0, 2.0, 3.0}) add(with("linear", s));
  for (int r : {0, 4}) {
    Point p = with("linear", 0.5);
    p.refine = r;
    add(p);
  }
  for (double scale : {0.5, 1.5}) {
    Point p = with("linear", 0.5);
    p.resolution_scale = scale;
    add(p);
  }
  {
    Point p = with("linear", 0.5);
    p.bits = 16;
    add(p);
  }
  {  // the default sampling on the smallest textures of the sweep
    Point p = with("threshold", 4.0);
    p.fine = 0.125;
    p.resolution_scale = 0.5;
    p.bits = 16;
    add(p);
  }
  for (double s : {1.0, 2.0, 3.0, 4.0, 6.0}) add(with("threshold", s));
  for (double s : {6.0, 8.0}) {  // the fine step at 0.5 voxel, as the default's
    Point p = with("threshold", s);
    p.fine = 0.5 / s;
    add(p);
  }
  {
    Point p = with("threshold", 4.0);
    p.fine = 0.125;
    add(p);
    p = with("threshold", 3.0);
    p.threshold = 3.0;
    add(p);
    p = with("threshold", 2.0);
    p.resolution_scale = 0.5;
    add(p);
    p = with("threshold", 2.0);
    p.bits = 16;
    add(p);
  }
  if (!moves_nothing) {
    for (double s : {0.25, 0.5, 1.0, 2.0, 3.0}) add(with("jacobian", s));
    Point p = with("jacobian", 1.0);
    p.resolution_scale = 0.5;
    add(p);
    p = with("jacobian", 1.0);
    p.bits = 16;
    add(p);
  }
  if (continuous) {
    for (double band : {3.0, 8.0})
      for (double e : {0.02, 0.1, 0.3}) {
        Point p = with("bounded", 0);
        p.band = band;
        p.epsilon = e;
        add(p);
      }
    Point p = with("bounded", 0);
    p.band = 16;
    p.epsilon = 0.1;
    add(p);
    p = with("bounded", 0);
    p.band = 8;
    p.epsilon = 0.1;
    p.resolution_scale = 0.5;
    add(p);
    for (int levels = 0; levels <= 4; ++levels) {
      Point o = with("object-space", 0);
      o.levels = levels;
      add(o);
    }
  }
  return points;
}

// Each triangle split into four at its edges' midpoints (shared, so no cracks), `levels` times.
Mesh subdivide(const Mesh& mesh, int levels) {
  Mesh m = mesh;
  for (int l = 0; l < levels; ++l) {
    std::unordered_map<uint64_t, int> mid;
    std::vector<Eigen::Vector3d> v;
    v.reserve(m.V.rows() * 4);
    for (Eigen::Index i = 0; i < m.V.rows(); ++i) v.push_back(m.V.row(i).transpose());
    auto midpoint = [&](int a, int b) {
      const uint64_t key = (uint64_t(std::min(a, b)) << 32) | uint64_t(std::max(a, b));
      auto [it, inserted] = mid.emplace(key, static_cast<int>(v.size()));
      if (inserted) v.push_back(0.5 * (v[a] + v[b]));
      return it->second;
    };
    Mesh next;
    next.F.resize(m.F.rows() * 4, 3);
    for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
      const int a = m.F(f, 0), b = m.F(f, 1), c = m.F(f, 2);
      const int ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      next.F.row(4 * f) << a, ab, ca;
      next.F.row(4 * f + 1) << ab, b, bc;
      next.F.row(4 * f + 2) << ca, bc, c;
      next.F.row(4 * f + 3) << ab, bc, ca;
    }
    next.V.resize(static_cast<Eigen::Index>(v.size()), 3);
    for (size_t i = 0; i < v.size(); ++i) next.V.row(static_cast<Eigen::Index>(i)) = v[i];
    m = std::move(next);
  }
  return m;
}

// The object-space peer: vertices inside a box moved by its exact forward map.
Mesh object_space_mesh(const PreparedScene& prepared, int levels) {
  Mesh m = subdivide(prepared.mesh(), levels);
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    Eigen::Vector3d p = m.V.row(i).transpose();
    for (const BakedBox& b : prepared.boxes) {
      const Box& box = b.textures.box;
      const Eigen::Vector3d q = box.to_local(p);
      if (box.contains_local(q)) {
        p = box.to_object(b.deformer->forward(q));
        break;
      }
    }
    m.V.row(i) = p.transpose();
  }
  return m;
}

// Of the pixels `reference` covers, the fraction `image` leaves empty.
double missed_of(const Image& image, const Image& reference) {
  long covered = 0, missed = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      if (reference.covered(x, y)) {
        ++covered;
        if (!image.covered(x, y)) ++missed;
      }
  return covered ? double(missed) / covered : 0.0;
}

struct Measure {
  ImageComparison c;
  double missed = 0;
};

Measure measure(const Image& image, const Truth& truth) {
  Measure m;
  m.c = compare_images(image, truth.image, 0.01 * truth.diagonal);
  m.missed = missed_of(image, truth.image);
  return m;
}

// The object-space peer stops subdividing beyond this many triangles (about 0.3 GiB of CPU and
// GPU buffers at the top level).
constexpr long kMaxObjectSpaceTriangles = 4'000'000;

// Equal error allows this much more of the ground truth's pixels missed (a few pixels at 256²).
constexpr double kMissedTolerance = 0.0002;

bool acceptable(const StudyRun& r) { return r.fraction_over <= 0.01 && r.iou >= 0.98; }

// The bounded tracer's step budget in the study: near-grazing rays need many short steps.
constexpr int kBoundedMaxSteps = 4096;

// A scene box with a point's resolutions (scaled, within the scene format's minimums) and band.
BoxSpec scaled_box(BoxSpec b, const Point& p) {
  // An automatic resolution is resolved before the sweep (run_study), on the scene's own bake.
  if (b.implicit.resolution != kAutoResolution)
    b.implicit.resolution =
        std::max(8, int(std::lround(b.implicit.resolution * p.resolution_scale)));
  // An automatic layout follows the scaled grid's voxel by itself.
  if (b.deformation_resolution != kAutoResolution)
    b.deformation_resolution =
        std::max(4, int(std::lround(b.deformation_resolution * p.resolution_scale)));
  if (p.band > 0) b.implicit.band_voxels = p.band;
  return b;
}

std::string describe_point(const Point& p, const BoxSpec& base) {
  const BoxSpec scaled = scaled_box(base, p);
  const int sdf = scaled.implicit.resolution, def = scaled.deformation_resolution;
  std::string s;
  if (p.method == "object-space") return "subdivision " + std::to_string(p.levels);
  if (p.method == "bounded")
    s = "epsilon " + fmt("%g", p.epsilon) + ", band " +
        fmt("%g", p.band > 0 ? p.band : base.implicit.band_voxels);
  else
    s = "step " + fmt("%g", p.step);
  if (p.method == "threshold")
    s += ", fine " + fmt("%.3g", p.fine) + " within " + fmt("%g", p.threshold);
  if (p.method != "bounded") s += ", refine " + std::to_string(p.refine);
  s += ", SDF " + std::to_string(sdf) + ", D " +
       (def == kAutoResolution ? std::string("auto") : std::to_string(def)) + ", " +
       std::to_string(p.bits) + "-bit";
  return s;
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      auto colon = line.find(':');
      if (colon != std::string::npos) return line.substr(colon + 2);
    }
  return "unknown CPU";
}

struct Goal {
  std::string scene;
  double ms = 0, over = 0, iou = 0, missed = 0;
  size_t texture_bytes = 0;
  std::string settings;
};

void write_csv(const std::filesystem::path& path, const std::vector<StudyRun>& runs) {
  std::ostringstream o;
  o << "scene,method,settings,step_voxels,refine_steps,fine_factor,threshold_voxels,"
       "hit_epsilon_voxels,sdf_resolution,deformation_resolution,band_voxels,texture_bits,"
       "subdivision_levels,triangles,ms,iou,mean_depth_error,max_depth_error,fraction_over,"
       "fraction_missed,fraction_missed_vs_bounded,memory_bytes\n";
  for (const StudyRun& r : runs)
    o << csv_field(r.scene) << ',' << r.method << ',' << csv_field(r.settings) << ','
      << r.step_voxels << ',' << r.refine_steps << ',' << r.fine_factor << ',' << r.threshold_voxels
      << ',' << r.hit_epsilon_voxels << ',' << r.sdf_resolution << ',' << r.deformation_resolution
      << ',' << r.band_voxels << ',' << r.texture_bits << ',' << r.subdivision_levels << ','
      << r.triangles << ',' << r.ms << ',' << r.iou << ',' << r.mean_depth_error << ','
      << r.max_depth_error << ',' << r.fraction_over << ',' << r.fraction_missed << ','
      << r.fraction_missed_vs_bounded << ',' << r.memory_bytes << '\n';
  const std::string text = o.str();
  write_file_atomic(path.string(), text.data(), text.size());
}

const char* kMethods[] = {"linear", "threshold", "jacobian", "bounded", "object-space"};

// The floor of the chart's error axis: runs with no pixel over are drawn there.
constexpr double kChartFloor = 1e-5;

// Error against frame time, one log-log panel per scene, one colour per method, the scene's
// Pareto front (study_front) in black.
void write_chart(const std::filesystem::path& path, const std::vector<std::string>& scenes,
                 const std::vector<StudyRun>& runs) {
  chart::Chart c;
  c.title = "Error against frame time";
  c.columns = scenes.size() > 1 ? 2 : 1;
  c.panel_width = 560;
  c.panel_height = 400;
  for (const std::string& scene : scenes) {
    chart::Panel panel;
    panel.title = scene;
    panel.x_label = "frame ms (median)";
    panel.y_label = "pixels over 1 % of diag";
    panel.y_floor = kChartFloor;
    std::vector<StudyRun> mine;
    for (const StudyRun& r : runs)
      if (r.scene == scene) mine.push_back(r);
    for (const char* method : kMethods) {
      chart::Series s;
      s.name = method;
      for (const StudyRun& r : mine)
        if (r.method == method) {
          s.x.push_back(r.ms);
          s.y.push_back(r.fraction_over);  // 0 is drawn on the floor
        }
      if (!s.x.empty()) panel.series.push_back(s);
    }
    for (size_t i : study_front(mine)) panel.front.emplace_back(mine[i].ms, mine[i].fraction_over);
    c.panels.push_back(panel);
  }
  chart::write_svg(path.string(), c);
}

std::string mib(size_t bytes) { return fmt("%.2f", bytes / double(1 << 20)); }
std::string pct(double f) { return fmt("%.2f", 100.0 * f); }

}  // namespace

std::vector<size_t> study_front(const std::vector<StudyRun>& runs) {
  std::vector<double> x, y;
  for (const StudyRun& r : runs) {
    x.push_back(r.ms);
    y.push_back(r.fraction_over);
  }
  return chart::pareto_front(x, y);
}

namespace {

// The records of a CSV text, as csv_field writes them: a field holding a comma, a quote or a
// newline is quoted, a quote inside doubled; an unquoted newline ends a record.
std::vector<std::vector<std::string>> parse_csv(const std::string& text) {
  std::vector<std::vector<std::string>> records;
  std::vector<std::string> record;
  std::string field;
  bool quoted = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (quoted) {
      if (c != '"')
        field += c;
      else if (i + 1 < text.size() && text[i + 1] == '"')
        field += '"', ++i;
      else
        quoted = false;
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',' || c == '\n') {
      record.push_back(std::move(field));
      field.clear();
      if (c == '\n') records.push_back(std::move(record)), record.clear();
    } else if (c != '\r') {
      field += c;
    }
  }
  if (!field.empty() || !record.empty())
    records.push_back(std::move(record)), records.back().push_back(field);
  return records;
}

}  // namespace

void write_study_chart_from_csv(const std::filesystem::path& csv,
                                const std::filesystem::path& svg) {
  std::ifstream in(csv, std::ios::binary);
  if (!in) throw Error(csv.string() + ": cannot read");
  std::ostringstream text;
  text << in.rdbuf();
  const std::vector<std::vector<std::string>> records = parse_csv(text.str());
  if (records.empty()) throw Error(csv.string() + ": empty, expected study.csv's header");
  const std::vector<std::string>& header = records[0];
  auto column = [&](const std::string& name) {
    const auto it = std::find(header.begin(), header.end(), name);
    if (it == header.end())
      throw Error(csv.string() + ": no column '" + name + "' in the header (not a study.csv?)");
    return static_cast<size_t>(it - header.begin());
  };
  const size_t scene = column("scene"), method = column("method"), ms = column("ms"),
               over = column("fraction_over");
  const size_t needed = std::max({scene, method, ms, over}) + 1;
  std::vector<std::string> scenes;
  std::vector<StudyRun> runs;
  for (size_t i = 1; i < records.size(); ++i) {
    const std::vector<std::string>& f = records[i];
    if (f.size() == 1 && f[0].empty()) continue;  // a blank line
    const std::string where = csv.string() + ": record " + std::to_string(i + 1);
    if (f.size() < needed)
      throw Error(where + ": " + std::to_string(f.size()) + " fields, expected at least " +
                  std::to_string(needed));
    auto number = [&](size_t k) {
      char* end = nullptr;
      const double v = std::strtod(f[k].c_str(), &end);
      if (f[k].empty() || *end != '\0')
        throw Error(where + ": " + header[k] + " '" + f[k] + "': not a number");
      return v;
    };
    StudyRun r;
    r.scene = f[scene];
    r.method = f[method];
    r.ms = number(ms);
    r.fraction_over = number(over);
    if (std::find(scenes.begin(), scenes.end(), r.scene) == scenes.end()) scenes.push_back(r.scene);
    runs.push_back(r);
  }
  write_chart(svg, scenes, runs);
}

namespace {

// Linear at 0.5 voxel, refine 8, the scene's resolutions, 32-bit: how the paper samples.
const StudyRun* paper_linear_run(const std::vector<StudyRun>& runs, const std::string& scene) {
  for (const StudyRun& r : runs)
    if (r.scene == scene && r.method == "linear" && r.step_voxels == kFineStepVoxels &&
        r.refine_steps == 8 && r.texture_bits == 32)
      return &r;  // the first such run of the sweep has the scene's own resolutions
  return nullptr;
}

// The fastest run of `scene` (of `method`, or of any image-space method when empty) whose error
// is no worse than `target`'s: no more pixels over, an IoU at most 0.001 lower, at most
// kMissedTolerance more of the ground truth's pixels missed.
const StudyRun* fastest_at(const std::vector<StudyRun>& runs, const std::string& scene,
                           const StudyRun& target, bool object_space,
                           const std::string& method = "") {
  const StudyRun* fastest = nullptr;
  for (const StudyRun& r : runs) {
    if (r.scene != scene || (r.method == "object-space") != object_space) continue;
    if (!method.empty() && r.method != method) continue;
    if (r.fraction_over <= target.fraction_over && r.iou >= target.iou - 0.001 &&
        r.fraction_missed <= target.fraction_missed + kMissedTolerance &&
        (!fastest || r.ms < fastest->ms))
      fastest = &r;
  }
  return fastest;
}

}  // namespace

std::vector<StudyRun> run_study(const StudyOptions& options, std::ostream& progress) {
  if (options.scenes.empty()) throw Error("study: give at least one scene file");
  if (options.size < 16 || options.size > 4096)
    throw Error("study: --size " + std::to_string(options.size) + ": must be in [16, 4096]");
  if (options.frames < 1 || options.frames > 1000)
    throw Error("study: --frames " + std::to_string(options.frames) + ": must be in [1, 1000]");
  // Every scene loads before any work starts, so a bad file fails at once.
  std::vector<Scene> scenes;
  for (const auto& path : options.scenes) {
    Scene s = load_scene(path);
    if (!s.camera)
      throw Error(path.string() + ": camera: missing; the study needs the scene's camera");
    scenes.push_back(std::move(s));
  }
  std::filesystem::create_directories(options.out);
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };

  std::vector<StudyRun> runs;
  std::vector<std::string> names, truth_kinds;
  std::vector<Goal> goals;
  for (size_t si = 0; si < scenes.size(); ++si) {
    Scene scene = scenes[si];
    const std::string name = options.scenes[si].stem().string();
    names.push_back(name);
    const Camera& camera = *scene.camera;
    bool continuous = true, moves_nothing = true;
    for (const BoxSpec& b : scene.boxes) {
      const std::string& type = b.deformer.type;
      continuous = continuous && (type == "twist" || type == "bend");
      moves_nothing = moves_nothing && type == "box_cut";
    }
    const std::vector<Point> points = sweep(continuous, moves_nothing, options.quick);
    progress << "[" << si + 1 << "/" << scenes.size() << "] " << name << ": " << points.size()
             << " runs (" << fmt("%.0f", elapsed()) << " s)\n";

    // Bakes, by what they depend on.
    std::map<std::string, PreparedScene> bakes;
    auto bake = [&](const Point& p) -> const PreparedScene& {
      const std::string key = fmt("%g", p.resolution_scale) + "/" + fmt("%g", p.band) + "/" +
                              std::to_string(p.bits) + "/" + (p.method == "bounded" ? "b" : "");
      auto found = bakes.find(key);
      if (found != bakes.end()) return found->second;
      Scene s = scene;
      s.render.texture_bits = p.bits;
      s.render.sampling = p.method == "bounded" ? Sampling::Bounded : Sampling::Linear;
      for (BoxSpec& b : s.boxes) b = scaled_box(b, p);
      std::ostringstream log;
      return bakes.emplace(key, prepare_scene(s, log)).first->second;
    };

    const PreparedScene& base = bake(Point{});
    // The sweep scales the resolution the scene's own bake chose.
    for (size_t b = 0; b < scene.boxes.size(); ++b)
      if (scene.boxes[b].implicit.resolution == kAutoResolution)
        scene.boxes[b].implicit.resolution = base.boxes[b].report.implicit_choice.resolution;
    const Truth truth = ground_truth(scene, base, camera, options.size, options.size);
    truth_kinds.push_back(truth.kind);
    // What the bounded tracer covers on the scene's own textures: a step never passes a surface
    // there, so pixels it covers and a run does not are thin features the run stepped over.
    Image bounded_image;
    if (continuous) {
      Point p;
      p.method = "bounded";
      const PreparedScene& prepared = bake(p);
      gl::Renderer renderer;
      renderer.set_mesh(prepared.mesh());
      renderer.set_boxes(prepared.textures());
      RenderSettings settings = scene.render;
      settings.sampling = Sampling::Bounded;
      settings.max_steps = std::max(settings.max_steps, kBoundedMaxSteps);
      bounded_image = renderer.render(camera, options.size, options.size, settings);
    }
    for (size_t pi = 0; pi < points.size(); ++pi) {
      const Point& p = points[pi];
      StudyRun r;
      r.scene = name;
      r.method = p.method;
      r.settings = describe_point(p, scene.boxes[0]);
      r.step_voxels = p.step;
      r.refine_steps = p.refine;
      r.fine_factor = p.fine;
      r.threshold_voxels = p.threshold;
      r.hit_epsilon_voxels = p.epsilon;
      r.texture_bits = p.bits;
      r.subdivision_levels = p.levels;
      RenderSettings settings = scene.render;
      settings.width = settings.height = options.size;
      Image image;
      gl::Renderer renderer;
      if (p.method == "object-space") {
        const long triangles = static_cast<long>(base.mesh().F.rows()) << (2 * p.levels);
        if (triangles > kMaxObjectSpaceTriangles) {
          progress << "  [" << pi + 1 << "/" << points.size() << "] object-space (subdivision "
                   << p.levels << "): skipped, " << triangles << " triangles exceed the study's "
                   << kMaxObjectSpaceTriangles << "\n";
          continue;
        }
        const Mesh m = object_space_mesh(base, p.levels);
        renderer.set_mesh(m);
        renderer.set_boxes(std::vector<BoxTextures>{});
        r.triangles = static_cast<long>(m.F.rows());
        r.memory_bytes = size_t(m.V.rows()) * 6 * sizeof(float) + size_t(m.F.rows()) * 3 * 4;
      } else {
        const PreparedScene& prepared = bake(p);
        settings.sampling = *parse_sampling(p.method);  // every method but object-space
        settings.step_voxels = p.step;
        settings.refine_steps = p.refine;
        settings.fine_factor = p.fine;
        settings.threshold_voxels = p.threshold;
        settings.hit_epsilon_voxels = p.epsilon;
        settings.texture_bits = p.bits;
        if (p.method == "bounded")
          settings.max_steps = std::max(settings.max_steps, kBoundedMaxSteps);
        renderer.set_mesh(prepared.mesh());
        renderer.set_boxes(prepared.textures());
        r.memory_bytes = renderer.texture_bytes();
        const BoxTextures& t = prepared.boxes[0].textures;
        const BoxSpec scaled = scaled_box(scene.boxes[0], p);
        r.sdf_resolution = scaled.implicit.resolution;
        r.deformation_resolution = t.deformation.grid.dims.maxCoeff();
        r.band_voxels = t.sdf.band_voxels;
      }
      r.ms = frame_median(renderer, camera, options.size, options.size, settings, options.frames);
      image = renderer.render(camera, options.size, options.size, settings);
      const Measure m = measure(image, truth);
      r.iou = m.c.iou;
      r.mean_depth_error = m.c.mean_depth_error;
      r.max_depth_error = m.c.max_depth_error;
      r.fraction_over = m.c.fraction_over;
      r.fraction_missed = m.missed;
      r.fraction_missed_vs_bounded = continuous ? missed_of(image, bounded_image) : NAN;
      progress << "  [" << pi + 1 << "/" << points.size() << "] " << r.method << " (" << r.settings
               << "): " << fmt("%.1f", r.ms) << " ms, " << pct(r.fraction_over) << " % over, IoU "
               << fmt("%.4f", r.iou) << "\n";
      runs.push_back(r);
    }

    // The goals: the scene as shipped (its own settings) at goal_size.
    if (!options.quick) {
      const int gs = options.goal_size;
      const Truth goal_truth = ground_truth(scene, base, camera, gs, gs);
      gl::Renderer renderer;
      renderer.set_mesh(base.mesh());
      renderer.set_boxes(base.textures());
      Goal g;
      g.scene = name;
      g.ms = frame_median(renderer, camera, gs, gs, scene.render, std::max(options.frames, 5));
      const Measure m = measure(renderer.render(camera, gs, gs, scene.render), goal_truth);
      g.over = m.c.fraction_over;
      g.iou = m.c.iou;
      g.missed = m.missed;
      g.texture_bytes = renderer.texture_bytes();
      g.settings = std::string(sampling_name(scene.render.sampling)) + ", step " +
                   fmt("%g", scene.render.step_voxels);
      if (scene.render.sampling == Sampling::Threshold)
        g.settings += ", fine " + fmt("%g", scene.render.fine_factor) + " within " +
                      fmt("%g", scene.render.threshold_voxels);
      goals.push_back(g);
      progress << "  goal at " << gs << "²: " << fmt("%.1f", g.ms) << " ms, " << pct(g.over)
               << " % over\n";
    }
  }

  // Files.
  write_csv(options.out / "study.csv", runs);
  write_chart(options.out / "pareto.svg", names, runs);

  std::ostringstream md;
  md << "# Error against frame time\n\n"
     << "Written by `raywarp study`";
  for (const auto& p : options.scenes) md << " " << p.generic_string();
  md << " --out " << options.out.generic_string() << " in " << fmt("%.0f", elapsed()) << " s.\n\n";
  md << "**Machine:** " << options.machine << "; CPU " << cpu_model() << ", "
     << std::thread::hardware_concurrency() << " hardware threads.\n\n";
  md << "**How the numbers were taken.** Each run renders the scene's camera at " << options.size
     << "x" << options.size << " (the goals at " << options.goal_size << "x" << options.goal_size
     << "). Frame time: the renderer's own clock, both passes from the first draw to glFinish, "
        "the median of "
     << options.frames
     << " frames after one warm-up frame; bakes are not counted. Error: against each scene's "
        "ground truth (below), the silhouette IoU, the fraction of pixels covered in both whose "
        "depths differ by more than 1 % of the scene's diagonal (*over*), the fraction of the "
        "ground truth's pixels the run leaves empty (*missed*), and the mean and largest depth "
        "error in object units. A run is *acceptable* when at most 1 % of pixels are over and "
        "the IoU is at least 0.98. Memory: GPU textures for image space; vertex (position and "
        "normal, float) and index buffers for object space. The object-space peer subdivides "
        "the whole mesh uniformly (each triangle into 4 per level) and moves the vertices inside "
        "the box by the exact forward map, as a vertex shader would; it cannot show a cut, so "
        "it runs on continuous deformations only. `bounded` runs with max_steps raised to "
     << kBoundedMaxSteps << ".\n\n";
  md << "![error against frame time](pareto.svg)\n\n";
  md << "*pareto.svg: fraction of pixels over 1 % of the diagonal (log; " << kChartFloor
     << " = none over) against frame ms (log), one colour per method, the Pareto front in "
        "black.*"
        "\n\n";

  // Summary per scene. The recommendation is the fastest image-space run at the paper's error:
  // no more pixels over, no lower IoU (by 0.001) and no more pixels missed than linear at 0.5
  // voxel on the scene's own textures.
  md << "## Summary\n\n"
     << "*Recommended*: the fastest image-space run whose error is no worse than linear sampling "
        "at 0.5 voxel, as the paper samples, on the scene's own textures (at most its fraction "
        "over, an IoU at most 0.001 lower, at most 0.02 % more pixels missed). *Acceptable*: at "
        "most 1 % of pixels over and IoU at least 0.98.\n\n"
     << "| scene | recommended | ms | speed-up over linear at 0.5 voxel | over % | missed of "
        "bounded's % | smallest acceptable texture memory | object space: fastest acceptable |\n"
     << "| --- | --- | ---: | ---: | ---: | ---: | --- | --- |\n";
  for (size_t si = 0; si < names.size(); ++si) {
    const StudyRun* paper = paper_linear_run(runs, names[si]);
    const StudyRun* best = paper ? fastest_at(runs, names[si], *paper, false) : nullptr;
    const StudyRun* smallest = nullptr;
    const StudyRun* best_object = nullptr;
    bool has_object = false;
    for (const StudyRun& r : runs) {
      if (r.scene == names[si] && r.method == "object-space") has_object = true;
      if (r.scene != names[si] || !acceptable(r)) continue;
      if (r.method == "object-space") {
        if (!best_object || r.ms < best_object->ms) best_object = &r;
        continue;
      }
      if (!smallest || r.memory_bytes < smallest->memory_bytes) smallest = &r;
    }
    md << "| " << names[si] << " | ";
    if (best)
      md << best->method << ": " << best->settings << " | " << fmt("%.1f", best->ms) << " | "
         << fmt("%.2fx", paper->ms / best->ms) << " | " << pct(best->fraction_over) << " | "
         << (std::isnan(best->fraction_missed_vs_bounded) ? std::string("—")
                                                          : pct(best->fraction_missed_vs_bounded));
    else
      md << "none | | | | ";
    md << " | "
       << (smallest ? mib(smallest->memory_bytes) + " MiB (" + smallest->method + ": " +
                          smallest->settings + ")"
                    : "—")
       << " | "
       << (best_object ? fmt("%.1f ms", best_object->ms) + ", " +
                             fmt("%.0f", double(best_object->triangles)) + " triangles, " +
                             mib(best_object->memory_bytes) + " MiB (" + best_object->settings + ")"
           : has_object ? std::string("none acceptable")
                        : std::string("— (a cut)"))
       << " |\n";
  }
  md << "\n";

  // Equal error: per scene and error target, each method's fastest run that reaches it.
  md << "## Frame time at equal error\n\n"
     << "For each scene and target, each method's fastest run with at most the target's fraction "
        "of pixels over, an IoU no more than 0.001 below the target run's, and at most 0.02 % "
        "more of the ground truth's pixels missed. Targets: linear at 0.5 voxel as the paper "
        "samples (refine 8, the scene's resolutions, 32-bit), and the "
        "smallest error any image-space run reached. *Speed-up over linear's best*: the fastest "
        "linear run's time at that target over the best image-space method's (linear at a "
        "larger step often reaches the same figures); *over the target*: the target run's own "
        "time over the best image-space method's.\n\n"
     << "| scene | target | over % | target ms | linear ms | threshold ms | jacobian ms | "
        "bounded ms | object-space ms | speed-up over linear's best | speed-up over the target "
        "|\n"
     << "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  for (const std::string& scene : names) {
    const StudyRun* paper = paper_linear_run(runs, scene);
    const StudyRun* least = nullptr;
    for (const StudyRun& r : runs)
      if (r.scene == scene && r.method != "object-space" &&
          (!least || r.fraction_over < least->fraction_over ||
           (r.fraction_over == least->fraction_over && r.iou > least->iou)))
        least = &r;
    std::vector<std::pair<std::string, const StudyRun*>> targets;
    if (paper) targets.emplace_back("linear at 0.5 voxel (the paper's)", paper);
    if (least && least != paper) targets.emplace_back("least error (" + least->method + ")", least);
    for (const auto& [label, target] : targets) {
      md << "| " << scene << " | " << label << " | " << pct(target->fraction_over) << " | "
         << fmt("%.1f", target->ms) << " |";
      for (const char* method : kMethods) {
        const bool object = std::string(method) == "object-space";
        const StudyRun* fastest = fastest_at(runs, scene, *target, object, method);
        md << " " << (fastest ? fmt("%.1f", fastest->ms) : "—") << " |";
      }
      const StudyRun* linear = fastest_at(runs, scene, *target, false, "linear");
      const StudyRun* best = fastest_at(runs, scene, *target, false);
      md << " " << (linear && best ? fmt("%.2fx", linear->ms / best->ms) : "—") << " | "
         << (best ? fmt("%.2fx", target->ms / best->ms) : "—") << " |\n";
    }
  }
  md << "\n";

  if (!goals.empty()) {
    md << "## Speed and memory goals, at " << options.goal_size << "x" << options.goal_size
       << ", each scene with its own settings\n\n"
       << "Median of " << std::max(options.frames, 5)
       << " frames after a warm-up. Goals: the bunny twist in at most 50 ms with at most 1 % of "
          "pixels over; a solid box cut in at most 80 ms.\n\n"
       << "| scene | settings | ms | over % | IoU | missed % | texture MiB | goal |\n"
       << "| --- | --- | ---: | ---: | ---: | ---: | ---: | --- |\n";
    for (const Goal& g : goals) {
      std::string goal = "—";
      if (g.scene == "bunny_twist")
        goal =
            (g.ms <= 50 && g.over <= 0.01 ? "met" : "not met") + std::string(" (≤ 50 ms, ≤ 1 %)");
      if (g.scene == "bunny_cut_solid")
        goal = (g.ms <= 80 ? "met" : "not met") + std::string(" (≤ 80 ms)");
      md << "| " << g.scene << " | " << g.settings << " | " << fmt("%.1f", g.ms) << " | "
         << pct(g.over) << " | " << fmt("%.4f", g.iou) << " | " << pct(g.missed) << " | "
         << mib(g.texture_bytes) << " | " << goal << " |\n";
    }
    md << "\n";
  }

  md << "## Every run\n\n";
  for (size_t si = 0; si < names.size(); ++si) {
    md << "### " << names[si] << "\n\nGround truth: " << truth_kinds[si] << ".\n\n"
       << "| method | settings | ms | IoU | over % | missed % | missed of bounded's % | mean "
          "depth err | max depth err | memory MiB | front |\n"
       << "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |\n";
    std::vector<StudyRun> mine;
    for (const StudyRun& r : runs)
      if (r.scene == names[si]) mine.push_back(r);
    std::vector<bool> on_front(mine.size(), false);
    for (size_t i : study_front(mine)) on_front[i] = true;
    for (size_t i = 0; i < mine.size(); ++i) {
      const StudyRun& r = mine[i];
      md << "| " << r.method << " | " << r.settings << " | " << fmt("%.1f", r.ms) << " | "
         << fmt("%.4f", r.iou) << " | " << pct(r.fraction_over) << " | " << pct(r.fraction_missed)
         << " | "
         << (std::isnan(r.fraction_missed_vs_bounded) ? std::string("—")
                                                      : pct(r.fraction_missed_vs_bounded))
         << " | " << fmt("%.3g", r.mean_depth_error) << " | " << fmt("%.3g", r.max_depth_error)
         << " | " << mib(r.memory_bytes) << " | " << (on_front[i] ? "yes" : "") << " |\n";
    }
    md << "\n";
  }
  const std::string text = md.str();
  write_file_atomic((options.out / "report.md").string(), text.data(), text.size());
  progress << "wrote " << (options.out / "study.csv").string() << ", "
           << (options.out / "pareto.svg").string() << " and "
           << (options.out / "report.md").string() << " (" << fmt("%.0f", elapsed()) << " s)\n";
  return runs;
}

}  // namespace raywarp
