#include "cli/engine_godot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <regex>
#include <sstream>

#include "base/error.h"
#include "cli/engine_templates.h"
#include "gl/shader_sources.h"
#include "library/image.h"
#include "library/scene.h"

namespace raywarp {

namespace {

using nlohmann::json;

// The textures of an export by their sidecar name, with the sampler that reads each.
struct TextureRole {
  const char* name;
  const char* uniform;
};
constexpr TextureRole kRoles[] = {{"deformation", "u_deformation"},
                                  {"distance", "u_sdf"},
                                  {"depth", "u_depth"},
                                  {"alpha", "u_alpha"},
                                  {"step_bounds_d", "u_bricks"},
                                  {"step_bounds_sdf", "u_sdf_bricks"}};

// Godot's sampler hints of each texture of the march: linear filtering within level 0 (the
// shaders read textureLod(..., 0.0): no mipmaps), clamp to edge; the step-bound bricks are read
// texel by texel; a cylindrical texture's angle is periodic (Godot has one wrap mode for all
// three axes, so its radius and height wrap too: the march returns before reading beyond them).
std::string sampler_hints(const std::string& name, bool cylindrical) {
  if (name == "u_bricks" || name == "u_sdf_bricks") return "filter_nearest, repeat_disable";
  if (name == "u_deformation" || name == "u_alpha")
    return cylindrical ? "filter_linear, repeat_enable" : "filter_linear, repeat_disable";
  if (name == "u_sdf" || name == "u_depth") return "filter_linear, repeat_disable";
  throw Error("march.glsl's sampler " + name +
              " has no Godot sampler hints (cli/engine_godot.cpp, sampler_hints)");
}

// The range hints of the render settings' integers (library/scene.h's bounds).
std::string range_hint(const std::string& name) {
  if (name == "u_max_steps") return "hint_range(1, 100000)";
  if (name == "u_refine_steps") return "hint_range(0, 64)";
  return "";
}

// A float literal of Godot's shading language (always with a point: Godot converts no int to
// float).
std::string godot_float(double x, const std::string& what) {
  if (!std::isfinite(x)) throw Error(what + " = " + std::to_string(x) + ": not a finite number");
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.9g", x);
  std::string s = buf;
  if (s.find('.') == std::string::npos) {
    const size_t e = s.find_first_of("eE");
    s.insert(e == std::string::npos ? s.size() : e, ".0");
  }
  return s;
}

// A number of Godot's text resources and GDScript.
std::string number(double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.9g", x);
  return buf;
}

double number_of(const json& v, const std::string& what) {
  if (!v.is_number()) throw Error(what + " = " + v.dump() + ": not a number");
  return v.get<double>();
}

// `v` as the default of a uniform of Godot type `type`.
std::string godot_value(const std::string& type, const json& v, const std::string& name) {
  const std::string what = "the value of " + name;
  if (type == "float") return godot_float(number_of(v, what), what);
  if (type == "int") {
    const double x = number_of(v, what);
    if (x != std::floor(x)) throw Error(what + " = " + v.dump() + ": not an integer");
    return std::to_string(static_cast<long long>(x));
  }
  static const std::regex vec(R"(^vec([234])$)");
  std::smatch m;
  if (std::regex_match(type, m, vec)) {
    const size_t n = std::stoul(m[1]);
    if (!v.is_array() || v.size() != n)
      throw Error(what + " = " + v.dump() + ": a " + type + " takes " + std::to_string(n) +
                  " numbers");
    std::string s = type + "(";
    for (size_t i = 0; i < n; ++i) s += (i ? ", " : "") + godot_float(number_of(v[i], what), what);
    return s + ")";
  }
  throw Error(what + ": raywarp writes no default for a " + type + " uniform");
}

std::string trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r"), b = s.find_last_not_of(" \t\r");
  return a == std::string::npos ? "" : s.substr(a, b - a + 1);
}

std::string join(const std::vector<std::string>& v, const std::string& sep) {
  std::string s;
  for (size_t i = 0; i < v.size(); ++i) s += (i ? sep : "") + v[i];
  return s;
}

std::string features(const gl::Variant& variant) {
  std::vector<std::string> macros;
  for (const gl::FeatureInfo& f : gl::kFeatures)
    if (variant.has(f.feature)) macros.push_back(f.macro);
  return join(macros, ", ");
}

// raywarp's linear colour `name` of `values` (RenderSettings' default where absent), sRGB-encoded
// as Godot's source_color uniforms take it: "r, g, b".
std::string srgb_colour(const json& values, const std::string& name) {
  const RenderSettings defaults;
  const Eigen::Vector3d fallback = name == "u_albedo"          ? defaults.colour
                                   : name == "u_inside_colour" ? defaults.inside_colour
                                                               : defaults.cut_colour;
  std::string s;
  for (int c = 0; c < 3; ++c) {
    const double linear = values.is_object() && values.contains(name)
                              ? number_of(values.at(name).at(c), "the value of " + name)
                              : fallback[c];
    s += (c ? ", " : "") + godot_float(srgb_encode(linear), name);
  }
  return s;
}

std::string vec3_text(double x, double y, double z) {
  return number(x) + ", " + number(y) + ", " + number(z);
}

void check_sidecar(const json& sidecar) {
  if (!sidecar.is_object() || sidecar.value("schema", "") != "raywarp.export" ||
      sidecar.value("version", 0) != 1)
    throw Error("a Godot bundle needs a raywarp.export version 1 sidecar");
}

}  // namespace

GodotMarch godot_march(const gl::Variant& variant, const json& values) {
  return godot_rewrite(gl::assemble_shader("march.glsl", variant.defines()), variant, values);
}

GodotMarch godot_rewrite(const std::string& glsl, const gl::Variant& variant, const json& values) {
  const std::string where = "march.glsl (" + features(variant) + ")";
  const bool cylindrical = variant.has(gl::Feature::Cylindrical);
  std::vector<std::string> feature_defines;
  for (const gl::FeatureInfo& f : gl::kFeatures)
    if (variant.has(f.feature)) feature_defines.push_back(std::string("#define ") + f.macro);

  static const std::regex uniform(R"(^uniform\s+(\w+)\s+(\w+)\s*(?:\[\s*(\d+)\s*\])?\s*;$)");
  static const std::regex gl_name(R"(\bgl_\w+)");
  static const std::regex layout(R"(\blayout\s*\()");
  static const std::regex function_header(R"(^\w+(\s+\w+)*\s+\w+\s*\()");
  GodotMarch out;
  std::istringstream in(glsl);
  std::string line;
  int depth = 0, paren = 0;  // braces and parentheses open before the line
  while (std::getline(in, line)) {
    const std::string t = trim(line);
    std::smatch m;
    if (t.empty()) continue;
    if (std::regex_search(t, m, gl_name))
      throw Error(where + ": `" + t + "` uses " + m[0].str() + ", which Godot has not");
    if (std::regex_search(t, layout))
      throw Error(where + ": `" + t + "`: Godot's shading language has no layout()");
    if (t[0] == '#') {
      if (t.rfind("#version", 0) == 0 || t.rfind("#line", 0) == 0) continue;
      if (std::find(feature_defines.begin(), feature_defines.end(), t) != feature_defines.end())
        continue;  // resolved by the assembly
      if (t.rfind("#define ", 0) == 0) {
        out.text += line + "\n";
        continue;
      }
      throw Error(where + ": `" + t + "`: a directive the Godot rewrite does not carry");
    }
    if (depth == 0 && t.rfind("precision ", 0) == 0) continue;  // Godot has no precision statement
    if (depth == 0 && std::regex_match(t, m, uniform)) {
      GodotUniform u;
      u.type = m[1];
      u.name = m[2];
      u.array = m[3].matched ? std::stoi(m[3]) : 0;
      const bool sampler = u.type.find("sampler") != std::string::npos;
      u.hints = sampler ? sampler_hints(u.name, cylindrical) : range_hint(u.name);
      const bool has_value = values.is_object() && values.contains(u.name) && !sampler && !u.array;
      if (has_value) {
        json v = values.at(u.name);
        if (u.name == "u_lipschitz" && v.is_number() && v.get<double>() < 0.0)
          v = 1e30;  // unknown (-1 in the sidecar): no skipping by f
        u.value = godot_value(u.type, v, u.name);
      } else if (!sampler) {
        out.unset.push_back(u.name);
      }
      // Integer samplers have no default precision in GLSL ES 3.00 (Godot's Compatibility
      // renderer); march.glsl has none today.
      const bool highp = sampler && (u.type[0] == 'i' || u.type[0] == 'u');
      std::string decl = "uniform " + std::string(highp ? "highp " : "") + u.type + " " + u.name;
      if (u.array) decl += "[" + std::to_string(u.array) + "]";
      if (!u.hints.empty()) decl += " : " + u.hints;
      if (!u.value.empty()) decl += " = " + u.value;
      out.text += decl + ";\n";
      out.uniforms.push_back(u);
      continue;
    }
    if (depth == 0 && paren == 0) {
      const bool header = std::regex_search(t, function_header) && t.back() != ';';
      const bool allowed = header || t.rfind("const ", 0) == 0 || t.rfind("struct ", 0) == 0 ||
                           t == "{" || t == "}" || t == "};";
      if (!allowed)
        throw Error(where + ": `" + t + "`: Godot allows no mutable global (nor a prototype)");
      if ((header || t.rfind("struct ", 0) == 0) && !out.text.empty()) out.text += "\n";
    }
    for (char c : t) paren += c == '(' ? 1 : c == ')' ? -1 : 0;
    for (char c : t) depth += c == '{' ? 1 : c == '}' ? -1 : 0;
    out.text += line + "\n";
  }
  if (depth != 0) throw Error(where + ": unbalanced braces after the assembly");
  if (out.text.find("raywarp_cast(") == std::string::npos)
    throw Error(where + ": the assembled march has no raywarp_cast");
  return out;
}

std::string godot_box_shader(const gl::Variant& variant, const json& values,
                             const std::string& stem) {
  const GodotMarch march = godot_march(variant, values);
  std::string text = march.text;
  while (!text.empty() && text.back() == '\n') text.pop_back();
  return fill_template("godot/raywarp_box.gdshader",
                       {{"STEM", stem},
                        {"FEATURES", features(variant)},
                        {"UNSET", march.unset.empty() ? "none" : join(march.unset, ", ")},
                        {"MARCH", text},
                        {"ALBEDO", "vec3(" + srgb_colour(values, "u_albedo") + ")"},
                        {"INSIDE", "vec3(" + srgb_colour(values, "u_inside_colour") + ")"},
                        {"CUT", "vec3(" + srgb_colour(values, "u_cut_colour") + ")"}});
}

std::string godot_remainder_shader(int box_count) {
  if (box_count < 1 || box_count > 16)
    throw Error("godot_remainder_shader: " + std::to_string(box_count) +
                " boxes; raywarp draws 1 to 16");
  const json defaults = nullptr;
  return fill_template("godot/raywarp_remainder.gdshader",
                       {{"BOX_COUNT", std::to_string(box_count)},
                        {"ALBEDO", "vec3(" + srgb_colour(defaults, "u_albedo") + ")"},
                        {"INSIDE", "vec3(" + srgb_colour(defaults, "u_inside_colour") + ")"}});
}

std::string godot_folder(const std::string& stem) { return "res://raywarp/" + stem; }

GodotFileNames godot_file_names(const std::string& stem) {
  return {stem + ".gdshader", stem + ".remainder.gdshader", "raywarp_import_" + stem + ".gd",
          stem + ".tscn"};
}

std::string godot_import_script(const json& sidecar, const std::string& stem) {
  check_sidecar(sidecar);
  const json& textures = sidecar.at("textures");
  json list = json::array();
  for (const TextureRole& role : kRoles) {
    if (!textures.contains(role.name)) continue;
    const json& t = textures.at(role.name);
    json entry = {{"name", role.name},      {"uniform", role.uniform},
                  {"dims", t.at("dims")},   {"channels", t.at("channels").size()},
                  {"scale", t.at("scale")}, {"exr", nullptr},
                  {"dds", nullptr},         {"resource", stem + "." + role.name + ".res"}};
    for (const json& f : sidecar.at("files")) {
      if (f.value("texture", "") != role.name) continue;
      const std::string format = f.value("format", "");
      if (format == "atlas-exr")
        entry["exr"] = {{"file", f.at("file")},
                        {"size", f.at("size")},
                        {"tiles", f.at("tiles")},
                        {"border", f.value("border", 0)}};
      else if (format == "dds")
        entry["dds"] = f.at("file");
    }
    list.push_back(entry);
  }
  if (list.empty()) throw Error("the sidecar of " + stem + " lists no texture a Godot box reads");
  return fill_template(
      "godot/raywarp_import.gd",
      {{"STEM", stem}, {"FOLDER", godot_folder(stem)}, {"TEXTURES", list.dump(1, '\t')}});
}

std::string godot_scene(const json& sidecar, const std::string& stem, const json& values,
                        const std::string& mesh_file) {
  check_sidecar(sidecar);
  const json& box = sidecar.at("box");
  const json& R = box.at("rotation");
  const json& c = box.at("centre");
  const json& h = box.at("half_extents");
  auto at = [](const json& v, int i, int j = -1) {
    return number_of(j < 0 ? v.at(i) : v.at(i).at(j), "the sidecar's box");
  };
  std::string transform;  // Godot's Transform3D text: the basis by rows, then the origin
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) transform += number(at(R, r, k)) + ", ";
  transform += vec3_text(at(c, 0), at(c, 1), at(c, 2));
  const json& region = sidecar.at("render").at("ray_cast_region");
  double lower[3], size[3];
  for (int a = 0; a < 3; ++a) {
    lower[a] = number_of(region.at("min").at(a), "ray_cast_region") * at(h, a);
    size[a] = number_of(region.at("max").at(a), "ray_cast_region") * at(h, a) - lower[a];
  }
  std::string mesh = mesh_file;
  if (mesh.empty())
    mesh = std::filesystem::path(sidecar.at("source").at("mesh").get<std::string>())
               .filename()
               .replace_extension(".obj")
               .string();
  std::string resources, parameters;
  const json& textures = sidecar.at("textures");
  for (const TextureRole& role : kRoles) {
    if (!textures.contains(role.name)) continue;
    const std::map<std::string, std::string> fields = {
        {"FOLDER", godot_folder(stem)},
        {"RESOURCE", stem + "." + role.name + ".res"},
        {"UNIFORM", role.uniform}};
    resources += fill_template("godot/parts/texture_resource.tscn.part", fields);
    parameters += fill_template("godot/parts/texture_parameter.tscn.part", fields);
  }
  while (!resources.empty() && resources.back() == '\n') resources.pop_back();
  while (!parameters.empty() && parameters.back() == '\n') parameters.pop_back();
  const GodotFileNames names = godot_file_names(stem);
  return fill_template(
      "godot/raywarp_scene.tscn",
      {{"STEM", stem},
       {"FOLDER", godot_folder(stem)},
       {"BOX_SHADER", names.box_shader},
       {"REMAINDER_SHADER", names.remainder_shader},
       {"MESH", mesh},
       {"TEXTURE_RESOURCES", resources},
       {"TEXTURE_PARAMETERS", parameters},
       {"ALBEDO", srgb_colour(values, "u_albedo")},
       {"INSIDE", srgb_colour(values, "u_inside_colour")},
       {"CUT", srgb_colour(values, "u_cut_colour")},
       {"TWO_SIDED", sidecar.at("render").value("has_cut", false) ? "true" : "false"},
       {"BOX_CENTRE", vec3_text(at(c, 0), at(c, 1), at(c, 2))},
       {"BOX_X", vec3_text(at(R, 0, 0), at(R, 1, 0), at(R, 2, 0))},
       {"BOX_Y", vec3_text(at(R, 0, 1), at(R, 1, 1), at(R, 2, 1))},
       {"BOX_Z", vec3_text(at(R, 0, 2), at(R, 1, 2), at(R, 2, 2))},
       {"HALF_EXTENTS", vec3_text(at(h, 0), at(h, 1), at(h, 2))},
       {"BOX_TRANSFORM", transform},
       {"REGION_AABB",
        vec3_text(lower[0], lower[1], lower[2]) + ", " + vec3_text(size[0], size[1], size[2])}});
}

}  // namespace raywarp
