#include "cli/engine_bundles.h"

#include <Eigen/Core>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <vector>

#include "base/atomic_file.h"
#include "base/error.h"
#include "cli/engine_shaders.h"
#include "cli/engine_templates.h"
#include "cli/viewer_assets.h"
#include "library/scene.h"

namespace raywarp {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// The textures a box may export, with the sampler of the ray-cast shader each one feeds.
struct TextureRole {
  const char* name;
  const char* sampler;
  bool nearest;  // the step bounds are read NEAREST
};
constexpr TextureRole kRoles[] = {{"deformation", "u_deformation", false},
                                  {"distance", "u_sdf", false},
                                  {"depth", "u_depth", false},
                                  {"alpha", "u_alpha", false},
                                  {"step_bounds_d", "u_bricks", true},
                                  {"step_bounds_sdf", "u_sdf_bricks", true}};

bool is_nearest(const std::string& name) {
  for (const TextureRole& r : kRoles)
    if (name == r.name) return r.nearest;
  return false;
}

// A number as JSON writes it: the shortest text that reads back to the same double.
std::string num(double x) { return json(x).dump(); }
std::string num(const json& x) { return x.dump(); }

// One exported texture as the sidecar describes it.
struct Tex {
  std::string name;
  json info;  // sidecar textures[name]
  std::vector<int> dims() const { return info.at("dims").get<std::vector<int>>(); }
  std::vector<double> scale() const { return info.at("scale").get<std::vector<double>>(); }
  size_t channels() const { return info.at("scale").size(); }
};

std::vector<Tex> textures_of(const json& side) {
  std::vector<Tex> out;
  const json& t = side.at("textures");
  for (const TextureRole& r : kRoles)
    if (t.contains(r.name)) out.push_back({r.name, t.at(r.name)});
  for (auto it = t.begin(); it != t.end(); ++it)  // any other texture, in the sidecar's order
    if (std::none_of(out.begin(), out.end(), [&](const Tex& x) { return x.name == it.key(); }))
      out.push_back({it.key(), it.value()});
  return out;
}

const json* file_of(const json& side, const std::string& texture, const std::string& format) {
  for (const json& f : side.at("files"))
    if (f.value("texture", "") == texture && f.value("format", "") == format) return &f;
  return nullptr;
}

bool has_format(const json& side, const std::string& format) {
  for (const json& f : side.at("files"))
    if (f.value("format", "") == format) return true;
  return false;
}

// The atlas of `texture`: EXR when written, else the 16-bit PNG, else null.
const json* atlas_of(const json& side, const std::string& texture) {
  if (const json* f = file_of(side, texture, "atlas-exr")) return f;
  return file_of(side, texture, "atlas-png");
}

std::string csv(const std::vector<int>& v, const char* sep = " x ") {
  std::string s;
  for (size_t i = 0; i < v.size(); ++i) s += (i ? sep : "") + std::to_string(v[i]);
  return s;
}

std::string quoted_channels(const Tex& t) {
  std::string s;
  const json ch = t.info.value("channels", json::array());
  for (size_t i = 0; i < ch.size(); ++i) {
    static const char* rgba[] = {"R", "G", "B", "A"};
    s += std::string(i ? ", " : "") + (i < 4 ? rgba[i] : "?") + " = `" + ch[i].get<std::string>() +
         "` (scale " + num(t.info.at("scale")[i]) + ")";
  }
  return s;
}

void write_text(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  write_file_atomic(path.string(), std::string_view(text));
}

// Escapes a string for a JavaScript, Python or C# double-quoted literal (ASCII names only).
std::string lit(const std::string& s) { return json(s).dump(); }

// ---- the parts every checklist shares ----------------------------------------------------------

std::string common_checklist(const json& side, const std::string& stem,
                             const std::vector<Tex>& texs) {
  std::ostringstream md;
  const json& box = side.at("box");
  md << "## The box\n\n"
     << "- Source: " << side.value("description", std::string("?")) << " (`" << stem
     << ".json`, schema `raywarp.export` version " << side.value("version", 0) << ").\n"
     << "- Box centre " << num(box.at("centre"))
     << ", half extents h = " << num(box.at("half_extents"))
     << " (object units), rotation (columns: the box axes) " << num(box.at("rotation")) << ".\n"
     << "- Box units: a box-frame point q (object units) is q / h, so the box is [-1, 1]^3. "
        "Each texture covers `region.min .. region.max` (box units); texel (i, j, k) has its "
        "centre at texture coordinate ((i, j, k) + 0.5) / dims. Memory order: channels, then x "
        "fastest, then y, then z.\n\n"
     << "## Textures\n\n"
     << "| texture | dims (x y z) | region min (box units) | region max | channels (object = "
        "stored * scale) | read |\n| --- | --- | --- | --- | --- | --- |\n";
  for (const Tex& t : texs)
    md << "| `" << t.name << "` | " << csv(t.dims()) << " | "
       << (t.info.contains("region") ? num(t.info.at("region").at("min"))
                                     : "none: six maps, sidecar `depth_cube`")
       << " | " << (t.info.contains("region") ? num(t.info.at("region").at("max")) : "") << " | "
       << quoted_channels(t) << " | " << (is_nearest(t.name) ? "NEAREST" : "LINEAR") << " |\n";
  md << "\nMeanings:\n\n";
  for (const Tex& t : texs)
    md << "- `" << t.name << "` (" << t.info.value("frame", std::string("?"))
       << " frame): " << t.info.value("meaning", std::string()) << "\n";
  md << "\n## Files in the export folder\n\n"
     << "| file | format | texture | storage | size / tiles | decode |\n"
     << "| --- | --- | --- | --- | --- | --- |\n";
  for (const json& f : side.at("files")) {
    md << "| `" << f.value("file", "") << "` | " << f.value("format", "") << " | "
       << f.value("texture", "") << " | " << f.value("storage", "") << " | ";
    if (f.contains("tiles"))
      md << num(f.at("size")) << " px, tiles " << num(f.at("tiles")) << ", border "
         << f.value("border", 0);
    md << " | ";
    if (f.contains("lo"))
      md << "stored = lo + code / 65535 * (hi - lo), lo = " << num(f.at("lo"))
         << ", hi = " << num(f.at("hi")) << "; then object = stored * scale";
    else if (f.value("format", "") == "vdb")
      md << f.value("grids", "");
    else
      md << "object = stored * scale";
    md << " |\n";
  }
  md << "\n## Settings every engine needs\n\n"
     << "- **Linear data, sRGB off.** The values are displacements and distances, not colours: an "
        "sRGB decode bends them.\n"
     << "- **Filtering linear (trilinear within level 0)**, the step bounds nearest.\n"
     << "- **Clamp to edge** on all three axes: repeating wraps the opposite face's displacement "
        "into the box.\n"
     << "- **No mipmaps.** A mip level averages the displacements of neighbouring texels, which "
        "is not the displacement of any point (and it averages validity and distances across the "
        "surface); sample level 0 only.\n"
     << "- **No resize, no compression** (no power-of-two rounding, no block compression, no "
        "texture streaming that drops levels): each texel is a sample at a known position, and "
        "block compression errors are displacement errors.\n"
     << "- **Decode**: object = stored * scale[channel] (scale above: the deformation's xyz "
        "scale is h, so D comes out in object units; its A is validity, scale 1, count it valid "
        "at >= 0.5). The 16-bit PNG first decodes its codes with lo/hi.\n\n";
  return md.str();
}

// What the engine should show for the orientation volume. `w_note` says how the engine's w
// relates to raywarp's (atlas routes add empty slices), `v_note` the vertical convention.
std::string orientation_section(const std::string& how, const std::string& v_note,
                                const std::string& w_note) {
  std::ostringstream md;
  md << "## Verify with the orientation test volume\n\n"
     << "`raywarp bake --orientation-test --out DIR --format all` writes `orientation.*` and "
        "`orientation.json`: 16 x 12 x 8 texels with R = u, G = v, B = w (the texture "
        "coordinate of each texel centre, (i + 0.5) / 16, (j + 0.5) / 12, (k + 0.5) / 8) and "
        "A = 1 except A = 0 in the 2 x 2 x 2 texels at texel (0, 0, 0). Import it "
     << how << ", then sample it:\n\n"
     << "| sample at (u, v, w) | expect RGBA |\n| --- | --- |\n"
     << "| (0.03125, 0.041667, 0.0625) (texel 0, 0, 0) | (0.03125, 0.041667, 0.0625, 0) |\n"
     << "| (0.96875, 0.041667, 0.0625) (texel 15, 0, 0) | (0.96875, 0.041667, 0.0625, 1) |\n"
     << "| (0.03125, 0.958333, 0.0625) (texel 0, 11, 0) | (0.03125, 0.958333, 0.0625, 1) |\n"
     << "| (0.03125, 0.041667, 0.9375) (texel 0, 0, 7) | (0.03125, 0.041667, 0.9375, 1) |\n"
     << "| (0.5, 0.5, 0.5) | (0.5, 0.5, 0.5, 1) |\n\n"
     << "R should grow along the engine's u, G along v, B along w. A swapped or flipped axis "
        "shows at once (G = 1 - v: a vertical flip; B out of order: slices mis-cut); a dark "
        "corner (A = 0) anywhere but at (0, 0, 0) names the flipped axes. "
     << v_note << " " << w_note << "\n";
  return md.str();
}

std::string missing_section(const std::vector<std::string>& missing, const std::string& why) {
  if (missing.empty()) return "";
  std::ostringstream md;
  md << "## Missing formats\n\n" << why << " Re-export with";
  for (const std::string& m : missing) md << " `" << m << "`";
  md << " (e.g. `raywarp bake SCENE --out DIR --format all`).\n\n";
  return md.str();
}

// The engines that cut a volume from an atlas make tiles_x * tiles_y slices, the last ones
// empty when nz is not a multiple: the texture coordinate w must be remapped.
std::string atlas_w_note(const std::vector<Tex>& texs, const json& side,
                         const std::string& engine) {
  std::ostringstream md;
  md << "**Slices and w.** " << engine
     << " makes one slice per tile, tiles_x * tiles_y of them, so where the last tile row is not "
        "full the volume has empty (zero) slices past slice nz - 1. Sample raywarp's w at "
        "w' = min(w * nz, nz - 0.5) / (tiles_x * tiles_y) (the clamp keeps the last slices' "
        "blend away from the zero slices):\n\n";
  for (const Tex& t : texs)
    if (const json* a = atlas_of(side, t.name)) {
      const int nz = t.dims()[2];
      const int tiles = a->at("tiles")[0].get<int>() * a->at("tiles")[1].get<int>();
      md << "- `" << t.name << "`: nz = " << nz << ", tiles " << num(a->at("tiles")) << " = "
         << tiles << " slices: "
         << (tiles == nz ? "none empty, w' = w"
                         : "w' = min(w * " + std::to_string(nz) + ", " + num(nz - 0.5) + ") / " +
                               std::to_string(tiles))
         << ".\n";
      if (a->value("border", 0) != 0)
        md << "  - border " << a->value("border", 0)
           << ": each slice then carries the border texels; re-export with `--atlas-border 0` "
              "for this engine.\n";
    }
  md << "\n";
  return md.str();
}

// ---- three.js ---------------------------------------------------------------------------------

}  // namespace

json box_uniform_values(const json& side) {
  const std::vector<double> h = side.at("box").at("half_extents").get<std::vector<double>>();
  const double hmax = *std::max_element(h.begin(), h.end());
  const json& render = side.at("render");
  auto times_h = [&](const json& v) {
    json out = json::array();
    for (int a = 0; a < 3; ++a) out.push_back(v.at(a).get<double>() * h[a]);
    return out;
  };
  struct Grid {
    json origin, size, spacing;
    double smallest = 0;
  };
  // A cylindrical box's D (unless it moves nothing) and A are over (theta, r, h), in the units
  // the sidecar's mapping gives.
  const json& mapping = side.contains("mapping") ? side.at("mapping") : json::object();
  const bool cylindrical = mapping.value("type", "cartesian") == "cylindrical";
  const bool moves_nothing = render.value("moves_nothing", false);
  auto over_cylinder = [&](const std::string& name) {
    return cylindrical && (name == "alpha" || (name == "deformation" && !moves_nothing));
  };
  auto times_units = [&](const json& v, const std::string& name) {
    if (!over_cylinder(name)) return times_h(v);
    json out = json::array();
    for (int a = 0; a < 3; ++a)
      out.push_back(v.at(a).get<double>() * mapping.at("units").at(a).get<double>());
    return out;
  };
  // The step of the shaders' central differences: a cylindrical texture's is its smallest of r's
  // and h's spacings on every axis (library/textures.h, deformation_step).
  auto difference_step = [&](const json& spacing, const std::string& name) {
    if (!over_cylinder(name)) return spacing;
    const double s = std::min(spacing[1].get<double>(), spacing[2].get<double>());
    return json{s, s, s};
  };
  auto grid = [&](const std::string& name) {
    const json& t = side.at("textures").at(name);
    Grid g;
    g.origin = times_units(t.at("region").at("min"), name);
    const json upper = times_units(t.at("region").at("max"), name);
    g.size = json::array();
    g.spacing = json::array();
    g.smallest = INFINITY;
    for (int a = 0; a < 3; ++a) {
      const double s = upper[a].get<double>() - g.origin[a].get<double>();
      g.size.push_back(s);
      const double sp = s / t.at("dims")[a].get<double>();
      g.spacing.push_back(sp);
      g.smallest = std::min(g.smallest, sp);
    }
    return g;
  };
  const json& tx = side.at("textures");
  json u;
  const json& R = side.at("box").at("rotation");
  const json& c = side.at("box").at("centre");
  json b2o = json::array();  // row-major 4x4
  for (int r = 0; r < 3; ++r) b2o.push_back({R[r][0], R[r][1], R[r][2], c[r]});
  b2o.push_back({0, 0, 0, 1});
  u["u_box_to_object"] = b2o;  // row-major; the module makes it a Matrix4
  u["u_box_to_object_dir"] = R;
  u["u_half_extents"] = h;
  // The consumers decode the textures when they load them (object units): no decode in the
  // shader (decode_scales gives the scales for one that does not).
  u["u_def_decode"] = {1.0, 1.0, 1.0, 1.0};
  u["u_sdf_decode"] = 1.0;
  u["u_alpha_decode"] = 1.0;
  if (cylindrical) {
    const int a = mapping.at("axis").get<std::string>()[0] - 'x';
    for (const auto& [name, axis] :
         {std::pair{"u_cyl_e_u", (a + 1) % 3}, std::pair{"u_cyl_e_v", (a + 2) % 3},
          std::pair{"u_cyl_e_a", a}}) {
      json e = {0.0, 0.0, 0.0};
      e[axis] = 1.0;
      u[name] = e;
    }
  }
  u["u_region_lower"] = times_h(render.at("ray_cast_region").at("min"));
  u["u_region_upper"] = times_h(render.at("ray_cast_region").at("max"));
  double voxel = 0;
  if (tx.contains("distance")) {
    const Grid g = grid("distance");
    u["u_sdf_origin"] = g.origin;
    u["u_sdf_size"] = g.size;
    voxel = g.smallest;
    u["u_sdf_spacing"] = voxel;
  }
  if (side.contains("depth_cube")) {  // the depth cube's maps, per axis (their -face's)
    const json& dc = side.at("depth_cube");
    voxel = 2.0 * hmax / dc.at("resolution").get<double>();
    u["u_sdf_spacing"] = voxel;
    for (int a = 0; a < 3; ++a) {
      const json& m = dc.at("maps").at(2 * a);
      const int ua = m.at("u_axis").get<std::string>()[0] - 'x';
      const int va = m.at("v_axis").get<std::string>()[0] - 'x';
      const std::string axis(1, "xyz"[a]);
      u["u_depth_origin_" + axis] = {m.at("origin")[0].get<double>() * h[ua],
                                     m.at("origin")[1].get<double>() * h[va]};
      u["u_depth_last_" + axis] = {m.at("texels")[0].get<int>() - 1,
                                   m.at("texels")[1].get<int>() - 1};
    }
    const json& dims = tx.at("depth").at("dims");
    u["u_depth_layer"] = {dims[0], dims[1]};
  }
  const double voxel_side = render.value("voxel_box_units", 0.0) * hmax;
  u["u_background"] = render.value("distance_background_voxels", 0.0) * voxel_side;
  json def_spacing;
  if (tx.contains("deformation")) {
    const Grid g = grid("deformation");
    u["u_def_origin"] = g.origin;
    u["u_def_size"] = g.size;
    u["u_def_spacing"] = def_spacing = difference_step(g.spacing, "deformation");
  }
  // H M H^-1, by its first three rows (the shaders' u_texture_map_x, _y, _z).
  const json& Ms = side.at("texture_map");
  for (int r = 0; r < 3; ++r) {
    json row = json::array();
    for (int k = 0; k < 4; ++k) {
      const double hk = k < 3 ? h[k] : 1.0;
      row.push_back(h[r] * Ms[r][k].get<double>() / hk);
    }
    u[std::string("u_texture_map_") + "xyz"[r]] = row;
  }
  const bool cut = render.value("has_cut", false);
  double cut_margin = 0;
  if (tx.contains("alpha")) {
    const Grid g = grid("alpha");
    u["u_alpha_origin"] = g.origin;
    u["u_alpha_size"] = g.size;
    u["u_alpha_spacing"] = difference_step(g.spacing, "alpha");
    if (cut) {
      auto norm = [](const json& v) {
        double s = 0;
        for (const auto& x : v) s += x.get<double>() * x.get<double>();
        return std::sqrt(s);
      };
      cut_margin =
          norm(u["u_alpha_spacing"]) + (def_spacing.is_null() ? 0.0 : 0.5 * norm(def_spacing));
    }
  }
  u["u_thickness"] = cut ? render.value("shell_thickness_voxels", 0.0) * voxel_side : 0.0;
  u["u_cut_margin"] = cut_margin;
  const double lip = render.value("lipschitz", -1.0);
  u["u_lipschitz"] = lip;  // -1: unknown, the module uploads Infinity
  u["u_seam"] = render.value("seam_voxels", 1.0) * voxel;
  if (tx.contains("step_bounds_d") && tx.contains("step_bounds_sdf")) {
    const Grid d = grid("step_bounds_d"), s = grid("step_bounds_sdf");
    u["u_brick_origin"] = d.origin;
    u["u_brick_spacing"] = d.spacing;
    u["u_sdf_brick_origin"] = s.origin;
    u["u_sdf_brick_spacing"] = s.smallest;
    const double vl =
        render.contains("step_bounds")
            ? render.at("step_bounds").value("validity_lipschitz_box_units", 0.0) / hmax
            : 0.0;
    u["u_inv_lipschitz_w"] = vl > 0 ? 1.0 / vl : 0.0;
  }
  return u;
}

namespace {

// The GLSL ES 3.00 shaders write_shader_bundle wrote beside the sidecar (raywarp library), if any:
// the box's fragment shader STEM.raycast.es.frag.glsl and the entry's vertex shader.
json find_es_shaders(const fs::path& dir, const std::string& stem) {
  const std::string frag = stem + ".raycast.es.frag.glsl";
  if (!fs::exists(dir / frag)) return nullptr;
  std::vector<std::string> bases = {stem};
  std::smatch m;
  static const std::regex box_suffix(R"(^(.*)_box[0-9]+$)");
  if (std::regex_match(stem, m, box_suffix)) bases.insert(bases.begin(), m[1].str());
  for (const std::string& b : bases) {
    const std::string vert = b + ".raycast.es.vert.glsl";
    if (fs::exists(dir / vert)) {
      json out = {{"vertex", vert}, {"fragment", frag}};
      if (fs::exists(dir / (b + ".shaders.md"))) out["uniforms"] = b + ".shaders.md";
      return out;
    }
  }
  return nullptr;
}

std::string threejs_module(const json& side, const std::string& stem, const std::vector<Tex>& texs,
                           const json& shaders) {
  json files = json::object(), tex_json = json::object();
  // A cylindrical box's D (unless it moves nothing) and A repeat: their angle is periodic.
  const bool cylindrical =
      side.contains("mapping") && side.at("mapping").value("type", "") == "cylindrical";
  const bool moves_nothing = side.at("render").value("moves_nothing", false);
  for (const Tex& t : texs) {
    tex_json[t.name] = {{"dims", t.info.at("dims")},
                        {"scale", t.info.at("scale")},
                        {"channels", t.info.value("channels", json::array())},
                        {"region", t.info.value("region", json())},
                        {"nearest", is_nearest(t.name)},
                        {"repeat", cylindrical && (t.name == "alpha" ||
                                                   (t.name == "deformation" && !moves_nothing))}};
    if (const json* f = file_of(side, t.name, "ktx2")) files[t.name] = f->at("file");
  }
  json samplers = json::object();
  for (const TextureRole& r : kRoles) samplers[r.name] = r.sampler;
  return fill_template("threejs/raywarp_box.js",
                       {{"STEM", stem},
                        {"STEM_LITERAL", lit(stem)},
                        {"DESCRIPTION", side.value("description", std::string())},
                        {"BOX", side.at("box").dump()},
                        {"TEXTURES", tex_json.dump()},
                        {"FILES", files.dump()},
                        {"SAMPLERS", samplers.dump()},
                        {"SHADERS", shaders.dump()},
                        {"BOX_UNIFORMS", box_uniform_values(side).dump()},
                        {"DEFAULT_SETTINGS", render_settings_to_json(RenderSettings{}).dump()}});
}

// ---- Unity ------------------------------------------------------------------------------------

std::string cs_ident(const std::string& s) {
  std::string out;
  for (char c : s) out += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  if (out.empty() || std::isdigit(static_cast<unsigned char>(out[0]))) out = "_" + out;
  return out;
}

// The import script of the volume route (template engines/unity/Editor/RaywarpImport.cs): each
// texture's file, the material property it fills, its scales, filter and wrap; the ray-cast region
// in Unity object space (raywarp's object space times the shader's default u_object_axes,
// (-1, 1, 1)) for the renderer's bounds.
std::string unity_volume_script(const std::string& stem, const json& side,
                                const std::vector<Tex>& texs, const std::string& format) {
  const json& mapping = side.contains("mapping") ? side.at("mapping") : json::object();
  const bool cylindrical = mapping.value("type", "cartesian") == "cylindrical";
  const bool moves_nothing = side.at("render").value("moves_nothing", false);
  std::string volumes;
  for (const Tex& t : texs) {
    const json* f = file_of(side, t.name, format);
    if (!f) continue;
    std::string property = t.name, scale;
    for (const TextureRole& r : kRoles)
      if (t.name == r.name) property = r.sampler;
    for (const auto& x : t.info.at("scale")) scale += (scale.empty() ? "" : ", ") + num(x) + "f";
    const bool repeat =
        cylindrical && (t.name == "alpha" || (t.name == "deformation" && !moves_nothing));
    volumes += std::string(volumes.empty() ? "" : ",\n") + "        new Volume(" +
               lit(f->at("file").get<std::string>()) + ", " + lit(property) + ", new float[] { " +
               scale + " }, " + (is_nearest(t.name) ? "true" : "false") + ", " +
               (repeat ? "true" : "false") + ")";
  }
  // The region's corners: box frame -> object space -> Unity object space.
  const json& R = side.at("box").at("rotation");
  const json& c = side.at("box").at("centre");
  const json& h = side.at("box").at("half_extents");
  const json& region = side.at("render").at("ray_cast_region");
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
  for (int corner = 0; corner < 8; ++corner) {
    Eigen::Vector3d q, p;
    for (int a = 0; a < 3; ++a)
      q[a] = region.at((corner >> a) & 1 ? "max" : "min").at(a).get<double>() * h[a].get<double>();
    for (int r = 0; r < 3; ++r) {
      p[r] = c[r].get<double>();
      for (int k = 0; k < 3; ++k) p[r] += R[r][k].get<double>() * q[k];
    }
    p.x() = -p.x();  // u_object_axes' default
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  auto vec = [](const Eigen::Vector3d& v) {
    return num(v.x()) + "f, " + num(v.y()) + "f, " + num(v.z()) + "f";
  };
  return fill_template("unity/Editor/RaywarpImport.cs", {{"STEM", stem},
                                                         {"IDENT", cs_ident(stem)},
                                                         {"VOLUMES", volumes},
                                                         {"REGION_CENTRE", vec(0.5 * (lo + hi))},
                                                         {"REGION_SIZE", vec(hi - lo)}});
}

std::string unity_atlas_script(const std::string& stem, const json& side,
                               const std::vector<Tex>& texs) {
  std::vector<std::string> names, cols, rows, points;
  for (const Tex& t : texs)
    if (const json* a = atlas_of(side, t.name)) {
      names.push_back(lit(a->at("file").get<std::string>()));
      cols.push_back(num(a->at("tiles")[0]));
      rows.push_back(num(a->at("tiles")[1]));
      points.push_back(is_nearest(t.name) ? "true" : "false");
    }
  auto list = [&](const std::vector<std::string>& v) {
    std::string s;
    for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : " ") + v[i];
    return s + " ";
  };
  return fill_template("unity/Editor/RaywarpAtlasImport.cs", {{"STEM", stem},
                                                              {"IDENT", cs_ident(stem)},
                                                              {"NAMES", list(names)},
                                                              {"COLUMNS", list(cols)},
                                                              {"ROWS", list(rows)},
                                                              {"POINT", list(points)}});
}

// ---- Unreal -----------------------------------------------------------------------------------

}  // namespace

std::string unreal_import_script(const json& side, const std::string& stem, const json& inputs) {
  const json& mapping = side.contains("mapping") ? side.at("mapping") : json::object();
  const bool cylindrical = mapping.value("type", "cartesian") == "cylindrical";
  const bool moves_nothing = side.at("render").value("moves_nothing", false);
  json list = json::array();
  for (const Tex& t : textures_of(side))
    if (const json* a = atlas_of(side, t.name)) {
      const int tx = a->at("tiles")[0].get<int>(), ty = a->at("tiles")[1].get<int>();
      json e = {{"texture", t.name},
                {"file", a->at("file")},
                {"format", a->at("format")},
                {"storage", a->value("storage", "half")},
                {"tiles", a->at("tiles")},
                {"tile_size", {a->at("size")[0].get<int>() / tx, a->at("size")[1].get<int>() / ty}},
                {"dims", t.info.at("dims")},
                {"scale", t.info.at("scale")},
                {"region", t.info.value("region", json())},
                {"nearest", is_nearest(t.name)},
                {"repeat", cylindrical &&
                               (t.name == "alpha" || (t.name == "deformation" && !moves_nothing))}};
      if (a->contains("lo")) e["lo"] = a->at("lo"), e["hi"] = a->at("hi");
      list.push_back(e);
    }
  const json& R = side.at("box").at("rotation");
  const json& c = side.at("box").at("centre");
  json box_to_object = json::array();
  for (int r = 0; r < 3; ++r) box_to_object.push_back({R[r][0], R[r][1], R[r][2], c[r]});
  return fill_template("unreal/import.py",
                       {{"STEM", stem},
                        {"IDENT", cs_ident(stem)},
                        {"ATLASES", list.dump()},
                        {"INPUTS", inputs.dump()},
                        {"BOX_TO_OBJECT", box_to_object.dump()},
                        {"HALF_EXTENTS", side.at("box").at("half_extents").dump()}});
}

namespace {

// ---- Godot ------------------------------------------------------------------------------------

std::string godot_import(const json& atlas) {
  std::ostringstream ini;
  ini << "; Generated by raywarp: Godot 4 import settings of "
      << atlas.at("file").get<std::string>() << " as a Texture3D.\n"
      << "; Put this file beside the image (same name + .import) before Godot first scans it,\n"
      << "; or copy the [params] into the Import dock. Godot fills in uid, path and [deps].\n"
      << "[remap]\n\nimporter=\"3d_texture\"\ntype=\"CompressedTexture3D\"\n\n[params]\n\n"
      << "compress/mode=0\n"  // Lossless (float images are stored VRAM Uncompressed)
      << "compress/high_quality=false\ncompress/high_quality_mode=0\ncompress/lossy_quality=0.7\n"
      << "compress/uastc_level=0\ncompress/rdo_quality_loss=0.0\n"
      << "compress/hdr_compression=0\ncompress/channel_pack=1\n"
      << "mipmaps/generate=false\nmipmaps/limit=-1\n"
      << "slices/horizontal=" << num(atlas.at("tiles")[0]) << "\n"
      << "slices/vertical=" << num(atlas.at("tiles")[1]) << "\n";
  return ini.str();
}

}  // namespace

std::vector<std::string> parse_engines(const std::string& list) {
  std::vector<std::string> names, out;
  for (const EngineLimit& e : kEngineLimits) names.push_back(e.name);
  if (list == "all") return names;
  std::string allowed;
  for (const std::string& n : names) allowed += (allowed.empty() ? "" : ", ") + n;
  std::set<std::string> chosen;
  size_t start = 0;
  while (start <= list.size()) {
    const size_t comma = std::min(list.find(',', start), list.size());
    const std::string word = list.substr(start, comma - start);
    if (std::find(names.begin(), names.end(), word) == names.end())
      throw Error("--engines: \"" + word +
                  "\" is no engine; give all or a comma-separated list of " + allowed);
    chosen.insert(word);
    start = comma + 1;
  }
  for (const std::string& n : names)
    if (chosen.count(n)) out.push_back(n);
  return out;
}

json write_engine_bundles(const json& side, const fs::path& dir, const std::string& stem,
                          const std::optional<BundleShaders>& shaders,
                          const std::vector<std::string>& engines) {
  auto wants = [&](const char* engine) {
    return engines.empty() || std::find(engines.begin(), engines.end(), engine) != engines.end();
  };
  if (side.value("schema", "") != "raywarp.export" || side.value("version", 0) != 1)
    throw Error(stem + ".json: not a raywarp.export version 1 sidecar");
  const std::string folder = stem + ".engines";
  const fs::path root = dir / folder;
  const std::vector<Tex> texs = textures_of(side);
  json result = {{"folder", folder}, {"engines", json::object()}};
  auto rel = [&](const std::string& engine, const std::string& name) {
    return folder + "/" + engine + "/" + name;
  };
  const bool ktx2 = has_format(side, "ktx2"), dds = has_format(side, "dds");
  const bool exr = has_format(side, "atlas-exr"), png = has_format(side, "atlas-png");
  const std::string common = common_checklist(side, stem, texs);

  // three.js
  if (wants("threejs")) {
    json e = {{"files", json::array()}, {"formats", json::array()}, {"missing", json::array()}};
    std::vector<std::string> missing;
    if (ktx2)
      e["formats"].push_back("ktx2");
    else
      missing.push_back("--format ktx2");
    const json shaders = find_es_shaders(dir, stem);
    const std::string module = "raywarp_" + stem + ".js";
    write_text(root / "threejs" / module, threejs_module(side, stem, texs, shaders));
    e["files"].push_back(rel("threejs", module));
    const json u = box_uniform_values(side);
    std::ostringstream md;
    md << "# three.js checklist: " << stem << "\n\n"
       << missing_section(missing,
                          "This bundle loads the KTX2 files, and the export has none: the module "
                          "finds nothing to load.")
       << "## Use\n\n`" << module
       << "` is an ES module (it imports `three` and "
          "`three/addons/loaders/KTX2Loader.js`: an import map or a bundler resolves them). "
          "`loadRaywarpBox({renderer})` loads every texture with `KTX2Loader` into a "
          "`Data3DTexture` (KTX2 with a plain vkFormat and pixelDepth > 0; RGBA16F and R16F "
          "included), sets LinearFilter (step bounds NearestFilter), ClampToEdgeWrapping on "
          "wrapS, wrapT and wrapR, generateMipmaps = false, colorSpace = NoColorSpace, and "
          "decodes each texel to object units in place. By default it reads the files two "
          "folders above the module (the export folder); pass `baseUrl` otherwise.\n\n";
    if (!shaders.is_null())
      md << "Shaders: `" << shaders.at("vertex").get<std::string>() << "` and `"
         << shaders.at("fragment").get<std::string>()
         << "` (GLSL ES 3.00, as raywarp compiles them) become a `RawShaderMaterial` "
            "(glslVersion GLSL3, side BackSide: the unit cube is drawn with front faces "
            "culled; the shader writes gl_FragDepth, so it composites with the scene by the "
            "depth test). Call `setRaywarpCamera(material, camera, object, width, height)` every "
            "frame, `object` being the Object3D whose frame is the mesh's object space. Output "
            "0 is sRGB-encoded colour: render to a linear target with no further encoding. The "
            "rest of the mesh (outside the box) is drawn by raywarp's raster pass, or by your own "
            "material discarding fragments inside the box.";
    else
      md << "Shaders: none beside the textures (`raywarp bake` writes none; `raywarp library` "
            "writes `NAME.raycast.es.vert.glsl` and `NAME_boxI.raycast.es.frag.glsl`). The module "
            "then returns `material = null` and the `uniforms` your own shader needs, computed "
            "as gl/renderer.cpp does (see below and the library's `NAME.shaders.md`).";
    md << "\n\n## Uniforms from the sidecar (object units, box frame)\n\n"
       << "| uniform | value | from |\n| --- | --- | --- |\n";
    static const std::map<std::string, std::string> from = {
        {"u_box_to_object", "[R | c]: box.rotation, box.centre"},
        {"u_box_to_object_dir", "box.rotation"},
        {"u_half_extents", "box.half_extents (h)"},
        {"u_region_lower", "render.ray_cast_region.min * h"},
        {"u_region_upper", "render.ray_cast_region.max * h"},
        {"u_sdf_origin", "textures.distance.region.min * h"},
        {"u_sdf_size", "(region.max - region.min) * h"},
        {"u_sdf_spacing", "min(u_sdf_size / dims): the voxel"},
        {"u_background", "render.distance_background_voxels * voxel_box_units * max(h)"},
        {"u_depth_origin_x", "depth_cube.maps[2a].origin * (h[u_axis], h[v_axis]) (_y, _z)"},
        {"u_depth_last_x", "depth_cube.maps[2a].texels - 1 (_y, _z)"},
        {"u_depth_layer", "textures.depth.dims[0], dims[1]"},
        {"u_def_origin", "textures.deformation.region.min * h"},
        {"u_def_size", "(region.max - region.min) * h"},
        {"u_def_spacing", "u_def_size / dims"},
        {"u_texture_map_x", "rows 0, 1, 2 of H M H^-1 (_y, _z), H = diag(h, 1), M = texture_map"},
        {"u_thickness", "render.shell_thickness_voxels * voxel_box_units * max(h) (0 uncut)"},
        {"u_cut_margin", "|u_alpha_spacing| + 0.5 |u_def_spacing| (0 uncut)"},
        {"u_lipschitz", "render.lipschitz (-1: +infinity)"},
        {"u_seam", "render.seam_voxels * voxel"},
        {"u_brick_origin", "textures.step_bounds_d.region.min * h"},
        {"u_brick_spacing", "its (region.max - region.min) * h / dims"},
        {"u_sdf_brick_origin", "textures.step_bounds_sdf.region.min * h"},
        {"u_sdf_brick_spacing", "min of its (region.max - region.min) * h / dims"},
        {"u_inv_lipschitz_w", "max(h) / render.step_bounds.validity_lipschitz_box_units"},
    };
    for (auto it = u.begin(); it != u.end(); ++it) {
      auto f = from.find(it.key());
      md << "| `" << it.key() << "` | " << it.value().dump() << " | "
         << (f != from.end() ? f->second : "") << " |\n";
    }
    md << "\nFrom the render settings (defaults of docs/scene.md unless `settings` overrides "
          "them): u_step = step_voxels * voxel, u_threshold = threshold_voxels * voxel, "
          "u_epsilon = hit_epsilon_voxels * voxel, u_fine_factor, u_max_steps, u_refine_steps, "
          "u_albedo, u_inside_colour, u_cut_colour. Per frame: u_view_proj, u_inv_view_proj, "
          "u_eye, u_view_dir, u_viewport, u_orthographic (setRaywarpCamera). Samplers: "
          "u_deformation, u_sdf, u_alpha, u_bricks, u_sdf_bricks.\n\n"
       << common
       << orientation_section(
              "as `orientation.ktx2` (change FILES to `{orientation: 'orientation.ktx2'}` and "
              "TEXTURES' scale to 1, or call `new KTX2Loader().loadAsync('orientation.ktx2')` "
              "and set the filters as the module does), draw it with a ShaderMaterial reading "
              "`texture(tex, vec3(u, v, w))`",
              "three.js uploads Data3DTexture rows as stored (flipY false): v = 0 is texel row "
              "0, no flip.",
              "w = 0 is slice 0.");
    write_text(root / "threejs" / "CHECKLIST.md", md.str());
    e["files"].push_back(rel("threejs", "CHECKLIST.md"));
    for (const std::string& m : missing) e["missing"].push_back(m);
    result["engines"]["threejs"] = e;
  }

  // Unity
  if (wants("unity")) {
    json e = {{"files", json::array()}, {"formats", json::array()}, {"missing", json::array()}};
    std::vector<std::string> missing;
    const char* volume_format = dds ? "dds" : (ktx2 ? "ktx2" : nullptr);
    if (volume_format) {
      e["formats"].push_back(volume_format);
      const std::string cs = "Editor/RaywarpImport_" + stem + ".cs";
      write_text(root / "unity" / cs, unity_volume_script(stem, side, texs, volume_format));
      e["files"].push_back(rel("unity", cs));
    } else {
      missing.push_back("--format dds");
    }
    if (exr || png) {
      e["formats"].push_back(exr ? "atlas-exr" : "atlas-png");
      const std::string cs = "Editor/RaywarpAtlasImport_" + stem + ".cs";
      write_text(root / "unity" / cs, unity_atlas_script(stem, side, texs));
      e["files"].push_back(rel("unity", cs));
    } else {
      missing.push_back("--format atlas-exr");
    }
    std::ostringstream md;
    md << "# Unity checklist: " << stem << "\n\n"
       << missing_section(missing,
                          "Unity imports no KTX2 or DDS 3D texture by itself: the volume route "
                          "reads the DDS (or KTX2) bytes in an editor script, the atlas route "
                          "imports a tiled image as a flipbook 3D texture; a route whose files "
                          "are missing is left out.")
       << "## Route 1 (exact): DDS/KTX2 -> Texture3D asset\n\n"
       << "Copy `Editor/RaywarpImport_" << stem
       << ".cs` into an `Editor` folder, and the "
          "`Shaders` folder and the files";
    for (const Tex& t : texs)
      if (const json* f = file_of(side, t.name, volume_format ? volume_format : "dds"))
        md << " `" << f->at("file").get<std::string>() << "`";
    md << " into `Assets/Raywarp/" << stem << "/`; run **Tools > Raywarp > Import " << stem
       << "**. Each file becomes a `Texture3D` decoded to object units (stored * scale per "
          "channel; RGBAFloat/RFloat, no mip chain, wrap Clamp (Repeat for a cylindrical "
          "texture), filter Bilinear, the step bounds Point; float formats are linear, never "
          "sRGB) saved as `.asset`; then the material `Raywarp_"
       << stem << ".mat` (shader `Raywarp/" << stem
       << "`, its textures set) and the prefab `raywarp_" << stem
       << ".prefab` (a cube with the material; its renderer's bounds the ray-cast region). Put the "
          "prefab under the mesh's GameObject with an identity transform. Texel order is kept, "
          "so the shader samples at raywarp's (u, v, w) directly. The shader, its passes and "
          "`u_object_axes` (the importer's axis flip and scale): docs/engines.md.\n\n"
       << "## Route 2: tiled atlas -> flipbook 3D texture\n\n"
       << "`Editor/RaywarpAtlasImport_" << stem
       << ".cs` is an AssetPostprocessor: when Unity imports an atlas named there it sets "
          "texture shape 3D, flipbook columns/rows = the sidecar's `tiles`, sRGB (Color "
          "Texture) off, Generate Mip Maps off, compression None, Non-Power of 2 None, Max Size "
          "16384, wrap Clamp, filter Bilinear. Put the script in place before copying the atlas "
          "files in (or reimport them).\n\n"
       << "**Vertical flip (decided):** Unity stores an imported image with v = 0 at its bottom "
          "row, while raywarp's texel row j = 0 is each tile's top row. Cells are cut from the "
          "top-left, row by row (slice z = tile (z % columns, z / columns)), as raywarp lays "
          "them out, but within each slice Unity's v runs upwards: sample the atlas route at "
          "(u, 1 - v, w'), w' below. The DDS route needs neither. Check both with the "
          "orientation volume: this is the one setting here not confirmed in Unity's sources.\n\n"
       << atlas_w_note(texs, side, "Unity's flipbook import")
       << "The 16-bit PNG (if you use it instead of the EXR) needs compression None and format "
          "R16/RGBA64 where your Unity version offers them; then decode lo + value * (hi - lo) "
          "(Unity samples unorm16 as value = code / 65535).\n\n"
       << common
       << orientation_section(
              "through both routes (`orientation.dds`, `orientation.exr` with "
              "flipbook 3 x 3 for its 8 slices)",
              "Route 1: G = v. Route 2: G = 1 - v unless you sample at 1 - v.",
              "Route 2 has 9 slices for 8: w' = min(8 w, 7.5) / 9.");
    write_text(root / "unity" / "CHECKLIST.md", md.str());
    e["files"].push_back(rel("unity", "CHECKLIST.md"));
    for (const std::string& m : missing) e["missing"].push_back(m);
    result["engines"]["unity"] = e;
  }

  // Unreal
  if (wants("unreal")) {
    json e = {{"files", json::array()}, {"formats", json::array()}, {"missing", json::array()}};
    std::vector<std::string> missing;
    if (exr)
      e["formats"].push_back("atlas-exr");
    else if (png)
      e["formats"].push_back("atlas-png");
    else
      missing.push_back("--format atlas-exr");
    const std::string py = "import_" + stem + ".py";
    write_text(root / "unreal" / py, unreal_import_script(side, stem, json::array()));
    e["files"].push_back(rel("unreal", py));
    std::ostringstream md;
    md << "# Unreal Engine 5 checklist: " << stem << "\n\n"
       << missing_section(missing,
                          "Unreal builds a Volume Texture from a 2D atlas; the export has no "
                          "atlas, so the script imports nothing.")
       << "## Use\n\nEnable the Python Editor Script Plugin, then run `" << py
       << "` (Tools > Execute Python Script). For each texture it imports the "
       << (exr ? "OpenEXR" : "16-bit PNG")
       << " atlas as a Texture2D with sRGB off, compression `TC_HDR` (`TC_HDR_F32` for float "
          "storage; the atlas keeps its pixel format: RGBA16F), `TMGS_NO_MIPMAPS`, LOD group "
          "`TEXTUREGROUP_16_BIT_DATA` (no LOD-group compression), never streamed, filter "
          "default (nearest for the step bounds), then creates `VT_...` (a `VolumeTexture` by "
          "`VolumeTextureFactory`) with `source2d_texture` = the atlas and "
          "`source2d_tile_size_x/y` = the tile size:\n\n"
       << "| texture | atlas | tiles | tile size | volume |\n| --- | --- | --- | --- | --- |\n";
    for (const Tex& t : texs)
      if (const json* a = atlas_of(side, t.name)) {
        const int tx = a->at("tiles")[0].get<int>(), ty = a->at("tiles")[1].get<int>();
        md << "| `" << t.name << "` | `" << a->at("file").get<std::string>() << "` | " << tx
           << " x " << ty << " | " << a->at("size")[0].get<int>() / tx << " x "
           << a->at("size")[1].get<int>() / ty << " | " << a->at("size")[0].get<int>() / tx << " x "
           << a->at("size")[1].get<int>() / ty << " x " << tx * ty << " |\n";
      }
    md << "\nUnreal cuts slice z from tile (z % tiles_x, z / tiles_x), rows from the top-left: "
          "raywarp's layout, so u and v need no flip. Interchange also reads DDS volumes "
          "(DX10 R16G16B16A16_FLOAT): importing `"
       << stem
       << ".deformation.dds` directly gives the exact depth (set the same sRGB, compression, "
          "mip and filter settings on it).\n\n"
       << atlas_w_note(texs, side, "The VolumeTexture built from the atlas")
       << "Exported with raywarp's shaders (`raywarp bake`), the script then makes the material "
          "`M_Raywarp_"
       << cs_ident(stem) << "` around the Custom node of `RaywarpCustomNode_" << stem
       << ".hlsl` (docs/engines.md): it reads the volumes as stored and decodes them by its "
          "`u_*_decode` inputs, the sidecar's scales. In a material of your own, sample with a "
          "Texture Object + `Texture3DSample`, clamp addressing, and decode object = stored * "
          "scale per channel.\n\n"
       << common
       << orientation_section("as `orientation.exr` with tile size 16 x 12 (3 x 3 tiles)",
                              "G = v (no flip).", "9 slices for 8: w' = min(8 w, 7.5) / 9.");
    write_text(root / "unreal" / "CHECKLIST.md", md.str());
    e["files"].push_back(rel("unreal", "CHECKLIST.md"));
    for (const std::string& m : missing) e["missing"].push_back(m);
    result["engines"]["unreal"] = e;
  }

  // Godot
  if (wants("godot")) {
    json e = {{"files", json::array()}, {"formats", json::array()}, {"missing", json::array()}};
    std::vector<std::string> missing;
    if (exr) {
      e["formats"].push_back("atlas-exr");
      for (const Tex& t : texs)
        if (const json* a = file_of(side, t.name, "atlas-exr")) {
          const std::string name = a->at("file").get<std::string>() + ".import";
          write_text(root / "godot" / name, godot_import(*a));
          e["files"].push_back(rel("godot", name));
        }
    } else {
      missing.push_back("--format atlas-exr");
    }
    if (dds) e["formats"].push_back("dds");
    std::ostringstream md;
    md << "# Godot 4 checklist: " << stem << "\n\n"
       << missing_section(missing,
                          "Godot's Texture3D importer cuts an image into slices; this bundle "
                          "uses the OpenEXR atlas (Godot's PNG loader keeps 8 bits per channel, "
                          "so the 16-bit PNG would lose its precision), and the export has none.")
       << "## Route 1: atlas -> Texture3D (importer `3d_texture`)\n\n"
       << "Copy each `.import` file beside its atlas image (same name plus `.import`) before "
          "Godot scans the folder, or set the same options in the Import dock (Import As: "
          "Texture3D): `slices/horizontal` = tiles_x, `slices/vertical` = tiles_y, "
          "`mipmaps/generate=false` (the default is true: it must be off), `compress/mode=0` "
          "(Lossless: a half/float image is stored VRAM Uncompressed, unchanged), "
          "`compress/hdr_compression=0`, `compress/channel_pack=1` (Optimized).\n\n"
       << "| texture | atlas | slices/horizontal | slices/vertical |\n| --- | --- | --- | --- |\n";
    for (const Tex& t : texs)
      if (const json* a = file_of(side, t.name, "atlas-exr"))
        md << "| `" << t.name << "` | `" << a->at("file").get<std::string>() << "` | "
           << num(a->at("tiles")[0]) << " | " << num(a->at("tiles")[1]) << " |\n";
    md << "\nGodot cuts slices row by row from the top-left (slice z = tile (z % h, z / h)): "
          "raywarp's layout, no flip.\n\n"
       << atlas_w_note(texs, side, "Godot's importer")
       << "## Route 2: DDS (Godot 4.4 and later)\n\n"
       << (dds ? "The `.dds` files (DDSCAPS2_VOLUME, DXGI R16G16B16A16_FLOAT / R16_FLOAT) load "
                 "directly as a 3D texture from Godot 4.4: drop them in the project and "
                 "`load(\"res://...dds\")`; their depth is exact (no empty slices)."
               : "Add `--format dds` for volumes Godot 4.4+ loads directly.")
       << "\n\nIn a shader: `uniform sampler3D raywarp_deformation : filter_linear, "
          "repeat_disable;` (`filter_nearest` for the step bounds), read "
          "`texture(raywarp_deformation, uvw).xyz * h` with h the half extents (the scale), "
          "`.w` the validity.\n\n"
       << common
       << orientation_section("as `orientation.exr` with slices 3 x 3 (and `orientation.dds`)",
                              "G = v (no flip).",
                              "The atlas route has 9 slices for 8: w' = min(8 w, 7.5) / 9.");
    write_text(root / "godot" / "CHECKLIST.md", md.str());
    e["files"].push_back(rel("godot", "CHECKLIST.md"));
    for (const std::string& m : missing) e["missing"].push_back(m);
    result["engines"]["godot"] = e;
  }
  if (shaders) {
    const json written =
        write_engine_shaders(side, root, stem, shaders->variant, shaders->settings, engines);
    for (const auto& [engine, files] : written.items())
      for (const auto& f : files)
        result["engines"][engine]["files"].push_back(folder + "/" + f.get<std::string>());
  }
  return result;
}

}  // namespace raywarp
