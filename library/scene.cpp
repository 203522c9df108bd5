#include "library/scene.h"

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <nlohmann/json.hpp>
#include <system_error>

#include "base/error.h"
#include "base/json_reader.h"
#include "deformers/deformer.h"
#include "library/mesh_pairs.h"

namespace raywarp {

namespace {

using json = nlohmann::json;

constexpr int kMaxBoxes = 16;
// Coordinates and extents beyond this (object units) are refused: they are typos, and their
// differences and products would lose all precision or overflow.
constexpr double kMaxCoordinate = 1e12;
constexpr double kMaxRotationDeg = 360.0;
constexpr int kMaxImageSide = 8192;
// Textures of all boxes together; checked at load time, before anything is allocated.

Eigen::Matrix3d rotation_from_euler_deg(const Eigen::Vector3d& deg) {
  // R = Rz * Ry * Rx: a point is rotated about x first, then y, then z (fixed object axes).
  Eigen::Vector3d rad = deg * (M_PI / 180.0);
  return (Eigen::AngleAxisd(rad.z(), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(rad.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rad.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

const char* const kBoxForms =
    "give either min and max, or centre and half_extents (with optional rotation_deg)";

Box read_min_max(const JsonReader& r, const json& j, const std::string& field) {
  const Interval coordinate = closed(-kMaxCoordinate, kMaxCoordinate);
  Eigen::Vector3d lo =
      r.vec3(r.required(j, field, "min", kBoxForms), child(field, "min"), coordinate);
  Eigen::Vector3d hi =
      r.vec3(r.required(j, field, "max", kBoxForms), child(field, "max"), coordinate);
  for (int a = 0; a < 3; ++a)
    if (!(hi[a] > lo[a]))
      r.fail(
          element(child(field, "max"), a), j["max"][a],
          "must be greater than " + element(child(field, "min"), a) + " = " + format_number(lo[a]));
  Box box;
  box.centre = 0.5 * (lo + hi);
  box.half_extents = 0.5 * (hi - lo);
  return box;
}

Box read_centred(const JsonReader& r, const json& j, const std::string& field) {
  if (j.contains("centre") && j.contains("center"))
    r.fail(child(field, "center"), j["center"], "an alias of centre; give only one of them");
  const char* centre_key = j.contains("center") ? "center" : "centre";
  Box box;
  box.centre = r.vec3(r.required(j, field, centre_key, kBoxForms), child(field, centre_key),
                      closed(-kMaxCoordinate, kMaxCoordinate));
  box.half_extents = r.vec3(r.required(j, field, "half_extents", kBoxForms),
                            child(field, "half_extents"), {0.0, kMaxCoordinate, true, false, true});
  if (j.contains("rotation_deg"))
    box.rotation = rotation_from_euler_deg(r.vec3(j["rotation_deg"], child(field, "rotation_deg"),
                                                  closed(-kMaxRotationDeg, kMaxRotationDeg)));
  return box;
}

Box read_box_geometry(const JsonReader& r, const json& j, const std::string& field) {
  bool axis_aligned = j.contains("min") || j.contains("max");
  for (const char* key : {"centre", "center", "half_extents", "rotation_deg"})
    if (axis_aligned && j.contains(key))
      r.fail(child(field, key), j[key],
             std::string("not allowed together with min/max; ") + kBoxForms);
  return axis_aligned ? read_min_max(r, j, field) : read_centred(r, j, field);
}

constexpr size_t kMaxComposed = 8;

// A length that must be > 0, any finite size.
double positive(const JsonReader& r, const json& j, const std::string& field, const char* key,
                const std::string& hint) {
  return r.number(r.required(j, field, key, hint), child(field, key),
                  {0.0, std::numeric_limits<double>::infinity(), true});
}

// One deformer object, or a list of them applied in order (continuous deformers only).
void read_deformers(const JsonReader& r, const json& j, const std::string& field, BoxSpec& b) {
  if (!j.is_array()) {
    b.deformer = read_deformer(r, j, field, b.box);
    return;
  }
  if (j.empty() || j.size() > kMaxComposed)
    r.fail(field, j,
           "must be one deformer object or a list of 1 to " + std::to_string(kMaxComposed) +
               " deformers applied in order");
  for (size_t i = 0; i < j.size(); ++i) {
    DeformerSpec d = read_deformer(r, j[i], element(field, i), b.box);
    if (is_cut(d) && j.size() > 1)
      r.fail(child(element(field, i), "type"), j[i]["type"],
             "a cut (" + cut_type_names() +
                 ") cannot be composed with other deformers; give it a box of its own, or list "
                 "only " +
                 continuous_type_names());
    if (needs_mesh(d) && j.size() > 1)
      r.fail(child(element(field, i), "type"), j[i]["type"],
             "a " + d.type +
                 " deformer is built over the mesh part and cannot be composed with other "
                 "deformers; give it a box of its own");
    if (i == 0)
      b.deformer = std::move(d);
    else
      b.then.push_back(std::move(d));
  }
}

// "auto" (kAutoResolution) or an integer in [lo, hi].
int read_resolution(const JsonReader& r, const json& j, const std::string& field, int lo = 4,
                    int hi = 1024) {
  if (j.is_string() && j.get<std::string>() == "auto") return kAutoResolution;
  if (j.is_string())
    r.fail(field, j,
           "must be \"auto\" or an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) +
               "]");
  return r.integer(j, field, lo, hi);
}

ImplicitSpec read_implicit(const JsonReader& r, const json& j, const std::string& field) {
  r.require_object(j, field, "{\"type\": \"sdf\", \"resolution\": ...}");
  r.check_keys(j, field, {"type", "resolution", "max_mib", "band_voxels", "margin_voxels"});
  ImplicitSpec s;
  if (j.contains("type"))
    s.type = r.one_of(j["type"], child(field, "type"), {"sdf", "depth_cube"},
                      " (sdf: a signed distance grid; depth_cube: six depth maps, one per face)");
  // Six maps of resolution^2 texels at most: a finer grid than a distance grid's fits.
  const int most = s.type == "depth_cube" ? 4096 : 1024;
  if (j.contains("resolution"))
    s.resolution = read_resolution(r, j["resolution"], child(field, "resolution"), 8, most);
  if (j.contains("max_mib")) {
    if (s.resolution != kAutoResolution)
      r.fail(child(field, "max_mib"), j["max_mib"],
             "applies to \"resolution\": \"auto\" only (an explicit resolution fixes the size)");
    s.max_mib = r.number(j["max_mib"], child(field, "max_mib"), closed(1, 1024));
  }
  if (s.type == "depth_cube") {
    for (const char* key : {"band_voxels", "margin_voxels"})
      if (j.contains(key))
        r.fail(child(field, key), j[key],
               std::string(key) + " applies to the distance grid (type sdf); " +
                   child(field, "type") + " is depth_cube");
    return s;
  }
  if (j.contains("band_voxels"))
    s.band_voxels = r.number(j["band_voxels"], child(field, "band_voxels"), closed(1, 32));
  if (j.contains("margin_voxels"))
    s.margin_voxels = r.number(j["margin_voxels"], child(field, "margin_voxels"), closed(0, 64));
  return s;
}

// A texture's layout section, "deformation" or "alpha": {"resolution": "auto" | n, "max_mib"}.
void read_layout(const JsonReader& r, const json& j, const std::string& field, int& resolution,
                 double& max_mib) {
  r.require_object(j, field, "{\"resolution\": \"auto\"}");
  r.check_keys(j, field, {"resolution", "max_mib"});
  if (j.contains("resolution"))
    resolution = read_resolution(r, j["resolution"], child(field, "resolution"));
  if (j.contains("max_mib")) {
    if (resolution != kAutoResolution)
      r.fail(child(field, "max_mib"), j["max_mib"],
             "applies to \"resolution\": \"auto\" only (an explicit resolution fixes the size)");
    max_mib = r.number(j["max_mib"], child(field, "max_mib"), closed(1, 1024));
  }
}

// cut_mode, shell_thickness and alpha, after the deformer has been read.
void read_cut_settings(const JsonReader& r, const json& j, const std::string& field, BoxSpec& b) {
  if (!is_cut(b.deformer)) {
    for (const char* key : {"cut_mode", "shell_thickness", "alpha"})
      if (j.contains(key))
        r.fail(child(field, key), j[key],
               std::string(key) + " applies to cut deformers (" + cut_type_names() + "); " +
                   child(field, "deformer.type") + " is " + b.deformer.type);
    return;
  }
  std::string mode = "solid";
  if (j.contains("cut_mode"))
    mode = r.one_of(j["cut_mode"], child(field, "cut_mode"), {"hollow", "solid", "thick_shell"});
  b.cut_mode = mode == "hollow"  ? CutMode::Hollow
               : mode == "solid" ? CutMode::Solid
                                 : CutMode::ThickShell;
  if (b.cut_mode == CutMode::ThickShell) {
    b.shell_thickness = positive(
        r, j, field, "shell_thickness",
        "required with cut_mode thick_shell; give the shell thickness in object units (> 0)");
  } else if (j.contains("shell_thickness")) {
    r.fail(child(field, "shell_thickness"), j["shell_thickness"],
           "only with cut_mode thick_shell; " + child(field, "cut_mode") + " is " + mode +
               (j.contains("cut_mode") ? "" : " (the default)"));
  }
  if (j.contains("alpha"))
    read_layout(r, j["alpha"], child(field, "alpha"), b.alpha_resolution, b.alpha_max_mib);
}

// "mapping": {"type": "cartesian" | "cylindrical", "axis": "y", "angle_texels": 16}.
MappingSpec read_mapping(const JsonReader& r, const json& j, const std::string& field) {
  r.require_object(j, field, "{\"type\": \"cylindrical\", \"axis\": \"y\"}");
  r.check_keys(j, field, {"type", "axis", "angle_texels"});
  MappingSpec m;
  const std::string type =
      r.one_of(r.required(j, field, "type", "give \"cartesian\" or \"cylindrical\""),
               child(field, "type"), {"cartesian", "cylindrical"});
  m.cylindrical = type == "cylindrical";
  if (!m.cylindrical) {
    for (const char* key : {"axis", "angle_texels"})
      if (j.contains(key))
        r.fail(
            child(field, key), j[key],
            "applies to \"type\": \"cylindrical\" only; " + child(field, "type") + " is cartesian");
    return m;
  }
  const std::string axis =
      r.one_of(r.required(j, field, "axis", "give the cylinder's axis, one of x, y, z"),
               child(field, "axis"), {"x", "y", "z"});
  m.axis = axis[0] - 'x';
  if (j.contains("angle_texels"))
    m.angle_texels = r.integer(j["angle_texels"], child(field, "angle_texels"), 2, 1024);
  return m;
}

BoxSpec read_box(const JsonReader& r, const json& j, const std::string& field) {
  r.require_object(j, field, "{\"min\": ..., \"max\": ..., \"deformer\": ...}");
  r.check_keys(j, field,
               {"min", "max", "centre", "center", "half_extents", "rotation_deg", "deformer",
                "implicit", "deformation", "cut_mode", "shell_thickness", "alpha", "mapping"});
  BoxSpec b;
  b.box = read_box_geometry(r, j, field);
  read_deformers(r,
                 r.required(j, field, "deformer",
                            "give {\"type\": ..., ...} (type one of " + deformer_type_names() +
                                ") or a list of them"),
                 child(field, "deformer"), b);
  read_cut_settings(r, j, field, b);
  if (j.contains("implicit"))
    b.implicit = read_implicit(r, j["implicit"], child(field, "implicit"));
  if (j.contains("deformation"))
    read_layout(r, j["deformation"], child(field, "deformation"), b.deformation_resolution,
                b.deformation_max_mib);
  if (j.contains("mapping")) b.mapping = read_mapping(r, j["mapping"], child(field, "mapping"));
  return b;
}

// Separating axis test for two oriented boxes (Gottschalk, Lin & Manocha 1996): they are
// disjoint iff their projections are disjoint on one of the 3 + 3 face normals or the 9 edge
// cross products. Boxes that only touch (share a face, an edge or a corner) do not overlap.
bool boxes_overlap(const Box& a, const Box& b) {
  Eigen::Vector3d t = b.centre - a.centre;
  double scale = a.half_extents.norm() + b.half_extents.norm() + t.norm();
  auto separates = [&](Eigen::Vector3d axis) {
    double n = axis.norm();
    if (n < 1e-9) return false;  // parallel edges: the face normals decide
    axis /= n;
    double ra = (a.rotation.transpose() * axis).cwiseAbs().dot(a.half_extents);
    double rb = (b.rotation.transpose() * axis).cwiseAbs().dot(b.half_extents);
    return std::abs(t.dot(axis)) >= ra + rb - 1e-9 * scale;
  };
  for (int i = 0; i < 3; ++i)
    if (separates(a.rotation.col(i)) || separates(b.rotation.col(i))) return false;
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k)
      if (separates(a.rotation.col(i).cross(b.rotation.col(k)))) return false;
  return true;
}

std::string format_vector(const Eigen::Vector3d& x) {
  std::string out = "[";
  for (int a = 0; a < 3; ++a) (out += a ? ", " : "") += format_number(x[a]);
  return out + "]";
}

std::string describe_box(const Box& b) {
  return "centre " + format_vector(b.centre) + ", half_extents " + format_vector(b.half_extents);
}

// The keys of a box that place it, for messages about its placement.
json geometry_keys(const json& box) {
  json out = json::object();
  for (const char* key : {"min", "max", "centre", "center", "half_extents", "rotation_deg"})
    if (box.contains(key)) out[key] = box[key];
  return out;
}

void check_overlaps(const JsonReader& r, const json& boxes, const std::vector<BoxSpec>& specs) {
  for (size_t i = 0; i < specs.size(); ++i)
    for (size_t k = 0; k < i; ++k)
      if (boxes_overlap(specs[k].box, specs[i].box))
        r.fail(element("boxes", i), geometry_keys(boxes[i]),
               "overlaps " + element("boxes", k) + " (" + describe_box(specs[k].box) + " vs " +
                   describe_box(specs[i].box) + "); boxes must not overlap (touching is allowed)");
}

// Sizes of the textures of one box, in bytes, before anything is allocated. The distance grid
// as bake_distance_grid lays it out: cubic voxels of side 2 max(h) / resolution over the box grown
// by margin_voxels on every side, rounded up to whole voxels. The deformation texture covers
// F(box), unknown before the deformer runs: at most resolution^3 texels of 4 floats (a cube is
// the worst case for `resolution` texels along the longest side).
// An automatic resolution takes at most its budget.
std::uint64_t distance_grid_bytes(const BoxSpec& b) {
  if (b.implicit.resolution == kAutoResolution)
    return static_cast<std::uint64_t>(b.implicit.max_mib * double(1 << 20));
  const Eigen::Vector3d& h = b.box.half_extents;
  double spacing = 2.0 * h.maxCoeff() / b.implicit.resolution;
  std::uint64_t voxels = 1;
  for (int a = 0; a < 3; ++a) {
    double extent = 2.0 * (h[a] + b.implicit.margin_voxels * spacing);
    voxels *=
        std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::ceil(extent / spacing - 1e-9)));
  }
  return voxels * sizeof(float);
}

// The implicit surface: the distance grid, or a depth cube's six maps (one 2D array texture of
// 6 layers, each as large as the largest map; depth_cube_bytes).
std::uint64_t implicit_bytes(const BoxSpec& b) {
  if (b.implicit.type == "depth_cube" && b.implicit.resolution != kAutoResolution)
    return depth_cube_bytes(b.box.half_extents, b.implicit.resolution);
  return distance_grid_bytes(b);
}

// An automatic layout takes at most its budget.
std::uint64_t deformation_bytes(const BoxSpec& b) {
  if (b.deformation_resolution == kAutoResolution)
    return static_cast<std::uint64_t>(b.deformation_max_mib * double(1 << 20));
  std::uint64_t d = b.deformation_resolution;
  if (b.mapping.cylindrical)
    return d * d * std::uint64_t(b.mapping.angle_texels) * 4 * sizeof(float);
  return d * d * d * 4 * sizeof(float);
}

// The alpha map A of a cut: at most resolution^3 texels of 1 float, like D.
std::uint64_t alpha_bytes(const BoxSpec& b) {
  if (!is_cut(b.deformer)) return 0;
  if (b.alpha_resolution == kAutoResolution)
    return static_cast<std::uint64_t>(b.alpha_max_mib * double(1 << 20));
  std::uint64_t a = b.alpha_resolution;
  if (b.mapping.cylindrical) return a * a * std::uint64_t(b.mapping.angle_texels) * sizeof(float);
  return a * a * a * sizeof(float);
}

std::string gib(std::uint64_t bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f GiB", bytes / double(std::uint64_t(1) << 30));
  return buf;
}

void check_memory_budget(const JsonReader& r, const std::vector<BoxSpec>& specs) {
  std::uint64_t grids = 0, textures = 0, alphas = 0;
  // The field to lower: the resolution with the largest texture.
  std::uint64_t largest = 0;
  std::string field;
  json value;
  auto consider = [&](std::uint64_t bytes, std::string name, json setting) {
    if (bytes <= largest) return;
    largest = bytes;
    field = std::move(name);
    value = std::move(setting);
  };
  bool cuts = false;
  for (size_t i = 0; i < specs.size(); ++i) {
    std::uint64_t g = implicit_bytes(specs[i]), t = deformation_bytes(specs[i]),
                  a = alpha_bytes(specs[i]);
    grids += g;
    textures += t;
    alphas += a;
    cuts = cuts || is_cut(specs[i].deformer);
    if (specs[i].implicit.resolution == kAutoResolution)
      consider(g, element("boxes", i) + ".implicit.max_mib", specs[i].implicit.max_mib);
    else
      consider(g, element("boxes", i) + ".implicit.resolution", specs[i].implicit.resolution);
    if (specs[i].deformation_resolution == kAutoResolution)
      consider(t, element("boxes", i) + ".deformation.max_mib", specs[i].deformation_max_mib);
    else
      consider(t, element("boxes", i) + ".deformation.resolution", specs[i].deformation_resolution);
    if (specs[i].alpha_resolution == kAutoResolution)
      consider(a, element("boxes", i) + ".alpha.max_mib", specs[i].alpha_max_mib);
    else
      consider(a, element("boxes", i) + ".alpha.resolution", specs[i].alpha_resolution);
  }
  std::uint64_t total = grids + textures + alphas;
  if (total <= kMemoryBudgetBytes) return;
  r.fail(field, value,
         "the textures of all boxes would take " + gib(total) + " (implicit surfaces " +
             gib(grids) + ", deformation textures " + gib(textures) +
             (cuts ? ", alpha maps " + gib(alphas) : std::string()) +
             "), more than the budget of " + gib(kMemoryBudgetBytes) +
             "; lower this setting (the largest of them)");
}

std::vector<BoxSpec> read_boxes(const JsonReader& r, const json& j) {
  const std::string allowed = "must be a list of 1 to " + std::to_string(kMaxBoxes) + " boxes";
  if (!j.is_array() || j.empty() || j.size() > static_cast<size_t>(kMaxBoxes))
    r.fail("boxes", j, allowed);
  std::vector<BoxSpec> specs;
  for (size_t i = 0; i < j.size(); ++i) specs.push_back(read_box(r, j[i], element("boxes", i)));
  check_overlaps(r, j, specs);
  check_memory_budget(r, specs);
  return specs;
}

Camera read_camera(const JsonReader& r, const json& j, const std::filesystem::path& folder) {
  if (j.is_object()) return camera_from_json(j, r.file() + ": camera");
  if (!j.is_string()) r.fail("camera", j, "must be a path (string) or a camera object");
  std::filesystem::path path = r.existing_file(j, "camera", folder);
  try {
    return load_camera(path.string());
  } catch (const Error& e) {
    throw Error(r.file() + ": camera = " + show(j) + ": " + e.what());
  } catch (const json::exception& e) {
    // load_camera lets numbers beyond double (out_of_range) through; they are not valid JSON.
    throw Error(r.file() + ": camera = " + show(j) + ": " + path.string() +
                ": not valid JSON: " + e.what());
  }
}

TransferFunction read_transfer_function(const JsonReader& r, const json& j,
                                        const std::string& field) {
  if (!j.is_array() || j.empty() || j.size() > static_cast<size_t>(kMaxTransferPoints))
    r.fail(field, j,
           "must be a list of 1 to " + std::to_string(kMaxTransferPoints) +
               " control points {\"s\": scalar, \"colour\": [r, g, b], \"tau\": extinction} "
               "in increasing s");
  TransferFunction tf;
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string at = element(field, i);
    const json& p = j[i];
    r.require_object(p, at, "{\"s\": 0, \"colour\": [1, 1, 1], \"tau\": 1}");
    r.check_keys(p, at, {"s", "colour", "tau"});
    TransferPoint point;
    point.s = r.number(r.required(p, at, "s", "give the scalar of the control point"),
                       child(at, "s"), {-1e9, 1e9, false, false});
    if (i > 0 && !(point.s > tf.points.back().s))
      r.fail(child(at, "s"), p["s"],
             "must be greater than the previous point's s (" + shortest_text(tf.points.back().s) +
                 ")");
    point.colour = r.vec3(r.required(p, at, "colour", "give [r, g, b], linear, in [0, 1]"),
                          child(at, "colour"), closed(0, 1));
    point.tau = r.number(r.required(p, at, "tau", "give the extinction per object unit, >= 0"),
                         child(at, "tau"), closed(0, 1e6));
    tf.points.push_back(point);
  }
  tf.validate();
  return tf;
}

TetDisplaySpec read_tets(const JsonReader& r, const json& j) {
  const std::string field = "render.tets";
  r.require_object(j, field, "{\"mode\": \"surface\"}");
  r.check_keys(
      j, field,
      {"mode", "refine", "scalar", "transfer_function", "scalar_samples", "length_samples"});
  TetDisplaySpec t;
  if (j.contains("mode")) t.mode = r.one_of(j["mode"], child(field, "mode"), {"surface", "volume"});
  if (j.contains("refine"))
    t.refine = read_resolution(r, j["refine"], child(field, "refine"), 1, 8);
  if (j.contains("scalar"))
    t.scalar = r.one_of(j["scalar"], child(field, "scalar"), {"f", "strain"});
  if (j.contains("transfer_function"))
    t.transfer =
        read_transfer_function(r, j["transfer_function"], child(field, "transfer_function"));
  if (j.contains("scalar_samples"))
    t.scalar_samples = r.integer(j["scalar_samples"], child(field, "scalar_samples"), 2, 512);
  if (j.contains("length_samples"))
    t.length_samples = r.integer(j["length_samples"], child(field, "length_samples"), 2, 512);
  if (t.mode == "surface")
    for (const char* k : {"scalar", "transfer_function", "scalar_samples", "length_samples"})
      if (j.contains(k)) r.fail(child(field, k), j[k], "applies to \"mode\": \"volume\" only");
  return t;
}

RenderSettings read_render(const JsonReader& r, const json& j) {
  r.require_object(j, "render", "{\"width\": ..., \"height\": ...}");
  r.check_keys(j, "render",
               {"width", "height", "step_voxels", "max_steps", "refine_steps", "background",
                "colour", "cut_colour", "inside_colour", "skipping", "sampling", "threshold_voxels",
                "fine_factor", "hit_epsilon_voxels", "texture_bits", "route", "tets"});
  RenderSettings s;
  if (j.contains("width")) s.width = r.integer(j["width"], "render.width", 1, kMaxImageSide);
  if (j.contains("height")) s.height = r.integer(j["height"], "render.height", 1, kMaxImageSide);
  if (j.contains("step_voxels"))
    s.step_voxels = r.number(j["step_voxels"], "render.step_voxels", {0.0, 8.0, true, false});
  if (j.contains("max_steps"))
    s.max_steps = r.integer(j["max_steps"], "render.max_steps", 1, 100000);
  if (j.contains("refine_steps"))
    s.refine_steps = r.integer(j["refine_steps"], "render.refine_steps", 0, 64);
  if (j.contains("background"))
    s.background = r.vec3(j["background"], "render.background", closed(0, 1));
  if (j.contains("colour")) s.colour = r.vec3(j["colour"], "render.colour", closed(0, 1));
  if (j.contains("cut_colour"))
    s.cut_colour = r.vec3(j["cut_colour"], "render.cut_colour", closed(0, 1));
  if (j.contains("inside_colour"))
    s.inside_colour = r.vec3(j["inside_colour"], "render.inside_colour", closed(0, 1));
  if (j.contains("skipping")) {
    if (!j["skipping"].is_boolean())
      r.fail("render.skipping", j["skipping"], "must be true or false");
    s.skipping = j["skipping"].get<bool>();
  }
  if (j.contains("sampling"))
    s.sampling = *parse_sampling(
        r.one_of(j["sampling"], "render.sampling", {"linear", "threshold", "jacobian", "bounded"}));
  if (s.sampling != Sampling::Threshold && !j.contains("step_voxels"))
    s.step_voxels = kFineStepVoxels;
  if (j.contains("threshold_voxels"))
    s.threshold_voxels =
        r.number(j["threshold_voxels"], "render.threshold_voxels", {0.0, 64.0, true, false});
  if (j.contains("fine_factor"))
    s.fine_factor = r.number(j["fine_factor"], "render.fine_factor", {0.0, 1.0, true, false});
  if (j.contains("hit_epsilon_voxels"))
    s.hit_epsilon_voxels =
        r.number(j["hit_epsilon_voxels"], "render.hit_epsilon_voxels", {0.0, 1.0, true, false});
  if (j.contains("texture_bits")) {
    const json& v = j["texture_bits"];
    if (!v.is_number_integer() || (v.get<double>() != 16 && v.get<double>() != 32))
      r.fail("render.texture_bits", v, "must be 16 or 32");
    s.texture_bits = v.get<int>();
  }
  if (j.contains("route")) s.route = r.one_of(j["route"], "render.route", {"texture", "tets"});
  if (j.contains("tets")) s.tets = read_tets(r, j["tets"]);
  return s;
}

json parse_file(const std::filesystem::path& path) { return read_json_file(path, "scene file"); }

}  // namespace

nlohmann::json read_scene_document(const std::filesystem::path& path) { return parse_file(path); }

Scene load_scene(const std::filesystem::path& path) {
  return load_scene_json(parse_file(path), path);
}

Scene load_scene_json(const nlohmann::json& root, const std::filesystem::path& path) {
  JsonReader r(path.string());
  if (!root.is_object())
    throw Error(path.string() + ": the scene = " + show(root) +
                ": must be a JSON object with mesh, boxes, camera, render");
  r.check_keys(root, "", {"mesh", "boxes", "camera", "render"});
  Scene scene;
  scene.file = path;
  std::filesystem::path folder = path.parent_path();
  scene.mesh = r.existing_file(
      r.required(root, "", "mesh", "give the mesh file, relative to the scene file"), "mesh",
      folder);
  scene.boxes = read_boxes(
      r,
      r.required(root, "", "boxes", "give a list of 1 to " + std::to_string(kMaxBoxes) + " boxes"));
  if (root.contains("camera")) scene.camera = read_camera(r, root["camera"], folder);
  if (root.contains("render")) scene.render = read_render(r, root["render"]);
  if (scene.render.sampling == Sampling::Bounded)
    for (size_t i = 0; i < scene.boxes.size(); ++i) {
      const std::string& type = scene.boxes[i].deformer.type;
      if (is_cut(scene.boxes[i].deformer))
        throw Error(path.string() + ": render.sampling = \"bounded\": boxes[" + std::to_string(i) +
                    "].deformer.type is \"" + type +
                    "\", a cut; bounded tracing needs a continuous deformation (" +
                    continuous_type_names() + "): use linear, threshold or jacobian");
      if (scene.boxes[i].implicit.type == "depth_cube")
        throw Error(path.string() + ": render.sampling = \"bounded\": boxes[" + std::to_string(i) +
                    "].implicit.type is \"depth_cube\", whose |f| is no distance bound; bounded "
                    "tracing needs a distance grid (implicit.type \"sdf\"): use linear, threshold "
                    "or jacobian");
      if (scene.boxes[i].mapping.cylindrical)
        throw Error(path.string() + ": render.sampling = \"bounded\": boxes[" + std::to_string(i) +
                    "].mapping.type is \"cylindrical\"; the bounded tracer's step bounds hold "
                    "for Cartesian textures: use linear, threshold or jacobian, or mapping "
                    "\"cartesian\"");
    }
  // A from_mesh folder target, a sequence: its frames listed now, so that a frame past the last
  // or an empty folder is said before anything is baked (a glTF's morph targets are counted when
  // it is read).
  for (size_t i = 0; i < scene.boxes.size(); ++i) {
    const DeformerSpec& d = scene.boxes[i].deformer;
    std::error_code ec;
    if (d.type != "from_mesh" || !std::filesystem::is_directory(d.target, ec)) continue;
    try {
      deformed_copy_files(d.target, d.frame);
    } catch (const Error& e) {
      const std::string what = e.what();
      throw Error(path.string() + ": boxes[" + std::to_string(i) + "].deformer." +
                  (what.rfind("frame", 0) == 0 ? "" : "target: ") + what);
    }
  }
  if (scene.render.route == "tets")
    for (size_t i = 0; i < scene.boxes.size(); ++i)
      if (scene.boxes[i].deformer.type != "simulation")
        throw Error(path.string() + ": render.route = \"tets\": boxes[" + std::to_string(i) +
                    "].deformer.type is \"" + scene.boxes[i].deformer.type +
                    "\"; the tetrahedral route shows simulation boxes only: use route "
                    "\"texture\"");
  return scene;
}

Eigen::Vector2i image_size(const Scene& scene, const Camera& camera, int cli_width,
                           int cli_height) {
  auto pick = [](int cli, int cam, int render) { return cli > 0 ? cli : cam > 0 ? cam : render; };
  return {pick(cli_width, camera.width, scene.render.width),
          pick(cli_height, camera.height, scene.render.height)};
}

}  // namespace raywarp
