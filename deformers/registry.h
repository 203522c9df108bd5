// The deformer registry: one entry per deformer type, declaring once its name, what it is, whether
// it cuts, its parameters (JSON key, kind, range, unit, default, meaning) and its factory.
//
// Everything that depends on a deformer's parameters is derived from that declaration:
//   read_deformer      the scene reader (unknown keys, missing required keys, ranges: every
//                      error names the file, the field, the value and what is allowed)
//   deformer_key       the bake cache's key (every declared parameter, numbers exact), so a
//                      parameter added to a declaration can never serve a stale bake
//   describe_spec      the one-line description in reports
//   deformer_table     the table of docs/scene.md (`raywarp deformers --markdown` prints it; a
//                      test checks the document holds it verbatim)
//   is_cut             cut or continuous, in one place
// and the deformer contract suite (tests/deformer_contract_test.cpp) runs every entry's examples.
// docs/adding_a_deformer.md walks through adding a type.
#pragma once
#include <Eigen/Core>
#include <array>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "base/box.h"
#include "base/interrupt.h"
#include "base/json_reader.h"
#include "deformers/deformer.h"
#include "deformers/from_mesh.h"
#include "deformers/simulation.h"

namespace raywarp {

// A control point of the "control_points" deformer: where a point of the undeformed mesh goes, in
// the box's local frame (the scene gives object coordinates; read_deformer converts them).
struct PointPair {
  Eigen::Vector3d source = Eigen::Vector3d::Zero();
  Eigen::Vector3d target = Eigen::Vector3d::Zero();
};

// The parameters of one deformer as read from a scene. Each type's declaration says which fields
// it reads; the others keep their defaults and are not part of its cache key.
struct DeformerSpec {
  std::string type;      // a registered type name (deformer_types())
  int axis = 1;          // 0 = x, 1 = y, 2 = z (twist, bend, taper, stretch: the axis; peel: the
                         // curl axis; incision: the normal of the cut plane)
  double angle_deg = 0;  // twist: any; bend: (-360, 360); peel: (0, 180]
  double factor = 0;     // taper, stretch: Blender's factor
  // detail: the noise's displacement bound and wavelength (0: a quarter of the box's shortest
  // side), object units, and its seed (a whole number).
  double scale = 0, wavelength = 0, seed = 1;
  // peel and incision: the face the cut enters through, e.g. "+y" (axis, side).
  int from_axis = 1;
  int from_side = 1;
  double thickness = 0;  // peel: layer thickness
  double radius = 0;     // peel: curl radius
  double hinge = 0;      // peel: where the flap starts along the peel direction
  double depth = 0;      // incision: how far the cut reaches from its face
  double opening = 0;    // incision: width of the gap at the face
  // box_cut: the removed sub-box as fractions of the box along its local axes, 0 = min face,
  // 1 = max face, and an optional wedge about an axis through the box centre.
  Eigen::Vector3d sub_min = Eigen::Vector3d::Zero();
  Eigen::Vector3d sub_max = Eigen::Vector3d::Ones();
  int wedge_axis = 1;
  double wedge_from_deg = 0;
  double wedge_angle_deg = 0;  // 0 = no wedge
  // control_points: the pairs (box frame), the radius of influence of each point (object units;
  // 0 = every point acts on the whole box) and the faces held fixed, in face order.
  std::vector<PointPair> points;
  double influence_radius = 0;
  std::array<bool, 6> pinned{};  // control_points, simulation: the faces held fixed
  bool pinned_given = false;     // whether the scene listed them (simulation: else automatic)
  // simulation (deformers/simulation.h): numbers as read, converted by simulation_params.
  int sim_model = 0;           // index in sim_model_names()
  int sim_integrator = 3;      // index in sim_integrator_names()
  double sim_resolution = 16;  // cells along the box's longest side
  double sim_margin = -1;      // < 0: the cell diagonal
  double density = 1000, ks = 0, kd = 0, dt = 0.01, sim_steps = 100;
  Eigen::Vector3d gravity = Eigen::Vector3d(0, -9.81, 0);  // box frame
  std::vector<Drag> drags;                                 // box frame
  // from_mesh: the deformed copy of the mesh (resolved against the scene file's folder), the
  // morph target read from it (-1: the file's own vertices) and its weight, the fit's lattice.
  // `target` may be a folder of copies, a sequence; `frame` (< 0: none) picks a copy of it, or
  // morph target `frame` of a glTF (library/mesh_pairs.h).
  std::string target;
  double morph = -1, weight = 1, fit_resolution = 48, frame = -1;
};

// How a parameter is written in JSON and where it is stored.
enum class ParamKind {
  Number,     // a JSON number in `range`                      -> double field
  Axis,       // "x" | "y" | "z"                                -> int field (0, 1, 2)
  Face,       // "+x" | "-x" | ... , on another axis than `axis`  -> from_axis, from_side
  Fractions,  // [a, b, c], each in [0, 1]                      -> Vector3d field
  Faces,      // a list of faces, e.g. ["-y", "+y"]             -> array<bool, 6> in face order
  Points,     // [{"from": [x, y, z], "to": [x, y, z]}, ...], object coordinates -> points
  Choice,     // one of `choices`                               -> int field (its index)
  Direction,  // [x, y, z], object axes, turned into the box frame -> Vector3d field
  Drags,      // [{"sub_min": .., "sub_max": .., "path": [{"t": s, "offset": [x, y, z]}]}] -> drags
  Group,      // a JSON object of `children`, optional as a whole
  File,       // a path relative to the scene file, which must exist (a folder too where
              // `folder_ok`)                                  -> string field (resolved)
};

struct ParamDecl {
  std::string key;  // the JSON key
  ParamKind kind = ParamKind::Number;
  bool required = false;
  Interval range;            // Number
  std::string unit;          // for the table: "degrees", "object units", "" ...
  std::string meaning;       // for the table
  std::string hint;          // said when a required parameter is missing
  std::string default_text;  // for the table, when not required
  std::variant<std::monostate, double DeformerSpec::*, int DeformerSpec::*,
               Eigen::Vector3d DeformerSpec::*, std::string DeformerSpec::*>
      field;
  std::vector<ParamDecl> children;   // Group
  std::string group_hint;            // Group: an example object for messages
  std::vector<std::string> choices;  // Choice
  bool folder_ok = false;            // File: a folder is accepted too
};

struct DeformerType {
  std::string name;
  std::string summary;  // one line: what it does and whose convention it follows
  bool cuts = false;    // a cut: an alpha map and a cut mode; never composed in a list
  std::vector<ParamDecl> params;
  // Relations between parameters, after each was read and range checked (may be empty).
  std::function<void(const JsonReader&, const nlohmann::json&, const std::string& field,
                     const DeformerSpec&)>
      check;
  // The deformer over a box of these half extents; `warnings` receives what building it found
  // worth saying. Throws Error on parameters the factory refuses.
  std::function<std::unique_ptr<Deformer>(const DeformerSpec&, const Eigen::Vector3d& half_extents,
                                          std::vector<std::string>* warnings)>
      make;
  // Instead of `make`, for a type built over the mesh part inside the box (the simulation): the
  // deformer given the part's signed distance; long work polls `interrupter`.
  std::function<std::unique_ptr<Deformer>(
      const DeformerSpec&, const Eigen::Vector3d& half_extents, const SimulationInput& part,
      std::vector<std::string>* warnings, Interrupter* interrupter)>
      make_on_mesh;
  // Parameter objects (without "type") of typical uses, in a box of half extents (1, 1.5, 1):
  // the contract suite runs every one, and the docs show the first.
  std::vector<nlohmann::json> examples;
};

// Every registered type, in the order of the docs.
const std::vector<DeformerType>& deformer_types();
// The entry named `name`, or null.
const DeformerType* find_deformer_type(std::string_view name);
// "twist, bend, ..." in registry order: every type, the cuts, the continuous ones.
std::string deformer_type_names();
std::string cut_type_names();
std::string continuous_type_names();

// Reads one deformer object at `field` (e.g. "boxes[0].deformer") of the document `r` reads;
// `box` converts control points from object coordinates into its frame.
DeformerSpec read_deformer(const JsonReader& r, const nlohmann::json& j, const std::string& field,
                           const Box& box);
bool is_cut(const DeformerSpec& d);
// Every declared parameter of d's type, numbers exact.
std::string deformer_key(const DeformerSpec& d);
// "twist: axis y, angle_deg 360".
std::string describe_spec(const DeformerSpec& d);
// The deformer d asks for over a box of half extents h. Throws Error (without a field prefix),
// also for a type built over the mesh part (needs_mesh), which takes the overload below.
std::unique_ptr<Deformer> make_deformer(const DeformerSpec& d, const Eigen::Vector3d& h,
                                        std::vector<std::string>* warnings = nullptr);
// Whether d's type is built over the mesh part inside its box (DeformerType::make_on_mesh).
bool needs_mesh(const DeformerSpec& d);
// The deformer over the mesh part `part` (any type: those that do not need it ignore it).
std::unique_ptr<Deformer> make_deformer(const DeformerSpec& d, const Eigen::Vector3d& h,
                                        const SimulationInput& part,
                                        std::vector<std::string>* warnings = nullptr,
                                        Interrupter* interrupter = nullptr);
// A simulation spec's parameters (type "simulation").
SimulationParams simulation_params(const DeformerSpec& d);
// A from_mesh spec's fit parameters: its resolution and pinned faces (as given, else the faces
// the mesh part crosses, where part.signed_distance > 0 on a face's lattice samples).
FromMeshParams from_mesh_params(const DeformerSpec& d, const Eigen::Vector3d& h,
                                const SimulationInput& part);
// The Markdown table of every type and parameter (docs/scene.md holds it).
std::string deformer_table();

}  // namespace raywarp
