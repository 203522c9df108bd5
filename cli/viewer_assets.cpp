#include "cli/viewer_assets.h"

#include <cstdint>
#include <cstring>
#include <map>
#include <regex>
#include <sstream>

#include "base/atomic_file.h"
#include "base/error.h"
#include "cli/viewer_files.h"
#include "gl/glsl_es.h"
#include "gl/raycast_tables.h"
#include "gl/renderer.h"
#include "gl/shader_sources.h"

namespace raywarp {

namespace fs = std::filesystem;

namespace {

void put_u32(std::string& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xffu));
}

void put_f32(std::string& out, float f) {
  std::uint32_t bits = 0;
  static_assert(sizeof bits == sizeof f);
  std::memcpy(&bits, &f, sizeof f);
  put_u32(out, bits);
}

// How a consumer computes each uniform the shaders declare. h = sidecar box.half_extents; "box
// units times h" turns a sidecar region or point (box units) into the box frame (object units).
struct UniformDoc {
  const char* meaning;
  const char* compute;
};

const std::map<std::string, UniformDoc>& uniform_docs() {
  static const std::map<std::string, UniformDoc> docs = {
      {"u_view_proj",
       {"object space -> clip space",
        "P V: V = gluLookAt(eye, target, up), P = gluPerspective(fov_y_deg, W / H, near, far) or "
        "glOrtho(-o W / H / 2, o W / H / 2, -o / 2, o / 2, near, far) with o = ortho_height "
        "(the entry's camera, W x H the framebuffer); column-major"}},
      {"u_inv_view_proj", {"clip -> object space", "the inverse of u_view_proj (in double)"}},
      {"u_eye", {"the camera's eye, object space", "camera.eye"}},
      {"u_view_dir",
       {"unit view direction, object space", "normalize(camera.target - camera.eye)"}},
      {"u_viewport", {"framebuffer size in pixels", "(W, H)"}},
      {"u_orthographic",
       {"orthographic camera: rays parallel to u_view_dir",
        "camera.projection == \"orthographic\""}},
      {"u_albedo", {"surface albedo, linear RGB", "render.colour"}},
      {"u_inside_colour",
       {"albedo of the inside of a shell seen through a cut, linear RGB", "render.inside_colour"}},
      {"u_cut_colour", {"albedo of solid cut faces, linear RGB", "render.cut_colour"}},
      {"u_two_sided",
       {"back faces show the inside of the shell (in u_inside_colour)",
        "true when any box's sidecar has render.has_cut"}},
      {"u_box_count", {"boxes whose inside the raster pass discards", "the number of boxes"}},
      {"u_object_to_box",
       {"object space -> box frame (raster: one per box, array of RAYWARP_MAX_BOXES)",
        "the inverse of u_box_to_object: [R^T | -R^T c]"}},
      {"u_half_extents",
       {"the box's half extents h, object units (raster: one per box)", "box.half_extents"}},
      {"u_box_to_object",
       {"box frame -> object space",
        "[R | c]: R = box.rotation (row-major in the sidecar: its columns are the box axes), "
        "c = box.centre; column-major"}},
      {"u_box_to_object_dir", {"directions box frame -> object space", "R = box.rotation"}},
      {"u_region_lower",
       {"lower corner of the region rays are cast over, box frame",
        "render.ray_cast_region.min (box units) times h"}},
      {"u_region_upper",
       {"upper corner of that region, box frame", "render.ray_cast_region.max times h"}},
      {"u_sdf",
       {"the distance grid f (> 0 inside), object units; texture unit 0",
        "textures.distance decoded: stored * scale[0]; LINEAR, CLAMP_TO_EDGE"}},
      {"u_sdf_origin",
       {"lower corner of the distance grid's region, box frame",
        "textures.distance.region.min times h"}},
      {"u_sdf_size",
       {"extent of that region (dims * spacing)",
        "(textures.distance.region.max - region.min) times h"}},
      {"u_sdf_spacing",
       {"the implicit's voxel: unit of steps, thresholds, seam and normals' differences",
        "voxel = min over axes of u_sdf_size / textures.distance.dims (= figures.voxel; a depth "
        "cube: 2 max(h) / depth_cube.resolution)"}},
      {"u_background",
       {"|f| of a sample with no preimage in the box",
        "render.distance_background_voxels * render.voxel_box_units * max(h)"}},
      {"u_step",
       {"linear-search step, object units",
        "render.step_voxels * voxel (the scene's render settings)"}},
      {"u_max_steps", {"bound on the linear search", "render.max_steps"}},
      {"u_refine_steps", {"binary refinement steps", "render.refine_steps"}},
      {"u_seam",
       {"hit tolerance at box faces, object units", "render.seam_voxels (sidecar) * voxel"}},
      {"u_deformation",
       {"D(p') in xyz (object units, p = p' + D), validity in w; texture unit 1",
        "textures.deformation decoded: stored * scale[c] (scale = h, h, h, 1); LINEAR"}},
      {"u_def_origin",
       {"lower corner of the deformation texture's region",
        "textures.deformation.region.min times h"}},
      {"u_def_size",
       {"extent of that region", "(textures.deformation.region.max - region.min) times h"}},
      {"u_def_spacing", {"its texel sides per axis", "u_def_size / textures.deformation.dims"}},
      {"u_texture_map_x",
       {"row 0 of M of eq. 2 (u_texture_map_y, u_texture_map_z: rows 1 and 2): D is read at "
        "M p'",
        "the rows of H M_s H^-1 with H = diag(h, 1) and M_s = sidecar texture_map (box units, "
        "row-major)"}},
      {"u_texture_map_y", {"row 1 of M", "see u_texture_map_x"}},
      {"u_def_decode",
       {"per channel, object units per stored unit of u_deformation",
        "1 when the texture is uploaded decoded (object = stored * scale); else "
        "textures.deformation.scale"}},
      {"u_sdf_decode", {"object units per stored unit of u_sdf", "1, or textures.distance.scale"}},
      {"u_alpha_decode", {"object units per stored unit of u_alpha", "1, or textures.alpha.scale"}},
      {"u_texture_map_z", {"row 2 of M", "see u_texture_map_x"}},
      {"u_cyl_e_u",
       {"cylindrical textures: the box axis after the cylinder's axis a, e_(a+1)%3",
        "textures' mapping.axis a"}},
      {"u_cyl_e_v", {"cylindrical textures: e_(a+2)%3", "textures' mapping.axis a"}},
      {"u_cyl_e_a", {"cylindrical textures: the cylinder's axis e_a", "textures' mapping.axis a"}},
      {"u_alpha",
       {"the cut's alpha map A (> 0 inside the cut), object units; texture unit 2",
        "textures.alpha decoded: stored * scale[0]; LINEAR"}},
      {"u_alpha_origin",
       {"lower corner of the alpha map's region", "textures.alpha.region.min times h"}},
      {"u_alpha_size",
       {"extent of that region", "(textures.alpha.region.max - region.min) times h"}},
      {"u_alpha_spacing", {"its texel sides per axis", "u_alpha_size / textures.alpha.dims"}},
      {"u_thickness",
       {"tau of eq. 7 (thick shell), object units",
        "render.shell_thickness_voxels * render.voxel_box_units * max(h)"}},
      {"u_threshold",
       {"threshold sampling: where the fine step applies, object units",
        "render.threshold_voxels * voxel"}},
      {"u_fine_factor", {"threshold sampling: fine step / step", "render.fine_factor"}},
      {"u_lipschitz",
       {"bound of |I + J_D| outside the cut, for skipping",
        "render.lipschitz of the sidecar (-1 means unknown: +infinity)"}},
      {"u_cut_margin",
       {"how far from the cut skipping by f stops",
        "|u_alpha_spacing| + 0.5 |u_def_spacing| (0 without a cut)"}},
      {"u_bricks",
       {"bounded tracing: per brick of D a bound of |I + J_D|; texture unit 3",
        "textures.step_bounds_d (R32F or R16F, NEAREST)"}},
      {"u_brick_origin",
       {"D's first texel centre (the bricks' origin)",
        "textures.step_bounds_d.region.min times h"}},
      {"u_brick_spacing",
       {"brick sides per axis",
        "(textures.step_bounds_d.region.max - region.min) times h / its dims"}},
      {"u_sdf_bricks",
       {"bounded tracing: per brick of the distance grid a bound of |grad f|; texture unit 4",
        "textures.step_bounds_sdf (NEAREST)"}},
      {"u_sdf_brick_origin",
       {"the distance grid's first texel centre", "textures.step_bounds_sdf.region.min times h"}},
      {"u_sdf_brick_spacing",
       {"brick side of the distance grid's bricks (their smallest)",
        "min over axes of (textures.step_bounds_sdf.region.max - region.min) times h / dims"}},
      {"u_inv_lipschitz_w",
       {"1 / bound of |grad w| (0: w = 1 everywhere)",
        "max(h) / render.step_bounds.validity_lipschitz_box_units (0 when that is 0)"}},
      {"u_epsilon",
       {"bounded tracing: a sample with g > -u_epsilon is the hit",
        "render.hit_epsilon_voxels * voxel"}},
      {"u_depth",
       {"depth-cube maps, map k in slice k of 8 (texture unit 5)",
        "textures.depth decoded: stored * scale[0]; LINEAR, CLAMP_TO_EDGE"}},
      {"u_depth_origin_x",
       {"depth cube: per axis (_x, _y, _z), its maps' texel grid origin",
        "depth_cube.maps[2a].origin times (h[u_axis], h[v_axis])"}},
      {"u_depth_origin_y", {"see u_depth_origin_x", "see u_depth_origin_x"}},
      {"u_depth_origin_z", {"see u_depth_origin_x", "see u_depth_origin_x"}},
      {"u_depth_last_x",
       {"depth cube: per axis (_x, _y, _z), its maps' last texel centre",
        "depth_cube.maps[2a].texels - 1"}},
      {"u_depth_last_y", {"see u_depth_last_x", "see u_depth_last_x"}},
      {"u_depth_last_z", {"see u_depth_last_x", "see u_depth_last_x"}},
      {"u_depth_layer", {"depth cube: texels of a slice", "textures.depth.dims[0], dims[1]"}},
  };
  return docs;
}

// The uniforms a shader declares, in order: (type, name, array suffix).
struct Declared {
  std::string type, name, array;
};
std::vector<Declared> declared_uniforms(const std::string& source) {
  static const std::regex decl(R"(^\s*uniform\s+(\w+)\s+(\w+)\s*(\[[^\]]*\])?\s*;)");
  std::vector<Declared> out;
  std::istringstream in(source);
  std::string line;
  while (std::getline(in, line)) {
    std::smatch m;
    if (std::regex_search(line, m, decl)) out.push_back({m[1], m[2], m[3]});
  }
  return out;
}

void uniform_table(std::ostream& md, const std::string& source) {
  md << "| uniform | type | meaning | how to compute it |\n| --- | --- | --- | --- |\n";
  for (const Declared& u : declared_uniforms(source)) {
    auto found = uniform_docs().find(u.name);
    md << "| `" << u.name << u.array << "` | `" << u.type << "` | "
       << (found != uniform_docs().end() ? found->second.meaning : "(undocumented)") << " | "
       << (found != uniform_docs().end() ? found->second.compute : "") << " |\n";
  }
  md << "\n";
}

void write_text(const fs::path& path, const std::string& text) {
  write_file_atomic(path.string(), std::string_view(text));
}

}  // namespace

void write_mesh_bin(const Mesh& mesh, const fs::path& file) {
  const auto normals = vertex_normals(mesh);
  const std::uint32_t nv = static_cast<std::uint32_t>(mesh.V.rows());
  const std::uint32_t nt = static_cast<std::uint32_t>(mesh.F.rows());
  std::string bytes = "RWM1";
  bytes.reserve(12 + size_t(nv) * 24 + size_t(nt) * 12);
  put_u32(bytes, nv);
  put_u32(bytes, nt);
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    for (int c = 0; c < 3; ++c) put_f32(bytes, static_cast<float>(mesh.V(i, c)));
  for (Eigen::Index i = 0; i < normals.rows(); ++i)
    for (int c = 0; c < 3; ++c) put_f32(bytes, static_cast<float>(normals(i, c)));
  for (Eigen::Index i = 0; i < mesh.F.rows(); ++i)
    for (int c = 0; c < 3; ++c) {
      const int v = mesh.F(i, c);
      if (v < 0 || static_cast<std::uint32_t>(v) >= nv)
        throw Error(file.string() + ": triangle " + std::to_string(i) + " names vertex " +
                    std::to_string(v) + " of " + std::to_string(nv));
      put_u32(bytes, static_cast<std::uint32_t>(v));
    }
  write_file_atomic(file.string(), std::string_view(bytes));
}

nlohmann::json render_settings_to_json(const RenderSettings& s) {
  auto v = [](const Eigen::Vector3d& x) { return nlohmann::json{x.x(), x.y(), x.z()}; };
  return {{"width", s.width},
          {"height", s.height},
          {"step_voxels", s.step_voxels},
          {"max_steps", s.max_steps},
          {"refine_steps", s.refine_steps},
          {"background", v(s.background)},
          {"colour", v(s.colour)},
          {"cut_colour", v(s.cut_colour)},
          {"inside_colour", v(s.inside_colour)},
          {"skipping", s.skipping},
          {"sampling", sampling_name(s.sampling)},
          {"threshold_voxels", s.threshold_voxels},
          {"fine_factor", s.fine_factor},
          {"hit_epsilon_voxels", s.hit_epsilon_voxels},
          {"texture_bits", s.texture_bits}};
}

nlohmann::json write_shader_bundle(const std::vector<BoxTextures>& boxes,
                                   const RenderSettings& settings, const fs::path& dir,
                                   const std::string& stem) {
  fs::create_directories(dir);
  const std::string raster_defines =
      "#define RAYWARP_MAX_BOXES " + std::to_string(gl::Renderer::kMaxBoxes) + "\n";
  const std::string raster_vert =
      gl::assemble_shader("raster.vert.glsl", raster_defines + gl::stage_defines(GL_VERTEX_SHADER));
  const std::string raster_frag = gl::assemble_shader(
      "raster.frag.glsl", raster_defines + gl::stage_defines(GL_FRAGMENT_SHADER));
  const std::string raycast_vert =
      gl::assemble_shader("raycast.vert.glsl", gl::stage_defines(GL_VERTEX_SHADER));

  nlohmann::json out;
  auto write_pair = [&](const std::string& base, const std::string& ext, const std::string& text,
                        nlohmann::json& glsl450, nlohmann::json& es, const char* key) {
    const std::string n450 = base + "." + ext + ".glsl", nes = base + ".es." + ext + ".glsl";
    write_text(dir / n450, text);
    write_text(dir / nes, gl::glsl_es_300(text));
    glsl450[key] = n450;
    es[key] = nes;
  };
  nlohmann::json r450, res;
  write_pair(stem + ".raster", "vert", raster_vert, r450, res, "vertex");
  write_pair(stem + ".raster", "frag", raster_frag, r450, res, "fragment");
  out["raster"] = {{"glsl450", r450}, {"glsl_es300", res}};
  nlohmann::json v450, ves;
  write_pair(stem + ".raycast", "vert", raycast_vert, v450, ves, "vertex");
  out["raycast_vertex"] = {{"glsl450", v450["vertex"]}, {"glsl_es300", ves["vertex"]}};

  std::ostringstream md;
  md << "# Shaders of " << stem << "\n\n"
     << "Generated by raywarp. Each box is ray cast by its own variant of "
        "`shaders/raycast.frag.glsl`, assembled with only the code its features use; the "
        "`.es.` files are the same text as GLSL ES 3.00 (WebGL2): `#version 300 es` and highp "
        "default precisions, nothing else changed.\n\n"
     << "A frame: clear colour = sRGB-encoded render.background, depth 1, depth test LESS. Pass "
        "1 draws the mesh (the library's meshes/HASH.bin, written by write_mesh_bin, or the "
        "source mesh with area-weighted vertex normals: positions at location 0, normals at 1) "
        "with the raster shaders, no culling. Pass 2, per box, draws the "
        "unit cube [0, 1]^3 (36 indices, counter-clockwise seen from outside; location 0) with "
        "the box's ray-cast variant, culling front faces; the fragment shader writes "
        "gl_FragDepth, so the passes composite by the depth test. Output 0 is the sRGB-encoded "
        "colour (write it to a linear RGBA8 target, not an sRGB one); output 1 is linear eye "
        "depth (optional: a float target, or no draw buffer).\n\n"
     << "Units: h = the sidecar's box.half_extents; a sidecar region or point in box units "
        "times h (per axis) is in the box frame, object units. Matrices go in column-major. "
        "Textures: decode every texel as object = stored * scale[channel] (sidecar "
        "textures.NAME.scale) before upload, or fold the scale into the shader; sample level 0 "
        "with LINEAR filtering and CLAMP_TO_EDGE (the step bounds NEAREST). Sampler units: u_sdf "
        "0, u_deformation 1, u_alpha 2, u_bricks 3, u_sdf_bricks 4, u_depth 5.\n\n"
     << "Render settings (render.*) are the scene's (`render_settings_to_json`): step_voxels, "
        "max_steps, refine_steps, threshold_voxels, fine_factor, hit_epsilon_voxels, colours. "
        "`voxel` below is the distance grid's smallest texel side in object units. In the tables, "
        "render.ray_cast_region, voxel_box_units, distance_background_voxels, "
        "shell_thickness_voxels, lipschitz, seam_voxels and step_bounds are the sidecar's "
        "`render` object; render.colour, step_voxels and the other settings are the scene's.\n\n"
     << "## Raster pass\n\nVertex: `" << r450["vertex"].get<std::string>() << "` / `"
     << res["vertex"].get<std::string>() << "`; fragment: `" << r450["fragment"].get<std::string>()
     << "` / `" << res["fragment"].get<std::string>() << "`.\n\n";
  uniform_table(md, raster_vert + raster_frag);
  md << "## Ray-cast pass, vertex shader (every box)\n\n`" << v450["vertex"].get<std::string>()
     << "` / `" << ves["vertex"].get<std::string>() << "`\n\n";
  uniform_table(md, raycast_vert);

  out["boxes"] = nlohmann::json::array();
  for (size_t i = 0; i < boxes.size(); ++i) {
    const BoxTextures& box = boxes[i];
    const gl::Variant variant = gl::raycast_variant(box, settings);
    const std::string frag = gl::raycast_fragment_source(box, settings);
    nlohmann::json b450 = {{"vertex", v450["vertex"]}}, bes = {{"vertex", ves["vertex"]}};
    write_pair(stem + "_box" + std::to_string(i) + ".raycast", "frag", frag, b450, bes, "fragment");
    nlohmann::json defines = nlohmann::json::array();
    for (const gl::FeatureInfo& f : gl::kFeatures)
      if (variant.has(f.feature)) defines.push_back(f.macro);
    out["boxes"].push_back({{"glsl450", b450}, {"glsl_es300", bes}, {"defines", defines}});
    md << "## Box " << i << ": ray-cast fragment shader\n\n`" << b450["fragment"].get<std::string>()
       << "` / `" << bes["fragment"].get<std::string>() << "`; features: ";
    for (size_t k = 0; k < defines.size(); ++k)
      md << (k ? ", " : "") << "`" << defines[k].get<std::string>() << "`";
    md << ".\n\n";
    uniform_table(md, frag);
  }
  const std::string md_name = stem + ".shaders.md";
  write_text(dir / md_name, md.str());
  out["uniforms"] = md_name;
  return out;
}

void write_viewer(const fs::path& dir) {
  fs::create_directories(dir);
  for (const auto& [name, text] : embedded_viewer_files()) write_text(dir / name, text);
}

}  // namespace raywarp
