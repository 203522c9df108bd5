// Godot 4 (4.3 and later): the files that ray cast one exported box in Godot, from the templates
// engines/godot/* (cli/engine_templates.h) and raywarp's GLSL. For a box exported as STEM, meant
// to lie together in the Godot project folder godot_folder(STEM) = res://raywarp/STEM with the
// export's EXR atlases (or DDS volumes) and the mesh as OBJ:
//   STEM.gdshader              the box's spatial shader: march.glsl's variant, rewritten
//   STEM.remainder.gdshader    the mesh's material: discards what lies in the box(es)
//   raywarp_import_STEM.gd     EditorScript: atlases -> decoded ImageTexture3D resources (.res)
//   STEM.tscn                  the mesh with its remainder material and the box's cube
// docs/engines_godot.md has the import steps and the conventions.
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "gl/raycast_tables.h"

namespace raywarp {

// A uniform of the march as the Godot shader declares it.
struct GodotUniform {
  std::string type;   // Godot's type: "float", "vec3", "sampler3D", ...
  std::string name;   // raywarp's name: "u_sdf", "u_step", ...
  int array = 0;      // > 0: an array of that many (Godot allows no default on it)
  std::string hints;  // "filter_linear, repeat_disable", "hint_range(1, 100000)", or ""
  std::string value;  // the default as Godot text ("vec3(1.0, 2.0, 3.0)"), or "" for none
};

// The variant's march (shaders/march.glsl, raywarp_clip and raywarp_cast and everything they use)
// in Godot's shading language. The rewrite works on gl::assemble_shader's text of the variant
// (includes expanded, conditionals resolved, comments dropped) line by line: it drops #version,
// #line and the variant's feature #defines (already resolved), gives every `uniform T u;` its
// sampler hints (filter_linear, repeat_disable; the step-bound bricks filter_nearest; a cylindrical
// texture's u_deformation and u_alpha repeat_enable, for the periodic angle) or range hint, and
// its default from `values` (a number, or an array of 2-4 numbers for vec2-vec4; a uniform that
// `values` lacks gets none), and keeps every other line. It throws Error for what Godot's language
// refuses and the rewrite cannot carry: a directive other than #define (#extension, #include,
// #pragma, a conditional), layout(), gl_* names, mutable globals and prototypes, and a sampler it
// has no hints for; precision statements are dropped (Godot has none; integer samplers get highp).
struct GodotMarch {
  std::string text;                    // the uniforms and functions, ready to paste
  std::vector<GodotUniform> uniforms;  // in their order in the text
  std::vector<std::string> unset;      // uniforms without a default (set them on the material)
};
GodotMarch godot_march(const gl::Variant& variant, const nlohmann::json& values);
// The rewrite itself, of `glsl` (assemble_shader's text of `variant`'s march).
GodotMarch godot_rewrite(const std::string& glsl, const gl::Variant& variant,
                         const nlohmann::json& values);

// The spatial shader that ray casts one box in Godot 4.3+ (template
// engines/godot/raywarp_box.gdshader): godot_march's text, the colour uniforms u_albedo,
// u_inside_colour, u_cut_colour (vec3, source_color, defaults the sRGB encoding of `values`' linear
// colours, or of RenderSettings' when absent), vertex() mapping Godot's unit BoxMesh onto the
// ray-cast region, and fragment(): the camera ray through the pixel, near to far plane, in the box
// frame (inverse MODEL_MATRIX; the node's transform is box frame -> world), discard on a miss, else
// ALBEDO by surface kind, NORMAL (view space, through MODEL_NORMAL_MATRIX), LIGHT_VERTEX at the hit
// and DEPTH (reversed Z in Forward+/Mobile, [-1, 1] clip z in Compatibility). `values`:
// raycast_uniform_values (cli/engine_shaders.h), or any object of uniform values by name.
std::string godot_box_shader(const gl::Variant& variant, const nlohmann::json& values,
                             const std::string& stem);

// The material shader of the rest of the mesh (template engines/godot/raywarp_remainder.gdshader):
// Godot's lighting of the mesh, with the fragments inside any of `box_count` boxes (1 to 16)
// discarded; both faces drawn, back faces in u_inside_colour where u_two_sided (a cut). The boxes
// are uniform arrays in the mesh's object space: u_box_centre, u_box_x, u_box_y, u_box_z (the
// box's axes), u_half_extents.
std::string godot_remainder_shader(int box_count);

// The EditorScript (template engines/godot/raywarp_import.gd) that makes one ImageTexture3D
// resource STEM.TEXTURE.res per texture of the sidecar from its EXR atlas (sliced by the
// sidecar's tiles and border, exact depth) or else its DDS volume (Godot 4.4+), decoded to
// object units (stored * scale per channel), as 32-bit float (a constant switches to half).
std::string godot_import_script(const nlohmann::json& sidecar, const std::string& stem);

// The scene (template engines/godot/raywarp_scene.tscn): a Node3D raywarp_STEM holding Mesh (the
// mesh `mesh_file` in godot_folder(stem), default the sidecar's source mesh with the extension
// .obj, with the remainder material) and, under it, Box (Godot's unit BoxMesh with the box
// shader, its transform the box frame -> object map, its custom AABB the ray-cast region) with
// the textures the import script writes. Colours from `values` (as godot_box_shader).
std::string godot_scene(const nlohmann::json& sidecar, const std::string& stem,
                        const nlohmann::json& values = nullptr, const std::string& mesh_file = "");

// Where the files go in the Godot project, "res://raywarp/STEM", and their names there.
std::string godot_folder(const std::string& stem);
struct GodotFileNames {
  std::string box_shader, remainder_shader, import_script, scene;
};
GodotFileNames godot_file_names(const std::string& stem);

}  // namespace raywarp
