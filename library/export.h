// Textures that leave raywarp: one baked box written in the formats engines and DCC tools read,
// with a versioned JSON sidecar that says how to sample them (docs/export.md is the schema).
//
//   BakedBox box = session.bake(make_job(scene, 0, mesh));
//   nlohmann::json sidecar = export_box(box, export_source(scene, document, 0, *mesh), options,
//                                       "out/lib", "bunny_twist_box0");
//   BoxTextures again = import_box("out/lib/bunny_twist_box0.json", ExportFormat::Ktx2);
//
// Encoding (one convention for every format): texture geometry and displacements are in **box
// units**, a box-frame point q (object units) being q / half_extents, so the box is [-1, 1]^3 and
// a displacement of the box's own size is 1 whatever the mesh's units: half floats then hold
// D to 2^-11 of its magnitude. Distances (the distance grid f, the alpha map A) are stored in
// voxels of the box's implicit. A stored value decodes as object = stored * scale[channel]; the
// sidecar gives each texture's scale, region, texel layout and measured quantisation error.
#pragma once
#include <Eigen/Core>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "library/bake.h"
#include "library/texture_volume.h"

namespace raywarp {

// The version of the sidecar schema (docs/export.md). A reader refuses a newer major version.
inline constexpr int kExportSchemaVersion = 1;

enum class ExportFormat { Ktx2, Dds, Vdb, AtlasPng, AtlasExr };
// "ktx2", "dds", "vdb", "atlas-png", "atlas-exr"
const char* format_name(ExportFormat format);
// The file name extension after the texture's name: ".ktx2", ".dds", ".vdb", ".png", ".exr".
const char* format_extension(ExportFormat format);
// A comma-separated list of format names, or "all"; Error naming `where` and the names allowed.
std::vector<ExportFormat> parse_formats(const std::string& list, const std::string& where);

struct ExportOptions {
  std::vector<ExportFormat> formats{ExportFormat::Ktx2};
  Storage storage = Storage::Half;  // KTX2, DDS and EXR: half (default) or float per channel
  int atlas_border = 0;             // texels of edge replication around each atlas tile, 0 or 1
  bool dds_legacy = false;          // a D3DFORMAT FourCC header instead of DX10
};

// What the sidecar says of where a box's textures came from.
struct ExportSource {
  std::string scene;  // the scene file's name
  size_t box_index = 0;
  nlohmann::json box;      // the scene's box entry as written (deformer, implicit, ...)
  std::string mesh;        // the mesh file's name
  std::string mesh_hash;   // of its bytes (bake cache hash)
  std::string input_hash;  // export_input_hash
  // How an engine animates the box through the map M with no bake (null: it cannot), written to
  // the sidecar as it is (export_animation).
  nlohmann::json animation;
};
// The source of box `index` of `scene`, whose parsed file is `document`.
ExportSource export_source(const Scene& scene, const nlohmann::json& document, size_t index,
                           const MeshHandle& mesh);
// A hash of everything the exported files depend on: the mesh's bytes, the box entry, the export
// options and raywarp's version. A library skips an entry whose hash is unchanged.
std::string export_input_hash(const std::string& mesh_hash, const nlohmann::json& box,
                              const ExportOptions& options);

// One texture in the exported encoding, with what the sidecar says of it.
struct ExportedTexture {
  TextureVolume volume;
  std::vector<float> object;          // the baked values (object units), in volume's layout
  std::vector<double> scale;          // object value = stored * scale[channel]
  std::vector<std::string> channels;  // "dx", "dy", "dz", "valid" ...
  Eigen::Vector3d origin_box_units;   // the region's lower corner, box units
  Eigen::Vector3d spacing_box_units;  // texel sides, box units
  std::string frame;                  // "deformed" (read at p') or "undeformed" (at p)
  std::string meaning;                // one sentence
  bool round_up = false;              // bounds: quantised upwards, never below the value
  bool has_region = true;             // false: not a grid over the box (a depth cube's maps)
};
// The textures of a baked box: deformation (RGBA: D in box units, validity), the implicit (the
// distance grid, R in voxels, or a depth cube's six maps, R in units of the box's
// largest half extent), the alpha map of a cut (R, voxels) and the step bounds where baked (R).
std::vector<ExportedTexture> export_textures(const BakedBox& box);

// A cylindrical texture's units per texture axis (theta, r, h about `axis`): 1 (radians),
// max(h_u, h_v) and h_a, the half extents across and along the axis. Its region and its
// displacements are stored divided by them, as a Cartesian texture's are by the half extents.
Eigen::Vector3d cylindrical_units(const Eigen::Vector3d& half_extents, int axis);

// Writes every texture of `box` in every format of `options` into `dir` as STEM.TEXTURE.EXT
// (OpenVDB: one STEM.vdb with every grid), then the sidecar STEM.json. Each file is written
// atomically, the sidecar last, so a sidecar names only complete files. Returns the sidecar.
nlohmann::json export_box(const BakedBox& box, const ExportSource& source,
                          const ExportOptions& options, const std::filesystem::path& dir,
                          const std::string& stem);

// Reads an exported box back from its sidecar and the files of `format` (any but vdb) into the
// textures the ray caster reads (values decoded to object units, uploaded as 32-bit floats).
// Error naming the file on anything missing, malformed or inconsistent.
BoxTextures import_box(const std::filesystem::path& sidecar, ExportFormat format);

// The orientation test volume: 16 x 12 x 8 texels, R = (i + 0.5) / 16, G = (j + 0.5) / 12,
// B = (k + 0.5) / 8, A = 1 but 0 in the 2 x 2 x 2 texels at the origin corner (i, j, k < 2).
// Sampled at texture coordinate (u, v, w) it reads (u, v, w) and A = 0 near (0, 0, 0): a
// consumer that swaps, flips or mis-slices an axis sees it at once.
TextureVolume orientation_volume();
// Writes it in every format of `options` into `dir` as orientation.EXT, with orientation.json.
nlohmann::json export_orientation(const ExportOptions& options, const std::filesystem::path& dir);

// The job that bakes box `index` of `scene` for export: 32-bit textures (the formats quantise
// them themselves), the step bounds baked where a box can use them, and a distance grid where the
// scene asks for a depth cube (exports carry the grid, so a consumer can ray cast).
BakeJob export_job(const Scene& scene, size_t index, MeshPtr mesh);

// How an engine animates box `index` through the map M of eq. 2 with no bake, as `raywarp render
// --frames` does (library/texture_map.h): for a box whose only deformer is a twist, its angle
// between 0 and the baked one; for a peel, its hinge at or above the baked one. The sidecar's
// "animation": {parameter, baked, axis, lipschitz_add, texture_map (the rule, in words)}; null
// for a box that cannot be animated so (a composition, a cylindrical texture, bounded sampling).
nlohmann::json export_animation(const Scene& scene, size_t index);

}  // namespace raywarp
