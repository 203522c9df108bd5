#include "deformers/registry.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>

#include "base/error.h"
#include "deformers/bend.h"
#include "deformers/box_cut.h"
#include "deformers/control_points.h"
#include "deformers/detail.h"
#include "deformers/from_mesh.h"
#include "deformers/groove.h"
#include "deformers/incision.h"
#include "deformers/peel.h"
#include "deformers/stretch.h"
#include "deformers/taper.h"
#include "deformers/twist.h"

namespace raywarp {

namespace {

using json = nlohmann::json;

// Coordinates beyond this (object units) are refused: they are typos (as in the scene reader).
constexpr double kMaxCoordinate = 1e12;
constexpr size_t kMaxControlPoints = 1024;  // the interpolant's dense solve grows as n^3
constexpr double kInf = std::numeric_limits<double>::infinity();

// Declarations, shortened.
ParamDecl axis_param(std::string meaning, std::string hint) {
  ParamDecl p;
  p.key = "axis";
  p.kind = ParamKind::Axis;
  p.required = true;
  p.meaning = std::move(meaning);
  p.hint = std::move(hint);
  p.field = &DeformerSpec::axis;
  return p;
}

ParamDecl number_param(std::string key, double DeformerSpec::*field, Interval range,
                       std::string unit, std::string meaning, std::string hint,
                       std::string default_text = "") {
  ParamDecl p;
  p.key = std::move(key);
  p.kind = ParamKind::Number;
  p.required = default_text.empty();
  p.range = range;
  p.unit = std::move(unit);
  p.meaning = std::move(meaning);
  p.hint = std::move(hint);
  p.default_text = std::move(default_text);
  p.field = field;
  return p;
}

ParamDecl from_param(std::string meaning) {
  ParamDecl p;
  p.key = "from";
  p.kind = ParamKind::Face;
  p.required = true;
  p.meaning = std::move(meaning);
  p.hint = "give a face of the box: +x, -x, +y, -y, +z, -z";
  return p;
}

const Interval kPositive{0.0, kInf, true, false};

// `from` must lie on another axis than `axis` (peel, incision).
void check_from_face(const JsonReader& r, const json& j, const std::string& field,
                     const DeformerSpec& d) {
  if (d.from_axis != d.axis) return;
  std::string others;
  for (int a = 0; a < 3; ++a)
    if (a != d.axis)
      for (const char* side : {"+", "-"})
        others += (others.empty() ? "" : ", ") + std::string(side) + char('x' + a);
  r.fail(child(field, "from"), j["from"],
         "must be a face on another axis than " + child(field, "axis") + " = \"" +
             char('x' + d.axis) + "\"; allowed: " + others);
}

void check_sub_box(const JsonReader& r, const json& j, const std::string& field,
                   const DeformerSpec& d) {
  for (int a = 0; a < 3; ++a) {
    if (d.sub_max[a] > d.sub_min[a]) continue;
    if (j.contains("sub_max"))
      r.fail(element(child(field, "sub_max"), a), j["sub_max"][a],
             "must be greater than " + element(child(field, "sub_min"), a) + " = " +
                 format_number(d.sub_min[a]));
    r.fail(element(child(field, "sub_min"), a), j["sub_min"][a],
           "must be less than " + element(child(field, "sub_max"), a) + " = " +
               format_number(d.sub_max[a]) + " (the default: the box's max face)");
  }
}

std::string format_vector(const Eigen::Vector3d& v) {
  std::string out(1, '[');
  for (int i = 0; i < 3; ++i) {
    if (i) out += ", ";
    out += format_number(v[i]);
  }
  out += ']';
  return out;
}

constexpr size_t kMaxDrags = 64, kMaxDragKeys = 1024;

std::vector<Drag> read_drags(const JsonReader& r, const json& v, const std::string& at,
                             const Box& box) {
  const std::string shape =
      "[{\"sub_min\": [0, 0.8, 0], \"sub_max\": [1, 1, 1], \"path\": [{\"t\": 1, "
      "\"offset\": [0, 0.2, 0]}]}]";
  if (!v.is_array() || v.size() > kMaxDrags)
    r.fail(at, v,
           "must be a list of at most " + std::to_string(kMaxDrags) + " drags, e.g. " + shape);
  std::vector<Drag> out;
  const Interval coordinate = closed(-kMaxCoordinate, kMaxCoordinate);
  for (size_t i = 0; i < v.size(); ++i) {
    const std::string drag_at = element(at, i);
    r.require_object(v[i], drag_at, shape.substr(1, shape.size() - 2));
    r.check_keys(v[i], drag_at, {"sub_min", "sub_max", "path"});
    Drag drag;
    if (v[i].contains("sub_min"))
      drag.sub_min = r.vec3(v[i]["sub_min"], child(drag_at, "sub_min"), closed(0, 1));
    if (v[i].contains("sub_max"))
      drag.sub_max = r.vec3(v[i]["sub_max"], child(drag_at, "sub_max"), closed(0, 1));
    for (int a = 0; a < 3; ++a)
      if (!(drag.sub_max[a] >= drag.sub_min[a]))
        r.fail(element(child(drag_at, "sub_max"), a), v[i].value("sub_max", json(1.0)),
               "must be at least " + element(child(drag_at, "sub_min"), a) + " = " +
                   format_number(drag.sub_min[a]));
    const json& path = r.required(v[i], drag_at, "path",
                                  "give the path: [{\"t\": seconds, \"offset\": [x, y, z]}]");
    const std::string path_at = child(drag_at, "path");
    if (!path.is_array() || path.empty() || path.size() > kMaxDragKeys)
      r.fail(path_at, path,
             "must be a list of 1 to " + std::to_string(kMaxDragKeys) +
                 " keys {\"t\": seconds, \"offset\": [x, y, z]} by increasing t");
    for (size_t k = 0; k < path.size(); ++k) {
      const std::string key_at = element(path_at, k);
      r.require_object(path[k], key_at, "{\"t\": seconds, \"offset\": [x, y, z]}");
      r.check_keys(path[k], key_at, {"t", "offset"});
      DragKey key;
      key.t = r.number(r.required(path[k], key_at, "t", "give the key's time in seconds"),
                       child(key_at, "t"), closed(0, 1e9));
      if (!drag.path.empty() && !(key.t > drag.path.back().t))
        r.fail(child(key_at, "t"), path[k]["t"],
               "must be later than the key before (t = " + format_number(drag.path.back().t) + ")");
      key.offset = box.direction_to_local(
          r.vec3(r.required(path[k], key_at, "offset",
                            "give the offset from rest [x, y, z] in object units"),
                 child(key_at, "offset"), coordinate));
      drag.path.push_back(key);
    }
    out.push_back(std::move(drag));
  }
  return out;
}

// Integer parameters of the simulation.
void check_simulation(const JsonReader& r, const json& j, const std::string& field,
                      const DeformerSpec& d) {
  for (const auto& [key, value] :
       {std::pair<const char*, double>{"resolution", d.sim_resolution}, {"steps", d.sim_steps}})
    if (value != std::floor(value)) r.fail(child(field, key), j[key], "must be a whole number");
}

// The box faces the mesh part crosses: those where its signed distance is > 0 at a sample of a
// lattice of `resolution` cells along the box's longest side.
std::array<bool, 6> crossed_faces(const Eigen::Vector3d& h, const SimulationInput& part,
                                  int resolution) {
  std::array<bool, 6> faces{};
  if (!part.signed_distance) return faces;
  const double cell = 2.0 * h.maxCoeff() / std::max(1, resolution);
  Eigen::Vector3i n;
  for (int a = 0; a < 3; ++a) n[a] = std::max(1, static_cast<int>(std::lround(2.0 * h[a] / cell)));
  for (int f = 0; f < 6; ++f) {
    const int axis = f / 2, u = (axis + 1) % 3, v = (axis + 2) % 3;
    for (int i = 0; i <= n[u] && !faces[f]; ++i)
      for (int j = 0; j <= n[v] && !faces[f]; ++j) {
        Eigen::Vector3d q;
        q[axis] = (f % 2) ? h[axis] : -h[axis];
        q[u] = -h[u] + 2.0 * h[u] * i / n[u];
        q[v] = -h[v] + 2.0 * h[v] * j / n[v];
        faces[f] = part.signed_distance(q) > 0.0;
      }
  }
  return faces;
}

}  // namespace

FromMeshParams from_mesh_params(const DeformerSpec& d, const Eigen::Vector3d& h,
                                const SimulationInput& part) {
  FromMeshParams params;
  params.resolution = static_cast<int>(d.fit_resolution);
  params.pinned = d.pinned_given ? d.pinned : crossed_faces(h, part, params.resolution);
  return params;
}

namespace {

DeformerType twist_type() {
  DeformerType t;
  t.name = "twist";
  t.summary =
      "rotation about an axis growing from 0 at the box's lower face to angle_deg at its "
      "upper face (Blender's Simple Deform, mode Twist)";
  t.params = {axis_param("the twist axis", "give one of x, y, z"),
              number_param("angle_deg", &DeformerSpec::angle_deg, Interval{}, "degrees",
                           "the angle at the upper face; any finite value (several turns)",
                           "give the angle in degrees")};
  t.make = [](const DeformerSpec& d, const Eigen::Vector3d& h, std::vector<std::string>*) {
    return make_twist(h, static_cast<Axis>(d.axis), d.angle_deg);
  };
  t.examples = {{{"axis", "y"}, {"angle_deg", 360}}, {{"axis", "x"}, {"angle_deg", -90}}};
  return t;
}

DeformerType bend_type() {
  DeformerType t;
  t.name = "bend";
  t.summary =
      "bend about an axis through the box centre, the box's lower face fixed (Blender's "
      "Simple Deform, mode Bend)";
  t.params = {axis_param("the bend axis", "give one of x, y, z"),
              number_param("angle_deg", &DeformerSpec::angle_deg, {-360.0, 360.0, true, true},
                           "degrees", "the bend angle over the box", "give the angle in degrees")};
  t.make = [](const DeformerSpec& d, const Eigen::Vector3d& h, std::vector<std::string>*) {
    return make_bend(h, static_cast<Axis>(d.axis), d.angle_deg);
  };
  t.examples = {{{"axis", "z"}, {"angle_deg", 90}}, {{"axis", "x"}, {"angle_deg", -200}}};
  return t;
}

DeformerType taper_type() {
  DeformerType t;
  t.name = "taper";
  t.summary =
      "scale across an axis by 1 + factor t, t from 0 at the box's lower face to 1 at "
      "its upper face (Blender's Simple Deform, mode Taper)";
  t.params = {axis_param("the taper axis", "give one of x, y, z"),
              number_param("factor", &DeformerSpec::factor, {-1.0, 10.0, true, false}, "",
                           "Blender's factor: the relative change of the width at the upper "
                           "face",
                           "give the taper factor, e.g. 0.8")};
  t.make = [](const DeformerSpec& d, const Eigen::Vector3d& h, std::vector<std::string>*) {
    return make_taper(h, static_cast<Axis>(d.axis), d.factor);
  };
  t.examples = {{{"axis", "y"}, {"factor", 0.8}}, {{"axis", "z"}, {"factor", -0.6}}};
  return t;
}

DeformerType stretch_type() {
  DeformerType t;
  t.name = "stretch";
  t.summary =
      "stretch along an axis with the matching squeeze across it, by the square of the "
      "coordinate in object units, as Blender does (Simple Deform, mode Stretch)";
  t.params = {axis_param("the stretch axis", "give one of x, y, z"),
              number_param("factor", &DeformerSpec::factor, Interval{}, "",
                           "Blender's factor; the box's length along the axis bounds it "
                           "(the error says how)",
                           "give the stretch factor, e.g. 0.5")};
  t.make = [](const DeformerSpec& d, const Eigen::Vector3d& h, std::vector<std::string>*) {
    return make_stretch(h, static_cast<Axis>(d.axis), d.factor);
  };
  t.examples = {{{"axis", "y"}, {"factor", 0.5}}, {{"axis", "x"}, {"factor", -0.3}}};
  return t;
}

DeformerType detail_type() {
  DeformerType t;
  t.name = "detail";
  t.summary =
      "a seeded vector noise displacement of at most `scale`, windowed to 0 on the box faces; "
      "in a list it comes last and is added to the list's inverse displacement, as Correa & "
      "Silver add textures for detail (section 4)";
  t.params = {
      number_param("scale", &DeformerSpec::scale, {0.0, kMaxCoordinate, false, false, true},
                   "object units",
                   "the largest displacement; at most 1/2 over the noise's Lipschitz bound, so "
                   "that it never folds (the error gives the limit)",
                   "give the detail's displacement in object units, e.g. 0.1"),
      number_param("wavelength", &DeformerSpec::wavelength,
                   {0.0, kMaxCoordinate, false, false, true}, "object units",
                   "the noise's mean wavelength, also the width of the window's falloff at the "
                   "faces; 0 = a quarter of the box's shortest side",
                   "", "0"),
      number_param("seed", &DeformerSpec::seed, closed(0, 4294967295.0), "",
                   "picks the noise: a whole number", "", "1")};
  t.check = [](const JsonReader& r, const json& j, const std::string& field,
               const DeformerSpec& d) {
    if (d.seed != std::floor(d.seed))
      r.fail(child(field, "seed"), j["seed"], "must be a whole number in [0, 4294967295]");
  };
  t.make = [](const DeformerSpec& d, const Eigen::Vector3d& h, std::vector<std::string>*) {
    const double wavelength = d.wavelength > 0.0 ? d.wavelength : 0.5 * h.minCoeff();
    return make_detail(h, d.scale, wavelength, static_cast<std::uint64_t>(d.seed));
  };
  t.examples = {{{"scale", 0.02}, {"wavelength", 0.5}, {"seed", 7}},
                {{"scale", 0.03}},
                {{"scale", 0.015}, {"wavelength", 0.3}, {"seed", 4294967295.0}}};
  return t;
}

DeformerType peel_type() {
  DeformerType t;
  t.name = "peel";
  t.summary =
      "a layer of the box cut from one face and curled away about an axis (Correa & "
      "Silver, section 5)";
  t.cuts = true;
  t.params = {axis_param("the curl axis", "give the curl axis, one of x, y, z"),
              from_param("the face the layer is peeled from, on another axis than `axis`"),
              number_param("angle_deg", &DeformerSpec::angle_deg, {0.0, 180.0, true, false},
                           "degrees", "how far the flap curls", "give the curl angle in degrees"),
              number_param("thickness", &DeformerSpec::thickness, kPositive, "object units",
                           "the layer's thickness, below 2 h of the face's axis",
                           "give the layer thickness in object units"),
              number_param("radius", &DeformerSpec::radius, kPositive, "object units",
                           "the curl radius", "give the curl radius in object units"),
              number_param("hinge", &DeformerSpec::hinge, Interval{}, "object units",
                           "where the flap starts along the peel direction, in [-h, h)", "", "0")};
  t.check = check_from_face;
  t.make = [](const DeformerSpec& d, const Eigen::Vector3d& h, std::vector<std::string>*) {
    return make_peel(h, static_cast<Axis>(d.axis),
                     Face{static_cast<Axis>(d.from_axis), d.from_side}, d.angle_deg, d.thickness,
                     d.radius, d.hinge);
  };
  t.examples = {
      {{"axis", "z"}, {"from", "+y"}, {"angle_deg", 120}, {"thickness", 0.4}, {"radius", 0.6}},
      {{"axis", "x"},
       {"from", "-z"},
       {"angle_deg", 60},
       {"thickness", 0.3},
       {"radius", 1.0},
       {"hinge", -0.5}}};
  return t;
}

DeformerType incision_type() {
  DeformerType t;
  t.name = "incision";
  t.summary =
      "a planar cut from one face, pushed open into a wedge-shaped gap (Correa & Silver, "
      "section 5)";
  t.cuts = true;
  t.params = {
      axis_param("the normal of the cut plane", "give the normal of the cut plane, one of x, y, z"),
      from_param("the face the cut enters through, on another axis than `axis`"),
      number_param("depth", &DeformerSpec::depth, kPositive, "object units",
                   "how far the cut reaches from its face, up to 2 h of that axis",
                   "give the depth of the cut in object units"),
      number_param("opening", &DeformerSpec::opening, kPositive, "object units",
                   "the gap's width at the face, below 2 h of `axis`",
                   "give the width of the gap in object units")};
  t.check = check_from_face;
  t.make = [](const DeformerSpec& d, const Eigen::Vector3d& h, std::vector<std::string>*) {
    return make_incision(h, static_cast<Axis>(d.axis),
                         Face{static_cast<Axis>(d.from_axis), d.from_side}, d.depth, d.opening);
  };
  t.examples = {{{"axis", "x"}, {"from", "+y"}, {"depth", 1.5}, {"opening", 0.5}},
                {{"axis", "z"}, {"from", "-x"}, {"depth", 0.8}, {"opening", 0.3}}};
  return t;
}

DeformerType box_cut_type() {
  DeformerType t;
  t.name = "box_cut";
  t.summary =
      "removes a sub-box of the box, optionally only a wedge of it about an axis through "
      "the centre; moves nothing";
  t.cuts = true;
  ParamDecl sub_min;
  sub_min.key = "sub_min";
  sub_min.kind = ParamKind::Fractions;
  sub_min.meaning = "the removed sub-box's lower corner, fractions of the box (0 = min face)";
  sub_min.default_text = "[0, 0, 0]";
  sub_min.field = &DeformerSpec::sub_min;
  ParamDecl sub_max = sub_min;
  sub_max.key = "sub_max";
  sub_max.meaning = "its upper corner (1 = max face)";
  sub_max.default_text = "[1, 1, 1]";
  sub_max.field = &DeformerSpec::sub_max;
  ParamDecl wedge;
  wedge.key = "wedge";
  wedge.kind = ParamKind::Group;
  wedge.meaning = "only the wedge of the sub-box from from_deg over angle_deg about axis";
  wedge.default_text = "none";
  wedge.group_hint = "{\"axis\": \"y\", \"from_deg\": 0, \"angle_deg\": 90}";
  ParamDecl wedge_axis = axis_param("the wedge's axis", "give the wedge's axis, one of x, y, z");
  wedge_axis.field = &DeformerSpec::wedge_axis;
  wedge.children = {
      wedge_axis,
      number_param("from_deg", &DeformerSpec::wedge_from_deg, Interval{}, "degrees",
                   "where the wedge starts", "", "0"),
      number_param("angle_deg", &DeformerSpec::wedge_angle_deg, {0.0, 180.0, true, false},
                   "degrees", "the wedge's angle", "give the wedge's angle in degrees")};
  t.params = {sub_min, sub_max, wedge};
  t.check = check_sub_box;
  t.make = [](const DeformerSpec& d, const Eigen::Vector3d& h,
              std::vector<std::string>*) -> std::unique_ptr<Deformer> {
    BoxCutParams params;
    params.sub_min = d.sub_min;
    params.sub_max = d.sub_max;
    params.wedge_axis = static_cast<Axis>(d.wedge_axis);
    params.wedge_from_deg = d.wedge_from_deg;
    params.wedge_angle_deg = d.wedge_angle_deg;
    return make_box_cut(h, params);
  };
  t.examples = {{{"sub_min", {0.5, 0.5, 0.0}}},
                {{"sub_min", {0, 0.3, 0}},
                 {"sub_max", {1, 1, 0.8}},
                 {"wedge", {{"axis", "y"}, {"from_deg", 10}, {"angle_deg", 90}}}}};
  return t;
}

DeformerType groove_type() {
  DeformerType t;
  t.name = "groove";
  t.summary =
      "a round cut: removes the ring farther than radius from an axis through the centre, "
      "within a slab of width about the centre; moves nothing";
  t.cuts = true;
  t.params = {axis_param("the groove's axis", "give the groove's axis, one of x, y, z"),
              number_param("radius", &DeformerSpec::radius, kPositive, "object units",
                           "the groove's inner radius: what lies farther from the axis goes",
                           "give the groove's inner radius in object units"),
              // The slab's width along the axis, held in the spec's `opening`.
              number_param("width", &DeformerSpec::opening, kPositive, "object units",
                           "the groove's width along the axis, up to 2 h of that axis",
                           "give the groove's width in object units")};
  t.make = [](const DeformerSpec& d, const Eigen::Vector3d& h, std::vector<std::string>*) {
    return make_groove(h, static_cast<Axis>(d.axis), d.radius, d.opening);
  };
  t.examples = {{{"axis", "y"}, {"radius", 0.6}, {"width", 0.5}},
                {{"axis", "x"}, {"radius", 0.8}, {"width", 1.2}}};
  return t;
}

DeformerType control_points_type() {
  DeformerType t;
  t.name = "control_points";
  t.summary =
      "source -> target pairs interpolated by radial basis functions (global r^3 with an "
      "affine part, or Wendland C2 within a radius), pinned faces exact";
  ParamDecl points;
  points.key = "points";
  points.kind = ParamKind::Points;
  points.required = true;
  points.unit = "object coordinates";
  points.meaning = "1 to 1024 pairs {\"from\": [x, y, z], \"to\": [x, y, z]}, each from in the box";
  points.hint = "give a list of {\"from\": [x, y, z], \"to\": [x, y, z]} pairs";
  ParamDecl pinned;
  pinned.key = "pinned";
  pinned.kind = ParamKind::Faces;
  pinned.meaning = "box faces held fixed, e.g. [\"-y\"]";
  pinned.default_text = "[]";
  t.params = {points,
              number_param("radius", &DeformerSpec::influence_radius,
                           {0.0, kMaxCoordinate, false, false, true}, "object units",
                           "each point's radius of influence; 0 = the whole box", "", "0"),
              pinned};
  t.make = [](const DeformerSpec& d, const Eigen::Vector3d& h, std::vector<std::string>* w) {
    std::vector<ControlPoint> points;
    for (const PointPair& p : d.points) points.push_back({p.source, p.target});
    return make_control_points(h, std::move(points), d.influence_radius, d.pinned, w);
  };
  t.examples = {{{"points", {{{"from", {0, 1.0, 0}}, {"to", {0.3, 1.2, 0}}}}}, {"pinned", {"-y"}}},
                {{"points",
                  {{{"from", {0.5, 0.5, 0}}, {"to", {0.7, 0.4, 0.1}}},
                   {{"from", {-0.5, 0.8, 0.2}}, {"to", {-0.5, 1.0, 0.2}}}}},
                 {"radius", 1.2}}};
  return t;
}

DeformerType simulation_type() {
  DeformerType t;
  t.name = "simulation";
  t.summary =
      "a mass-spring body over the mesh part (Mosegaard & Sorensen's 18-neighbour grid, or "
      "Kuhn tetrahedra as in Tejada & Ertl), run from rest under gravity, pins and drags; "
      "its last state deforms the part (docs/simulation.md)";
  ParamDecl model;
  model.key = "model";
  model.kind = ParamKind::Choice;
  model.choices = sim_model_names();
  model.meaning = "grid: springs to 18 neighbours, trilinear F; tets: Kuhn tetrahedra, linear F";
  model.default_text = "grid";
  model.field = &DeformerSpec::sim_model;
  ParamDecl integrator = model;
  integrator.key = "integrator";
  integrator.choices = sim_integrator_names();
  integrator.meaning = "how a step is taken (docs/physics.md)";
  integrator.default_text = "implicit_euler";
  integrator.field = &DeformerSpec::sim_integrator;
  ParamDecl gravity;
  gravity.key = "gravity";
  gravity.kind = ParamKind::Direction;
  gravity.range = closed(-1e9, 1e9);
  gravity.unit = "object units / s^2";
  gravity.meaning = "acceleration of gravity, object axes";
  gravity.default_text = "[0, -9.81, 0]";
  gravity.field = &DeformerSpec::gravity;
  ParamDecl pins;
  pins.key = "pins";
  pins.kind = ParamKind::Faces;
  pins.meaning = "box faces whose nodes are held at rest";
  pins.default_text = "the faces the mesh crosses";
  ParamDecl drags;
  drags.key = "drags";
  drags.kind = ParamKind::Drags;
  drags.unit = "object units, s";
  drags.meaning =
      "nodes in a sub-box (fractions, like box_cut) moved along a path of "
      "{\"t\", \"offset\"} keys";
  drags.default_text = "[]";
  t.params = {
      model,
      number_param("resolution", &DeformerSpec::sim_resolution, closed(2, 128), "cells",
                   "lattice cells along the box's longest side", "", "16"),
      number_param("margin", &DeformerSpec::sim_margin, {0.0, kMaxCoordinate, false, false, true},
                   "object units", "how far outside the mesh the body reaches", "",
                   "the cell diagonal"),
      number_param("density", &DeformerSpec::density, {0.0, 1e9, true, false}, "mass / unit^3",
                   "mass per volume (lumped on the nodes)", "", "1000"),
      number_param("ks", &DeformerSpec::ks, {0.0, 1e9, true, false}, "force / unit",
                   "spring stiffness (Tejada & Ertl's ks; Mosegaard & Sorensen's k is 2 ks)",
                   "give the spring stiffness in force per object unit, e.g. 3e4"),
      number_param("kd", &DeformerSpec::kd, closed(0, 1e9), "force s / unit",
                   "damping of the relative velocity of each spring's two nodes", "", "0"),
      integrator,
      number_param("dt", &DeformerSpec::dt, {0.0, 1.0, true, false}, "s", "time step", "", "0.01"),
      number_param("steps", &DeformerSpec::sim_steps, closed(1, 100000), "",
                   "steps run from rest; the last state deforms the part", "", "100"),
      gravity,
      pins,
      drags};
  t.check = check_simulation;
  t.make_on_mesh = [](const DeformerSpec& d, const Eigen::Vector3d& h, const SimulationInput& part,
                      std::vector<std::string>* w,
                      Interrupter* interrupter) -> std::unique_ptr<Deformer> {
    Simulation sim(simulation_params(d), h, part, w, interrupter);
    sim.run(0, nullptr, interrupter);
    return sim.deformer(sim.positions());
  };
  t.examples = {
      {{"ks", 3e4}, {"steps", 20}, {"gravity", {0, -2, 0}}},
      {{"model", "tets"},
       {"ks", 1e4},
       {"resolution", 8},
       {"steps", 10},
       {"pins", {"-y"}},
       {"drags",
        {{{"sub_min", {0, 0.9, 0}}, {"path", {{{"t", 0.1}, {"offset", {0.05, 0, 0}}}}}}}}}};
  return t;
}

DeformerType from_mesh_type() {
  DeformerType t;
  t.name = "from_mesh";
  t.summary =
      "a deformation authored elsewhere: a deformed copy of the mesh (same vertices, same "
      "order) or a glTF morph target, its vertex pairs in the box fitted by a smooth field "
      "over the box (docs/from_mesh.md)";
  ParamDecl target;
  target.key = "target";
  target.kind = ParamKind::File;
  target.required = true;
  target.meaning =
      "the deformed copy: a mesh file with the scene mesh's vertices in the same order "
      "(PLY, OBJ, STL, OFF, glTF, ...), a glTF whose morph target `morph` is read, or a folder "
      "of such copies, a sequence (`frame`)";
  target.hint = "give the deformed copy of the mesh, relative to the scene file";
  target.field = &DeformerSpec::target;
  target.folder_ok = true;
  ParamDecl pins;
  pins.key = "pins";
  pins.kind = ParamKind::Faces;
  pins.meaning = "box faces held at rest; default: the faces the mesh crosses";
  pins.default_text = "the faces the mesh crosses";
  t.params = {target,
              number_param("morph", &DeformerSpec::morph, closed(0, 1e6), "",
                           "the morph target of `target` to read (glTF); none: the file's own "
                           "vertices",
                           "", "none"),
              number_param("weight", &DeformerSpec::weight, closed(-10, 10), "",
                           "the morph target's weight: base + weight (target - base)", "", "1"),
              number_param("resolution", &DeformerSpec::fit_resolution, closed(4, 256), "cells",
                           "the fit's lattice cells along the box's longest side", "", "48"),
              number_param("frame", &DeformerSpec::frame, closed(0, 1e6), "",
                           "the frame of a sequence: the copy of a folder `target` (its mesh "
                           "files in name order), or morph target `frame` of a glTF at weight "
                           "1; a fraction blends the two copies on either side",
                           "", "none (a folder: 0)"),
              pins};
  t.check = [](const JsonReader& r, const json& j, const std::string& field,
               const DeformerSpec& d) {
    if (j.contains("morph") && d.morph != std::floor(d.morph))
      r.fail(child(field, "morph"), j["morph"], "must be an integer >= 0");
    if (j.contains("weight") && !j.contains("morph"))
      r.fail(child(field, "weight"), j["weight"], "applies to a morph target: give \"morph\"");
    if (j.contains("frame") && j.contains("morph"))
      r.fail(child(field, "frame"), j["frame"],
             "picks a morph target itself (frame k is morph target k): give one of \"frame\" "
             "and \"morph\"");
    std::error_code ec;
    if (j.contains("morph") && std::filesystem::is_directory(d.target, ec))
      r.fail(child(field, "morph"), j["morph"],
             "applies to a glTF target; the target is a folder of copies: give \"frame\"");
    if (j.contains("resolution") && d.fit_resolution != std::floor(d.fit_resolution))
      r.fail(child(field, "resolution"), j["resolution"], "must be an integer in [4, 256]");
  };
  t.make_on_mesh = [](const DeformerSpec& d, const Eigen::Vector3d& h, const SimulationInput& part,
                      std::vector<std::string>* w,
                      Interrupter* interrupter) -> std::unique_ptr<Deformer> {
    const FromMeshParams params = from_mesh_params(d, h, part);
    if (part.sources.empty() || part.sources.size() != part.targets.size())
      throw Error("target: no vertex of the mesh lies in the box: nothing to fit");
    std::vector<PointPair> pairs(part.sources.size());
    for (size_t i = 0; i < pairs.size(); ++i) pairs[i] = {part.sources[i], part.targets[i]};
    (void)w;
    return make_from_mesh(h, pairs, params, nullptr, interrupter);
  };
  t.examples = {{{"target", "examples/meshes/bunny.ply"}, {"resolution", 16}}};
  return t;
}

// The registry, in the order of the docs: one function per type.
std::vector<DeformerType> make_registry() {
  return {twist_type(),  bend_type(),           taper_type(),      stretch_type(),
          detail_type(), peel_type(),           incision_type(),   box_cut_type(),
          groove_type(), control_points_type(), simulation_type(), from_mesh_type()};
}

std::string allowed_type_list() { return deformer_type_names(); }

void read_params(const JsonReader& r, const json& j, const std::string& field,
                 const std::vector<ParamDecl>& params, const Box& box, DeformerSpec& d,
                 bool with_type) {
  std::vector<std::string> keys;
  if (with_type) keys.push_back("type");
  for (const ParamDecl& p : params) keys.push_back(p.key);
  for (const auto& [key, value] : j.items()) {
    bool known = false;
    for (const std::string& k : keys) known = known || key == k;
    if (known) continue;
    std::string list;
    for (const std::string& k : keys) list += (list.empty() ? "" : ", ") + k;
    r.fail(child(field, key), value, "unknown field; allowed: " + list);
  }
  for (const ParamDecl& p : params) {
    const std::string at = child(field, p.key);
    if (!j.contains(p.key)) {
      if (p.required) r.missing(at, p.hint);
      continue;
    }
    const json& v = j[p.key];
    switch (p.kind) {
      case ParamKind::Number:
        d.*std::get<double DeformerSpec::*>(p.field) = r.number(v, at, p.range);
        break;
      case ParamKind::Axis: {
        const std::string axis = r.one_of(v, at, {"x", "y", "z"});
        d.*std::get<int DeformerSpec::*>(p.field) = axis[0] - 'x';
        break;
      }
      case ParamKind::Face: {
        const std::string face = r.one_of(v, at, {"+x", "-x", "+y", "-y", "+z", "-z"});
        d.from_side = face[0] == '+' ? 1 : -1;
        d.from_axis = face[1] - 'x';
        break;
      }
      case ParamKind::Fractions:
        d.*std::get<Eigen::Vector3d DeformerSpec::*>(p.field) = r.vec3(v, at, closed(0, 1));
        break;
      case ParamKind::Faces: {
        const std::string allowed = "must be a list of box faces such as [\"-y\", \"+y\"]";
        if (!v.is_array()) r.fail(at, v, allowed);
        for (size_t i = 0; i < v.size(); ++i) {
          const std::string face =
              r.one_of(v[i], element(at, i), {"-x", "+x", "-y", "+y", "-z", "+z"});
          d.pinned[2 * (face[1] - 'x') + (face[0] == '+' ? 1 : 0)] = true;
        }
        d.pinned_given = true;
        break;
      }
      case ParamKind::Choice: {
        const std::string name = r.one_of(v, at, p.choices);
        const auto it = std::find(p.choices.begin(), p.choices.end(), name);
        d.*std::get<int DeformerSpec::*>(p.field) = static_cast<int>(it - p.choices.begin());
        break;
      }
      case ParamKind::Direction:
        d.*std::get<Eigen::Vector3d DeformerSpec::*>(p.field) =
            box.direction_to_local(r.vec3(v, at, p.range));
        break;
      case ParamKind::Drags:
        d.drags = read_drags(r, v, at, box);
        break;
      case ParamKind::Points: {
        if (!v.is_array() || v.empty() || v.size() > kMaxControlPoints)
          r.fail(at, v,
                 "must be a list of 1 to " + std::to_string(kMaxControlPoints) +
                     " {\"from\": [x, y, z], \"to\": [x, y, z]} pairs (object coordinates)");
        const Interval coordinate = closed(-kMaxCoordinate, kMaxCoordinate);
        for (size_t i = 0; i < v.size(); ++i) {
          const std::string pair_at = element(at, i);
          r.require_object(v[i], pair_at, "{\"from\": [x, y, z], \"to\": [x, y, z]}");
          r.check_keys(v[i], pair_at, {"from", "to"});
          PointPair pair;
          pair.source = box.to_local(r.vec3(
              r.required(v[i], pair_at, "from", "give the point's undeformed position [x, y, z]"),
              child(pair_at, "from"), coordinate));
          const Eigen::Vector3d outside = pair.source.cwiseAbs() - box.half_extents * (1.0 + 1e-9);
          if (outside.maxCoeff() > 0.0)
            r.fail(child(pair_at, "from"), v[i]["from"],
                   "must lie in the box (centre " + format_vector(box.centre) + ", half_extents " +
                       format_vector(box.half_extents) +
                       "): a control point moves the part of the mesh inside its box");
          pair.target = box.to_local(r.vec3(
              r.required(v[i], pair_at, "to", "give the point's deformed position [x, y, z]"),
              child(pair_at, "to"), coordinate));
          d.points.push_back(pair);
        }
        break;
      }
      case ParamKind::Group:
        r.require_object(v, at, p.group_hint);
        read_params(r, v, at, p.children, box, d, false);
        break;
      case ParamKind::File:
        d.*std::get<std::string DeformerSpec::*>(p.field) =
            r.existing_file(v, at, std::filesystem::path(r.file()).parent_path(), p.folder_ok)
                .string();
        break;
    }
  }
}

// Appends every declared parameter's value, exactly, to `out`.
void key_params(const std::vector<ParamDecl>& params, const DeformerSpec& d, std::string& out) {
  char buf[40];
  auto number = [&](double x) {
    std::snprintf(buf, sizeof buf, "%a ", x);
    out += buf;
  };
  for (const ParamDecl& p : params) {
    out += p.key + "=";
    switch (p.kind) {
      case ParamKind::Number:
        number(d.*std::get<double DeformerSpec::*>(p.field));
        break;
      case ParamKind::Axis:
        out += std::to_string(d.*std::get<int DeformerSpec::*>(p.field)) + " ";
        break;
      case ParamKind::Face:
        out += std::to_string(d.from_axis) + std::to_string(d.from_side) + " ";
        break;
      case ParamKind::Fractions:
        for (int i = 0; i < 3; ++i)
          number((d.*std::get<Eigen::Vector3d DeformerSpec::*>(p.field))[i]);
        break;
      case ParamKind::Faces:
        for (bool b : d.pinned) out += b ? '1' : '0';
        out += d.pinned_given ? " " : "(automatic) ";
        break;
      case ParamKind::Choice:
        out += std::to_string(d.*std::get<int DeformerSpec::*>(p.field)) + " ";
        break;
      case ParamKind::Direction:
        for (int i = 0; i < 3; ++i)
          number((d.*std::get<Eigen::Vector3d DeformerSpec::*>(p.field))[i]);
        break;
      case ParamKind::Drags:
        out += std::to_string(d.drags.size()) + ": ";
        for (const Drag& drag : d.drags) {
          for (int i = 0; i < 3; ++i) {
            number(drag.sub_min[i]);
            number(drag.sub_max[i]);
          }
          out += std::to_string(drag.path.size()) + " keys ";
          for (const DragKey& key : drag.path) {
            number(key.t);
            for (int i = 0; i < 3; ++i) number(key.offset[i]);
          }
        }
        break;
      case ParamKind::Points:
        out += std::to_string(d.points.size()) + ": ";
        for (const PointPair& pair : d.points)
          for (int i = 0; i < 3; ++i) {
            number(pair.source[i]);
            number(pair.target[i]);
          }
        break;
      case ParamKind::Group:
        out += "{ ";
        key_params(p.children, d, out);
        out += "} ";
        break;
      case ParamKind::File:
        // The path; the bake adds the file's content hash to the keys of what it reads.
        out += d.*std::get<std::string DeformerSpec::*>(p.field) + " ";
        break;
    }
  }
}

void describe_params(const std::vector<ParamDecl>& params, const DeformerSpec& d,
                     std::string& out) {
  for (const ParamDecl& p : params) {
    std::string value;
    switch (p.kind) {
      case ParamKind::Number:
        value = format_number(d.*std::get<double DeformerSpec::*>(p.field));
        break;
      case ParamKind::Axis:
        value = std::string(1, char('x' + d.*std::get<int DeformerSpec::*>(p.field)));
        break;
      case ParamKind::Face:
        value = std::string(d.from_side > 0 ? "+" : "-") + char('x' + d.from_axis);
        break;
      case ParamKind::Fractions:
        value = format_vector(d.*std::get<Eigen::Vector3d DeformerSpec::*>(p.field));
        break;
      case ParamKind::Faces:
        if (!d.pinned_given && !p.default_text.empty() && p.default_text[0] != '[') {
          value = "automatic";
          break;
        }
        value = "[";
        for (int f = 0; f < 6; ++f)
          if (d.pinned[f]) value += (value.size() > 1 ? ", " : "") + face_name(face_of(f));
        value += "]";
        break;
      case ParamKind::Choice:
        value = p.choices.at(d.*std::get<int DeformerSpec::*>(p.field));
        break;
      case ParamKind::Direction:
        value = format_vector(d.*std::get<Eigen::Vector3d DeformerSpec::*>(p.field));
        break;
      case ParamKind::Drags:
        value = std::to_string(d.drags.size()) + " drags";
        break;
      case ParamKind::Points:
        value = std::to_string(d.points.size()) + " pairs";
        break;
      case ParamKind::Group: {
        std::string inner;
        describe_params(p.children, d, inner);
        value = "{" + inner + "}";
        break;
      }
      case ParamKind::File: {
        const std::filesystem::path path(d.*std::get<std::string DeformerSpec::*>(p.field));
        value = (path.has_filename() ? path : path.parent_path()).filename().string();
        break;
      }
    }
    out += (out.empty() ? "" : ", ") + p.key + " " + value;
  }
}

std::string range_text(const ParamDecl& p) {
  switch (p.kind) {
    case ParamKind::Number: {
      const Interval& r = p.range;
      if (!std::isfinite(r.lo) && !std::isfinite(r.hi)) return "any finite number";
      if (r.hi_is_sanity_limit || !std::isfinite(r.hi))
        return std::string(r.lo_open ? "> " : ">= ") + format_number(r.lo);
      return std::string(r.lo_open ? "(" : "[") + format_number(r.lo) + ", " + format_number(r.hi) +
             (r.hi_open ? ")" : "]");
    }
    case ParamKind::Axis:
      return "`x`, `y`, `z`";
    case ParamKind::Face:
      return "`+x`, `-x`, `+y`, `-y`, `+z`, `-z`";
    case ParamKind::Fractions:
      return "3 numbers in [0, 1]";
    case ParamKind::Faces:
      return "list of faces";
    case ParamKind::Points:
      return "1 to 1024 pairs";
    case ParamKind::Choice: {
      std::string out;
      for (const std::string& c : p.choices) out += (out.empty() ? "`" : ", `") + c + "`";
      return out;
    }
    case ParamKind::Direction:
      return "3 finite numbers";
    case ParamKind::Drags:
      return "list of drags";
    case ParamKind::Group:
      return "object";
    case ParamKind::File:
      return p.folder_ok ? "a mesh file or a folder of them" : "a mesh file";
  }
  return "";
}

void table_rows(const std::string& type, const std::string& prefix,
                const std::vector<ParamDecl>& params, std::string& out) {
  for (const ParamDecl& p : params) {
    out += "| " + type + " | `" + prefix + p.key + "` | " + range_text(p) + " | " +
           (p.unit.empty() ? "" : p.unit) + " | " +
           (p.required ? std::string("required") : "`" + p.default_text + "`") + " | " + p.meaning +
           " |\n";
    if (p.kind == ParamKind::Group) table_rows(type, prefix + p.key + ".", p.children, out);
  }
}

}  // namespace

const std::vector<DeformerType>& deformer_types() {
  static const std::vector<DeformerType> types = make_registry();
  return types;
}

const DeformerType* find_deformer_type(std::string_view name) {
  for (const DeformerType& t : deformer_types())
    if (t.name == name) return &t;
  return nullptr;
}

namespace {
std::string names_where(int cuts) {  // -1: all
  std::string list;
  for (const DeformerType& t : deformer_types())
    if (cuts < 0 || t.cuts == (cuts == 1)) list += (list.empty() ? "" : ", ") + t.name;
  return list;
}
}  // namespace

std::string deformer_type_names() { return names_where(-1); }
std::string cut_type_names() { return names_where(1); }
std::string continuous_type_names() { return names_where(0); }

DeformerSpec read_deformer(const JsonReader& r, const json& j, const std::string& field,
                           const Box& box) {
  r.require_object(j, field, "{\"type\": ..., \"axis\": ..., \"angle_deg\": ...}");
  const json& type = r.required(j, field, "type", "give one of " + allowed_type_list());
  const DeformerType* entry =
      type.is_string() ? find_deformer_type(type.get<std::string>()) : nullptr;
  if (!entry) r.fail(child(field, "type"), type, "must be one of " + allowed_type_list());
  DeformerSpec d;
  d.type = entry->name;
  read_params(r, j, field, entry->params, box, d, true);
  if (entry->check) entry->check(r, j, field, d);
  return d;
}

bool is_cut(const DeformerSpec& d) {
  const DeformerType* t = find_deformer_type(d.type);
  return t && t->cuts;
}

std::string deformer_key(const DeformerSpec& d) {
  const DeformerType* t = find_deformer_type(d.type);
  if (!t) throw Error("type = \"" + d.type + "\": must be one of " + allowed_type_list());
  std::string out = d.type + " ";
  key_params(t->params, d, out);
  return out;
}

std::string describe_spec(const DeformerSpec& d) {
  const DeformerType* t = find_deformer_type(d.type);
  if (!t) return d.type;
  std::string params;
  describe_params(t->params, d, params);
  return d.type + ": " + params;
}

std::unique_ptr<Deformer> make_deformer(const DeformerSpec& d, const Eigen::Vector3d& h,
                                        std::vector<std::string>* warnings) {
  const DeformerType* t = find_deformer_type(d.type);
  if (!t) throw Error("type = \"" + d.type + "\": must be one of " + allowed_type_list());
  if (!t->make)
    throw Error("type = \"" + d.type +
                "\": is built over the mesh part inside its box, in a bake (not on its own)");
  return t->make(d, h, warnings);
}

bool needs_mesh(const DeformerSpec& d) {
  const DeformerType* t = find_deformer_type(d.type);
  return t && t->make_on_mesh;
}

std::unique_ptr<Deformer> make_deformer(const DeformerSpec& d, const Eigen::Vector3d& h,
                                        const SimulationInput& part,
                                        std::vector<std::string>* warnings,
                                        Interrupter* interrupter) {
  const DeformerType* t = find_deformer_type(d.type);
  if (!t) throw Error("type = \"" + d.type + "\": must be one of " + allowed_type_list());
  if (!t->make_on_mesh) return t->make(d, h, warnings);
  return t->make_on_mesh(d, h, part, warnings, interrupter);
}

SimulationParams simulation_params(const DeformerSpec& d) {
  SimulationParams p;
  p.model = static_cast<SimModel>(d.sim_model);
  p.integrator = static_cast<SimIntegrator>(d.sim_integrator);
  p.resolution = static_cast<int>(d.sim_resolution);
  p.margin = d.sim_margin;
  p.density = d.density;
  p.ks = d.ks;
  p.kd = d.kd;
  p.dt = d.dt;
  p.steps = static_cast<long>(d.sim_steps);
  p.gravity = d.gravity;
  p.pinned = d.pinned;
  p.pins_given = d.pinned_given;
  p.drags = d.drags;
  return p;
}

std::string deformer_table() {
  std::string out =
      "| type | parameter | allowed | unit | default | meaning |\n"
      "| --- | --- | --- | --- | --- | --- |\n";
  for (const DeformerType& t : deformer_types()) {
    std::string name = "`" + t.name + "`" + (t.cuts ? " (cut)" : "");
    table_rows(name, "", t.params, out);
  }
  out += "\n";
  for (const DeformerType& t : deformer_types())
    out += "- `" + t.name + "`" + (t.cuts ? " (a cut)" : "") + ": " + t.summary + ".\n";
  return out;
}

}  // namespace raywarp
