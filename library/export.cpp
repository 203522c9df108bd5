#include "library/export.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>

#include "base/atomic_file.h"
#include "base/error.h"
#include "base/version.h"
#include "deformers/deformer.h"
#include "library/atlas.h"
#include "library/bake_cache.h"
#include "library/dds.h"
#include "library/ktx2.h"
#include "library/vdb_export.h"

namespace raywarp {

namespace fs = std::filesystem;

namespace {

constexpr ExportFormat kAllFormats[] = {ExportFormat::Ktx2, ExportFormat::Dds, ExportFormat::Vdb,
                                        ExportFormat::AtlasPng, ExportFormat::AtlasExr};

nlohmann::json vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
nlohmann::json ivec(const Eigen::Vector3i& v) { return {v.x(), v.y(), v.z()}; }
nlohmann::json matrix(const Eigen::MatrixXd& m) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < m.rows(); ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (int c = 0; c < m.cols(); ++c) row.push_back(m(r, c));
    rows.push_back(row);
  }
  return rows;
}

// The smallest half at or above x (bounds must never be quantised downwards).
float half_at_or_above(float x) {
  if (!(x <= 65504.0f))
    throw Error("a step bound of " + std::to_string(x) +
                " exceeds the largest half float (65504); export with --float");
  float h = half_bits_to_float(float_to_half_bits(x));
  if (h >= x) return h;
  const std::uint16_t bits = float_to_half_bits(x);
  // x > 0 here (bounds are >= 1): the next half up has the next bit pattern.
  return half_bits_to_float(static_cast<std::uint16_t>(bits + 1));
}

// The value a format stores for v at `storage` precision, as a float.
float stored(float v, Storage storage) {
  return storage == Storage::Half ? half_bits_to_float(float_to_half_bits(v)) : v;
}

template <class F>
TextureVolume volume_from(const std::string& name, const Eigen::Vector3i& dims, int channels,
                          F&& value) {
  TextureVolume v;
  v.name = name;
  v.dims = dims;
  v.channels = channels;
  v.values.resize(v.texels() * channels);
  for (int k = 0; k < dims.z(); ++k)
    for (int j = 0; j < dims.y(); ++j)
      for (int i = 0; i < dims.x(); ++i)
        for (int c = 0; c < channels; ++c) v.values[v.index(i, j, k, c)] = value(i, j, k, c);
  return v;
}

ExportedTexture scalar_texture(const std::string& name, const Grid3<float>& grid, double scale,
                               const Eigen::Vector3d& h, const std::string& frame,
                               const std::string& meaning, bool round_up) {
  ExportedTexture t;
  t.volume = volume_from(name, grid.dims, 1, [&](int i, int j, int k, int) {
    return static_cast<float>(grid.at(i, j, k) / scale);
  });
  t.object = volume_from(name, grid.dims, 1, [&](int i, int j, int k, int) {
               return grid.at(i, j, k);
             }).values;
  t.scale = {scale};
  t.channels = {"value"};
  t.origin_box_units = grid.origin.cwiseQuotient(h);
  t.spacing_box_units = grid.spacing.cwiseQuotient(h);
  t.frame = frame;
  t.meaning = meaning;
  t.round_up = round_up;
  return t;
}

// The volume as a format stores it: bounds rounded up to a half where the storage is half.
TextureVolume as_stored(const ExportedTexture& t, Storage storage) {
  TextureVolume v = t.volume;
  if (storage == Storage::Half)
    for (float& x : v.values) x = t.round_up ? half_at_or_above(x) : stored(x, storage);
  return v;
}

// The largest |decoded - baked| over the texture, object units (bounds: their own unit), the
// decoded value rounded to float as a reader that decodes to floats gets it.
double decode_error(const ExportedTexture& t, const TextureVolume& decoded) {
  double worst = 0;
  const int n = t.volume.channels;
  for (size_t idx = 0; idx < t.volume.values.size(); ++idx) {
    const int c = static_cast<int>(idx % n);
    const float got = static_cast<float>(double(decoded.values[idx]) * t.scale[c]);
    worst = std::max(worst, std::abs(double(got) - double(t.object[idx])));
  }
  return worst;
}

std::vector<std::uint8_t> read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path.string() + ": cannot read");
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), {});
}

const char* kMipmaps =
    "none: a coarser level would average the displacements of neighbouring texels, which is not "
    "the displacement of any point (and averages validity and distances across the surface); "
    "sample level 0 only, with linear filtering, clamp to edge, no sRGB";

const char* kReuse =
    "To apply a texture to another box of half extents h2, read it at q / h2 (box units) and "
    "decode displacements with scale h2 instead of this box's half_extents: the texture is "
    "scaled by the ratio of extents. That is exact for a box scaled uniformly when the "
    "deformer's lengths scale with it (its angles unchanged), and an approximation otherwise: a "
    "twist in a box stretched along one axis shears instead of rotating rigidly. The distance "
    "grid belongs to this mesh and box only.";

const char* kEncoding =
    "Box units: a box-frame point q (object units) is q / half_extents, so the box is [-1, 1]^3. "
    "A texture covers region.min .. region.max (box units) with dims texels per axis; texel "
    "(i, j, k) has its centre at texture coordinate ((i, j, k) + 0.5) / dims, as in OpenGL and "
    "Vulkan. Memory order: channels, then x fastest, then y, then z (KTX2 orientation rdi). A "
    "stored value decodes as object = stored * scale[channel].";

// A depth cube's far depth in units of the box's largest half extent.
double cube_far(const BoxTextures& tex) {
  return tex.depth_cube.far_depth / tex.box.half_extents.maxCoeff();
}

nlohmann::json texture_entry(const ExportedTexture& t) {
  nlohmann::json e;
  e["dims"] = ivec(t.volume.dims);
  e["channels"] = t.channels;
  e["scale"] = t.scale;
  if (t.has_region)
    e["region"] = {{"min", vec(t.origin_box_units)},
                   {"max", vec(t.origin_box_units +
                               t.spacing_box_units.cwiseProduct(t.volume.dims.cast<double>()))}};
  e["frame"] = t.frame;
  e["meaning"] = t.meaning;
  if (t.round_up) e["quantised"] = "upwards (a bound stays a bound)";
  return e;
}

// M in box units, S^-1 M S with S = diag(h, 1), entry by entry so that the identity stays exact:
// m_rc h_c / h_r (the translation column: m_r3 / h_r). And back.
Eigen::Matrix4d map_to_box_units(const Eigen::Matrix4d& m, const Eigen::Vector3d& h) {
  const Eigen::Vector4d s(h.x(), h.y(), h.z(), 1.0);
  Eigen::Matrix4d out;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out(r, c) = m(r, c) * s[c] / s[r];
  return out;
}
Eigen::Matrix4d map_from_box_units(const Eigen::Matrix4d& m, const Eigen::Vector3d& h) {
  const Eigen::Vector4d s(h.x(), h.y(), h.z(), 1.0);
  Eigen::Matrix4d out;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out(r, c) = m(r, c) * s[r] / s[c];
  return out;
}

std::string file_name(const std::string& stem, const std::string& texture, ExportFormat f) {
  return stem + "." + texture + format_extension(f);
}

}  // namespace

const char* format_name(ExportFormat format) {
  switch (format) {
    case ExportFormat::Ktx2:
      return "ktx2";
    case ExportFormat::Dds:
      return "dds";
    case ExportFormat::Vdb:
      return "vdb";
    case ExportFormat::AtlasPng:
      return "atlas-png";
    case ExportFormat::AtlasExr:
      return "atlas-exr";
  }
  return "?";
}

const char* format_extension(ExportFormat format) {
  switch (format) {
    case ExportFormat::Ktx2:
      return ".ktx2";
    case ExportFormat::Dds:
      return ".dds";
    case ExportFormat::Vdb:
      return ".vdb";
    case ExportFormat::AtlasPng:
      return ".png";
    case ExportFormat::AtlasExr:
      return ".exr";
  }
  return "";
}

std::vector<ExportFormat> parse_formats(const std::string& list, const std::string& where) {
  std::vector<ExportFormat> out;
  if (list == "all")
    return std::vector<ExportFormat>(std::begin(kAllFormats), std::end(kAllFormats));
  size_t start = 0;
  while (start <= list.size()) {
    const size_t end = std::min(list.find(',', start), list.size());
    const std::string name = list.substr(start, end - start);
    bool found = false;
    for (ExportFormat f : kAllFormats)
      if (name == format_name(f)) {
        if (std::find(out.begin(), out.end(), f) == out.end()) out.push_back(f);
        found = true;
      }
    if (!found)
      throw Error(where + " = \"" + list + "\": unknown format \"" + name +
                  "\"; allowed: ktx2, dds, vdb, atlas-png, atlas-exr (comma-separated), or all");
    start = end + 1;
  }
  return out;
}

std::string export_input_hash(const std::string& mesh_hash, const nlohmann::json& box,
                              const ExportOptions& options) {
  std::string text = std::string("raywarp ") + kVersion + "\nschema " +
                     std::to_string(kExportSchemaVersion) + "\nmesh " + mesh_hash + "\nbox " +
                     box.dump() + "\nstorage " + storage_name(options.storage) + "\nborder " +
                     std::to_string(options.atlas_border) + "\nlegacy dds " +
                     (options.dds_legacy ? "1" : "0") + "\nformats";
  for (ExportFormat f : options.formats) text += std::string(" ") + format_name(f);
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx",
                static_cast<unsigned long long>(fnv1a(text.data(), text.size())));
  return hex;
}

ExportSource export_source(const Scene& scene, const nlohmann::json& document, size_t index,
                           const MeshHandle& mesh) {
  ExportSource s;
  s.scene = scene.file.filename().string();
  s.box_index = index;
  if (document.contains("boxes") && document["boxes"].is_array() &&
      index < document["boxes"].size())
    s.box = document["boxes"][index];
  s.mesh = mesh.file.filename().string();
  s.mesh_hash = mesh.hash;
  return s;
}

Eigen::Vector3d cylindrical_units(const Eigen::Vector3d& half_extents, int axis) {
  return {1.0, std::max(half_extents[(axis + 1) % 3], half_extents[(axis + 2) % 3]),
          half_extents[axis]};
}

std::vector<ExportedTexture> export_textures(const BakedBox& baked) {
  const BoxTextures& tex = baked.textures;
  const Eigen::Vector3d h = tex.box.half_extents;
  // D and A's units per texture axis: box units, or for cylindrical textures (theta, r, h) in
  // radians, r / max(h_u, h_v) and h / h_a (cylindrical_units).
  // A box that moves nothing has no cylindrical D (its D is the identity, over the box).
  const Eigen::Vector3d units_a =
      tex.cylindrical() ? cylindrical_units(h, tex.cylindrical_axis) : h;
  const bool cylindrical_d = tex.cylindrical() && !tex.moves_nothing;
  const Eigen::Vector3d u = cylindrical_d ? units_a : h;
  const double voxel = implicit_spacing(tex);
  std::vector<ExportedTexture> out;

  ExportedTexture d;
  const Grid3<Eigen::Vector4f>& g = tex.deformation.grid;
  d.volume = volume_from("deformation", g.dims, 4, [&](int i, int j, int k, int c) {
    const float v = g.at(i, j, k)[c];
    return c < 3 ? static_cast<float>(v / u[c]) : v;
  });
  d.object = volume_from("deformation", g.dims, 4, [&](int i, int j, int k, int c) {
               return g.at(i, j, k)[c];
             }).values;
  d.scale = {u.x(), u.y(), u.z(), 1.0};
  d.channels = cylindrical_d ? std::vector<std::string>{"dtheta", "dr", "dh", "valid"}
                             : std::vector<std::string>{"dx", "dy", "dz", "valid"};
  d.origin_box_units = g.origin.cwiseQuotient(u);
  d.spacing_box_units = g.spacing.cwiseQuotient(u);
  d.frame = "deformed";
  d.meaning =
      "D(p') = F^-1(p') - p', read at a deformed point p' (after the texture map M): the "
      "undeformed point is p = p' + D(p'); valid is 1 where the preimage lies in the box, 0 "
      "elsewhere (a ray sample there is empty), trilinearly interpolated: count it valid at "
      ">= 0.5";
  out.push_back(std::move(d));

  if (tex.uses_depth_cube) {
    const DepthCube& cube = tex.depth_cube;
    const DepthCube::Layers layers = cube.layers();
    const std::vector<float> texels = cube.layer_texels();
    const double unit = h.maxCoeff();  // far_depth = 2048 of them: a half float holds it
    ExportedTexture t;
    t.volume = volume_from(
        "depth", {layers.width, layers.height, DepthCube::Layers::kDepth}, 1,
        [&](int i, int j, int k, int) {
          return static_cast<float>(
              texels[(static_cast<size_t>(k) * layers.height + j) * layers.width + i] / unit);
        });
    t.object = texels;
    t.scale = {unit};
    t.channels = {"depth"};
    t.origin_box_units = Eigen::Vector3d::Zero();
    t.spacing_box_units = Eigen::Vector3d::Ones();
    t.frame = "undeformed";
    t.meaning =
        "the depth-map cube's six maps H_k (faces -x, +x, -y, +y, -z, +z), map k in slice k, "
        "see depth_cube: the depth of the first surface inside the box seen from face k along its "
        "inward normal, +far_depth where a ray sees none, -far_depth where it starts inside";
    t.has_region = false;
    out.push_back(std::move(t));
  } else {
    out.push_back(scalar_texture(
        "distance", tex.sdf.grid, voxel, h, "undeformed",
        "signed distance f to the mesh part in the box, > 0 inside, read at the undeformed point "
        "p; exact within the narrow band, +-background beyond it (a lower bound of the distance)",
        false));
  }
  if (tex.has_cut)
    out.push_back(scalar_texture(
        "alpha", tex.alpha.grid, voxel, units_a, "deformed",
        "the cut's alpha map A(p'), > 0 inside the removed region, a signed distance to its "
        "boundary, read at the deformed point p'",
        false));
  if (!tex.step_bounds.empty()) {
    const StepBounds& sb = tex.step_bounds;
    ExportedTexture bd = scalar_texture(
        "step_bounds_d", sb.bricks, 1.0, h, "deformed",
        "per brick of brick_cells^3 interpolation cells of the deformation texture, a bound of "
        "||I + J_D|| over the brick and its 26 neighbours (>= 1), read nearest",
        true);
    ExportedTexture bs = scalar_texture(
        "step_bounds_sdf", sb.sdf_bricks, 1.0, h, "undeformed",
        "per brick of brick_cells^3 interpolation cells of the distance grid, a bound of |grad f| "
        "over the brick and its 26 neighbours (>= 1), read nearest",
        true);
    out.push_back(std::move(bd));
    out.push_back(std::move(bs));
  }
  return out;
}

namespace {

// The sidecar's description of the box, its textures and what they mean (all but "files").
nlohmann::json sidecar(const BakedBox& baked, const std::vector<ExportedTexture>& textures,
                       const ExportSource& source, const ExportOptions& options) {
  const BoxTextures& tex = baked.textures;
  const BakeReport& report = baked.report;
  const Box& box = tex.box;
  const Eigen::Vector3d h = box.half_extents;
  nlohmann::json side;
  side["schema"] = "raywarp.export";
  side["version"] = kExportSchemaVersion;
  side["raywarp"] = {{"version", kVersion}, {"build", executable_hash()}};
  side["input_hash"] = source.input_hash.empty()
                           ? export_input_hash(source.mesh_hash, source.box, options)
                           : source.input_hash;
  side["source"] = {{"scene", source.scene},
                    {"box_index", source.box_index},
                    {"mesh", source.mesh},
                    {"mesh_hash", source.mesh_hash}};
  side["box"] = {{"centre", vec(box.centre)},
                 {"half_extents", vec(h)},
                 {"rotation", matrix(box.rotation)},
                 {"rotation_meaning", "columns: the box's local x, y, z axes in object space"}};
  side["deformer"] = source.box.contains("deformer") ? source.box["deformer"] : nlohmann::json();
  side["description"] = report.deformer;
  side["parameters"] = report.parameters;
  side["encoding"] = kEncoding;
  if (tex.cylindrical()) {
    const int a = tex.cylindrical_axis;
    side["mapping"] = {
        {"type", "cylindrical"},
        {"axis", std::string(1, "xyz"[a])},
        {"units", vec(cylindrical_units(h, a))},
        {"meaning",
         "the deformation and alpha textures are over (theta, r, h) about the box's axis through "
         "its centre: with u = axis + 1, v = axis + 2 (mod 3), theta = atan2(q_v, q_u) in radians "
         "(periodic: wrap with repeat along the texture's first axis, clamp along the others), "
         "r = sqrt(q_u^2 + q_v^2), h = q_axis; regions and dtheta, dr, dh are stored divided by "
         "units = (1, max(h_u, h_v), h_axis). D holds the preimage's (theta, r, h) minus the "
         "point's: p = cartesian(c + D(c)) at c = cylindrical(p'). Read beyond the region along r "
         "or h: no preimage. A box that moves nothing (a cut) has only A so mapped"}};
  } else {
    side["mapping"] = {{"type", "cartesian"}};
  }
  if (tex.uses_depth_cube) {
    const DepthCube& cube = tex.depth_cube;
    nlohmann::json maps = nlohmann::json::array();
    for (int k = 0; k < 6; ++k) {
      const DepthMap& m = cube.maps[k];
      maps.push_back({{"face", face_name(face_of(k))},
                      {"slice", k},
                      {"u_axis", std::string(1, "xyz"[m.u_axis])},
                      {"v_axis", std::string(1, "xyz"[m.v_axis])},
                      {"texels", {m.nu, m.nv}},
                      {"origin", {m.origin.x() / h[m.u_axis], m.origin.y() / h[m.v_axis]}}});
    }
    side["depth_cube"] = {
        {"resolution", std::lround(2.0 * h.maxCoeff() / cube.spacing)},
        {"far_depth", cube_far(tex)},
        {"maps", maps},
        {"meaning",
         "the implicit is a depth-map cube, not a distance grid: texture depth holds map k in "
         "slice k of 8 (7 and 8 repeat map 5, so that slice centres (k + 0.5) / 8 are exact), "
         "its texel (i, j) at (i, j) and the rest of the slice repeating its last column and row. "
         "Texel side = 2 / resolution of the largest half extent; origin (box units along u_axis "
         "and v_axis) is a map's lower corner; depths and far_depth are in units of the largest "
         "half extent. With d_k the depth of p from face k, f_k = d_k - H_k (H bilinear, clamped "
         "to the map's outer texel centres), f = min |f_k|, negated unless every f_k > 0"}};
  }
  side["texture_map"] = matrix(map_to_box_units(tex.texture_map, h));
  if (!source.animation.is_null()) side["animation"] = source.animation;
  side["texture_map_meaning"] =
      "M of Correa & Silver eq. 2, box units, row-major, column vectors: D is read at M p'";
  side["reuse"] = kReuse;
  side["mipmaps"] = kMipmaps;
  side["sampling"] = "trilinear, clamp to edge, linear (not sRGB) values";
  side["render"] = {
      {"moves_nothing", tex.moves_nothing},
      {"has_cut", tex.has_cut},
      {"cut_mode", tex.has_cut ? cut_mode_name(tex.cut_mode) : "none"},
      {"shell_thickness_voxels", tex.has_cut ? tex.shell_thickness / implicit_spacing(tex) : 0.0},
      {"lipschitz", std::isfinite(tex.lipschitz) ? tex.lipschitz : -1.0},
      {"voxel_box_units", implicit_spacing(tex) / h.maxCoeff()},
      {"distance_background_voxels", implicit_background(tex) / implicit_spacing(tex)},
      {"band_voxels", tex.sdf.band_voxels},
      {"seam_voxels", kSeamVoxels},
      {"cap_voxels", kCapVoxels}};
  if (!tex.step_bounds.empty())
    side["render"]["step_bounds"] = {
        {"brick_cells", tex.step_bounds.brick_cells},
        {"sdf_lipschitz", std::isfinite(tex.step_bounds.sdf_lipschitz)
                              ? tex.step_bounds.sdf_lipschitz
                              : -1.0},  // -1: unknown
        {"validity_lipschitz_box_units", tex.step_bounds.validity_lipschitz * h.maxCoeff()}};
  const Eigen::AlignedBox3d region = ray_cast_region(tex);
  side["render"]["ray_cast_region"] = {{"min", vec(region.min().cwiseQuotient(h))},
                                       {"max", vec(region.max().cwiseQuotient(h))}};
  side["figures"] = {{"voxel", implicit_spacing(tex)},
                     {"texture_error", report.texture_error},
                     {"texture_error_voxels", report.texture_error_voxels()},
                     {"alpha_error", report.alpha_error},
                     {"inverse_residual",
                      {{"max", report.residual.max},
                       {"mean", report.residual.mean},
                       {"texels", report.residual.texels},
                       {"over_tolerance", report.residual.over_tolerance},
                       {"in_cut", report.residual.in_cut},
                       {"tolerance", report.residual.tolerance},
                       {"folded", report.residual.folded}}},
                     {"folded_volume", report.folds.folded_volume},
                     {"box_volume", report.folds.box_volume},
                     {"units", "object units of the source mesh"}};
  nlohmann::json warnings = nlohmann::json::array();
  for (const auto& w : report.warnings)
    warnings.push_back({{"code", w.code}, {"message", w.message}});
  side["warnings"] = warnings;
  nlohmann::json entries = nlohmann::json::object();
  for (const auto& t : textures) entries[t.volume.name] = texture_entry(t);
  side["textures"] = entries;

  return side;
}

// Writes texture `t` in format `f` (KTX2, DDS or an atlas) and returns its entry of the
// sidecar's "files"; a texture the format cannot hold adds a warning and returns null.
nlohmann::json write_texture_file(const ExportedTexture& t, ExportFormat f, const BoxTextures& tex,
                                  const ExportOptions& options, const fs::path& dir,
                                  const std::string& stem, const std::string& embedded,
                                  nlohmann::json& warnings) {
  auto record = [&](const std::string& name, Storage storage, double error,
                    nlohmann::json extra = {}) {
    nlohmann::json e = {
        {"texture", t.volume.name},
        {"format", format_name(f)},
        {"file", name},
        {"bytes", fs::file_size(dir / name)},
        {"storage", f == ExportFormat::AtlasPng ? "unorm16" : storage_name(storage)},
        {"max_error", error}};
    for (auto it = extra.begin(); it != extra.end(); ++it) e[it.key()] = it.value();
    return e;
  };
  if (f == ExportFormat::AtlasPng && t.volume.name == "depth") {
    warnings.push_back(
        {{"code", "depth_cube_not_in_png"},
         {"message",
          "the depth cube's texture is not written as a 16-bit PNG: its range (+-far_depth) "
          "leaves codes " +
              std::to_string(2.0 * cube_far(tex) / 65535.0) +
              " largest half extents apart; read it from ktx2, dds or atlas-exr"}});
    return nullptr;
  }
  const std::string name = file_name(stem, t.volume.name, f);
  const std::string path = (dir / name).string();
  const TextureVolume v = as_stored(t, options.storage);
  if (f == ExportFormat::Ktx2) {
    const auto bytes = encode_ktx2(v, options.storage, {{"raywarp.export", embedded}});
    write_file_atomic(path, bytes.data(), bytes.size());
    return record(name, options.storage, decode_error(t, v));
  } else if (f == ExportFormat::Dds) {
    const auto bytes =
        encode_dds(v, options.storage, options.dds_legacy ? DdsHeader::Legacy : DdsHeader::Dx10);
    write_file_atomic(path, bytes.data(), bytes.size());
    return record(name, options.storage, decode_error(t, v),
                  {{"header", options.dds_legacy ? "legacy FourCC" : "DX10"}});
  } else {
    const AtlasLayout layout = atlas_layout(t.volume.dims, options.atlas_border);
    nlohmann::json atlas = {{"tiles", {layout.tiles_x, layout.tiles_y}},
                            {"border", layout.border},
                            {"size", {layout.width(), layout.height()}},
                            {"order",
                             "slice z at tile (z % tiles_x, z / tiles_x), tile rows from the "
                             "top; within a tile, texel row j is image row j from the tile's "
                             "top (plus the border)"}};
    if (f == ExportFormat::AtlasExr) {
      write_atlas_exr(path, v, layout, options.storage);
      return record(name, options.storage, decode_error(t, v), atlas);
    } else {
      // 16-bit unsigned codes over each channel's range; bounds are exported exactly only
      // as floats, so their unorm codes are rounded up like their halves.
      TextureVolume in = t.volume;
      const UnormEncoding enc = write_atlas_png16(path, in, layout);
      const TextureVolume back = read_atlas_png16(path, layout, enc, in.channels);
      double error = decode_error(t, back);
      if (t.round_up)  // a unorm code may round a bound down: say so rather than hide it
        for (size_t i = 0; i < back.values.size(); ++i)
          if (back.values[i] < in.values[i]) {
            atlas["bound_warning"] = "unorm16 codes may round a bound down by up to max_error";
            break;
          }
      atlas["decode"] = "stored = lo + code / 65535 * (hi - lo), then object = stored * scale";
      atlas["lo"] = enc.lo;
      atlas["hi"] = enc.hi;
      return record(name, Storage::Float, error, atlas);
    }
  }
}

// Writes every grid into one OpenVDB file and returns its entry of the sidecar's "files".
nlohmann::json write_vdb_file(const std::vector<ExportedTexture>& textures, const BoxTextures& tex,
                              const fs::path& dir, const std::string& stem,
                              const std::string& embedded) {
  const Box& box = tex.box;
  const Eigen::Vector3d h = box.half_extents;
  // For DCC tools: object space and object units (vectors rotated into the object frame), the
  // index-to-world transform of each grid placing voxel centres where the texels' are.
  std::vector<VdbGrid> grids;
  for (const auto& t : textures) {
    // The bounds are for ray casters, not DCC tools; so is a depth cube's maps.
    if (t.round_up || !t.has_region) continue;
    Eigen::Matrix4d index_to_local = Eigen::Matrix4d::Identity();
    const Eigen::Vector3d spacing = t.spacing_box_units.cwiseProduct(h);
    const Eigen::Vector3d first = t.origin_box_units.cwiseProduct(h) + 0.5 * spacing;
    index_to_local.topLeftCorner<3, 3>() = spacing.asDiagonal();
    index_to_local.topRightCorner<3, 1>() = first;
    const Eigen::Matrix4d index_to_world = box.local_to_object() * index_to_local;
    const TextureVolume& v = t.volume;
    if (t.volume.name == "deformation") {
      VdbGrid dg;
      dg.name = "deformation";
      dg.index_to_world = index_to_world;
      dg.vector_is_displacement = true;
      dg.volume = volume_from("deformation", v.dims, 3, [&](int i, int j, int k, int c) {
        Eigen::Vector3d local(v.at(i, j, k, 0) * h.x(), v.at(i, j, k, 1) * h.y(),
                              v.at(i, j, k, 2) * h.z());
        return static_cast<float>((box.rotation * local)[c]);
      });
      VdbGrid valid;
      valid.name = "valid";
      valid.index_to_world = index_to_world;
      valid.volume = volume_from("valid", v.dims, 1,
                                 [&](int i, int j, int k, int) { return v.at(i, j, k, 3); });
      grids.push_back(std::move(dg));
      grids.push_back(std::move(valid));
    } else {
      VdbGrid s;
      s.name = t.volume.name;
      s.index_to_world = index_to_world;
      s.volume = volume_from(t.volume.name, v.dims, 1, [&](int i, int j, int k, int) {
        return static_cast<float>(v.at(i, j, k, 0) * t.scale[0]);
      });
      if (t.volume.name == "distance") {
        // OpenVDB's level sets are negative inside: f's sign flipped, as tools expect.
        for (float& x : s.volume.values) x = -x;
        s.level_set = true;
        s.background = static_cast<float>(tex.sdf.background);
      }
      grids.push_back(std::move(s));
    }
  }
  const std::string name = stem + ".vdb";
  write_vdb((dir / name).string(), grids, {{"raywarp.export", embedded}});
  nlohmann::json e = {
      {"texture", "all"},
      {"format", "vdb"},
      {"file", name},
      {"bytes", fs::file_size(dir / name)},
      {"storage", "float"},
      {"max_error", 0.0},
      {"grids", tex.uses_depth_cube
                    ? "deformation (vec3, object space and units, p = p' + D), valid, "
                      "alpha (cuts); no distance: the implicit is a depth cube"
                    : "deformation (vec3, object space and units, p = p' + D), valid, "
                      "distance (level set, OpenVDB's sign: negative inside), alpha "
                      "(cuts)"}};
  return e;
}

}  // namespace

nlohmann::json export_box(const BakedBox& baked, const ExportSource& source,
                          const ExportOptions& options, const fs::path& dir,
                          const std::string& stem) {
  const std::vector<ExportedTexture> textures = export_textures(baked);
  if (options.atlas_border < 0 || options.atlas_border > 1)
    throw Error("atlas border = " + std::to_string(options.atlas_border) + ": must be 0 or 1");
  nlohmann::json side = sidecar(baked, textures, source, options);
  // The metadata each texture carries inside its own file (KTX2 key/value, OpenVDB metadata):
  // the sidecar without the list of files (which the files cannot know before they exist).
  const std::string embedded = side.dump();
  fs::create_directories(dir);
  nlohmann::json files = nlohmann::json::array();
  for (ExportFormat f : options.formats) {
    if (f == ExportFormat::Vdb) continue;  // below: one file for every grid
    for (const auto& t : textures)
      if (nlohmann::json e = write_texture_file(t, f, baked.textures, options, dir, stem, embedded,
                                                side["warnings"]);
          !e.is_null())
        files.push_back(std::move(e));
  }
  if (std::find(options.formats.begin(), options.formats.end(), ExportFormat::Vdb) !=
      options.formats.end())
    files.push_back(write_vdb_file(textures, baked.textures, dir, stem, embedded));
  side["files"] = files;
  const std::string text = side.dump(2) + "\n";
  write_file_atomic((dir / (stem + ".json")).string(), text);
  return side;
}

BoxTextures import_box(const fs::path& sidecar, ExportFormat format) {
  if (format == ExportFormat::Vdb)
    throw Error("import_box: reads ktx2, dds, atlas-png or atlas-exr files, not vdb");
  const std::string where = sidecar.string();
  nlohmann::json side;
  {
    std::ifstream in(sidecar);
    if (!in) throw Error(where + ": cannot read");
    try {
      side = nlohmann::json::parse(in);
    } catch (const std::exception& e) {
      throw Error(where + ": not JSON: " + e.what());
    }
  }
  try {
    if (side.value("schema", "") != "raywarp.export")
      throw Error(where + ": schema: not a raywarp export sidecar");
    if (side.at("version").get<int>() > kExportSchemaVersion)
      throw Error(where + ": version " + side.at("version").dump() + ": this raywarp reads up to " +
                  std::to_string(kExportSchemaVersion));
    BoxTextures tex;
    auto v3 = [](const nlohmann::json& j) {
      return Eigen::Vector3d(j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>());
    };
    tex.box.centre = v3(side.at("box").at("centre"));
    tex.box.half_extents = v3(side.at("box").at("half_extents"));
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c)
        tex.box.rotation(r, c) = side.at("box").at("rotation").at(r).at(c).get<double>();
    const Eigen::Vector3d h = tex.box.half_extents;
    if (!(h.minCoeff() > 0)) throw Error(where + ": box.half_extents: must be > 0");
    const nlohmann::json& render = side.at("render");
    tex.moves_nothing = render.at("moves_nothing").get<bool>();
    tex.has_cut = render.at("has_cut").get<bool>();
    const double voxel = render.at("voxel_box_units").get<double>() * h.maxCoeff();
    if (tex.has_cut) {
      const std::string mode = render.at("cut_mode").get<std::string>();
      tex.cut_mode = mode == "hollow"        ? CutMode::Hollow
                     : mode == "thick_shell" ? CutMode::ThickShell
                                             : CutMode::Solid;
      tex.shell_thickness = render.at("shell_thickness_voxels").get<double>() * voxel;
    }
    const double lipschitz = render.at("lipschitz").get<double>();
    tex.lipschitz = lipschitz < 0 ? std::numeric_limits<double>::infinity() : lipschitz;
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) m(r, c) = side.at("texture_map").at(r).at(c).get<double>();
    tex.texture_map = map_from_box_units(m, h);
    Eigen::Vector3d units = h;  // of D's and A's regions and displacements
    if (side.contains("mapping") && side.at("mapping").at("type") == "cylindrical") {
      const std::string axis = side.at("mapping").at("axis").get<std::string>();
      if (axis != "x" && axis != "y" && axis != "z")
        throw Error(where + ": mapping.axis: \"" + axis + "\" is none of x, y, z");
      tex.cylindrical_axis = axis[0] - 'x';
      units = cylindrical_units(h, tex.cylindrical_axis);
    } else if (side.contains("mapping") && side.at("mapping").at("type") != "cartesian") {
      throw Error(where + ": mapping.type: " + side.at("mapping").at("type").dump() +
                  " is neither cartesian nor cylindrical");
    }
    const nlohmann::json& rr = render.at("ray_cast_region");
    tex.region =
        Eigen::AlignedBox3d(v3(rr.at("min")).cwiseProduct(h), v3(rr.at("max")).cwiseProduct(h));

    // Each texture: decoded values in object units on its grid.
    auto load = [&](const std::string& name, int channels,
                    const Eigen::Vector3d& u) -> Grid3<Eigen::Vector4f> {
      const nlohmann::json& t = side.at("textures").at(name);
      const nlohmann::json* file = nullptr;
      for (const auto& f : side.at("files"))
        if (f.at("texture") == name && f.at("format") == format_name(format)) file = &f;
      if (!file)
        throw Error(where + ": files: no " + std::string(format_name(format)) + " file of " + name);
      const fs::path path = sidecar.parent_path() / file->at("file").get<std::string>();
      const Eigen::Vector3i dims(t.at("dims").at(0).get<int>(), t.at("dims").at(1).get<int>(),
                                 t.at("dims").at(2).get<int>());
      TextureVolume v;
      if (format == ExportFormat::Ktx2) {
        v = decode_ktx2(read_bytes(path), path.string()).volume;
      } else if (format == ExportFormat::Dds) {
        v = decode_dds(read_bytes(path), path.string());
      } else {
        const AtlasLayout layout =
            atlas_layout(dims, file->at("border").get<int>(), file->at("tiles").at(0).get<int>());
        if (format == ExportFormat::AtlasExr) {
          v = read_atlas_exr(path.string(), layout, channels);
        } else {
          UnormEncoding enc;
          enc.lo = file->at("lo").get<std::vector<double>>();
          enc.hi = file->at("hi").get<std::vector<double>>();
          v = read_atlas_png16(path.string(), layout, enc, channels);
        }
      }
      if (v.dims != dims || v.channels != channels)
        throw Error(path.string() + ": holds " + std::to_string(v.dims.x()) + "x" +
                    std::to_string(v.dims.y()) + "x" + std::to_string(v.dims.z()) + "x" +
                    std::to_string(v.channels) + " texels, the sidecar says " +
                    t.at("dims").dump() + "x" + std::to_string(channels));
      const std::vector<double> scale = t.at("scale").get<std::vector<double>>();
      if (scale.size() != static_cast<size_t>(channels))
        throw Error(where + ": textures." + name + ".scale: " + std::to_string(channels) +
                    " numbers expected");
      // A texture with no region (a depth cube's maps) is read on the grid of its texels.
      Eigen::Vector3d origin = Eigen::Vector3d::Zero();
      Eigen::Vector3d upper = dims.cast<double>();
      if (t.contains("region")) {
        origin = v3(t.at("region").at("min")).cwiseProduct(u);
        upper = v3(t.at("region").at("max")).cwiseProduct(u);
      }
      Grid3<Eigen::Vector4f> g(origin, (upper - origin).cwiseQuotient(dims.cast<double>()), dims,
                               Eigen::Vector4f::Zero());
      for (int k = 0; k < dims.z(); ++k)
        for (int j = 0; j < dims.y(); ++j)
          for (int i = 0; i < dims.x(); ++i)
            for (int c = 0; c < channels; ++c) {
              const float x = static_cast<float>(v.at(i, j, k, c) * scale[c]);
              if (!std::isfinite(x)) throw Error(path.string() + ": a texel is not finite");
              g.at(i, j, k)[c] = x;
            }
      return g;
    };
    auto scalar = [&](const std::string& name, const Eigen::Vector3d& u) {
      Grid3<Eigen::Vector4f> g = load(name, 1, u);
      Grid3<float> s(g.origin, g.spacing, g.dims);
      for (size_t i = 0; i < g.data.size(); ++i) s.data[i] = g.data[i][0];
      return s;
    };
    tex.deformation.grid = load("deformation", 4, tex.moves_nothing ? h : units);
    if (side.contains("depth_cube")) {
      const nlohmann::json& dc = side.at("depth_cube");
      const int resolution = dc.at("resolution").get<int>();
      if (resolution < 1 || resolution > 65536)
        throw Error(where + ": depth_cube.resolution = " + std::to_string(resolution) +
                    ": must be in [1, 65536]");
      // The layout the resolution implies must be the texture's before any map is allocated.
      const Eigen::Vector3i n = depth_cube_dims(h, resolution);
      const int width = std::max(n.x(), n.y()), height = std::max(n.y(), n.z());
      const nlohmann::json& dims = side.at("textures").at("depth").at("dims");
      if (dims != nlohmann::json{width, height, DepthCube::Layers::kDepth})
        throw Error(where + ": textures.depth.dims = " + dims.dump() +
                    ": a depth cube of resolution " + std::to_string(resolution) +
                    " over this box is " + std::to_string(width) + "x" + std::to_string(height) +
                    "x" + std::to_string(DepthCube::Layers::kDepth) + " texels");
      DepthCube cube = depth_cube_layout(h, resolution);
      const double far = dc.at("far_depth").get<double>() * h.maxCoeff();
      if (!(far > 2.0 * h.maxCoeff()) || !std::isfinite(far))
        throw Error(where + ": depth_cube.far_depth: must exceed the box's size (2)");
      cube.far_depth = static_cast<float>(far);
      cube.set_depths_from_layers(scalar("depth", h).data);
      tex.depth_cube = std::move(cube);
      tex.uses_depth_cube = true;
    } else {
      tex.sdf.grid = scalar("distance", h);
      tex.sdf.background =
          static_cast<float>(render.at("distance_background_voxels").get<double>() * voxel);
      tex.sdf.band_voxels = render.at("band_voxels").get<double>();
    }
    if (tex.has_cut) tex.alpha.grid = scalar("alpha", units);
    if (side.at("textures").contains("step_bounds_d")) {
      const nlohmann::json& sb = render.at("step_bounds");
      tex.step_bounds.bricks = scalar("step_bounds_d", h);
      tex.step_bounds.sdf_bricks = scalar("step_bounds_sdf", h);
      tex.step_bounds.brick_cells = sb.at("brick_cells").get<int>();
      const double sdf_lipschitz = sb.at("sdf_lipschitz").get<double>();
      tex.step_bounds.sdf_lipschitz =
          sdf_lipschitz < 0 ? std::numeric_limits<double>::infinity() : sdf_lipschitz;
      tex.step_bounds.validity_lipschitz =
          sb.at("validity_lipschitz_box_units").get<double>() / h.maxCoeff();
    }
    return tex;
  } catch (const nlohmann::json::exception& e) {
    throw Error(where + ": " + e.what());
  }
}

TextureVolume orientation_volume() {
  const Eigen::Vector3i dims(16, 12, 8);
  return volume_from("orientation", dims, 4, [&](int i, int j, int k, int c) {
    if (c == 3) return (i < 2 && j < 2 && k < 2) ? 0.0f : 1.0f;
    const int index[3] = {i, j, k};
    return static_cast<float>((index[c] + 0.5) / dims[c]);
  });
}

nlohmann::json export_orientation(const ExportOptions& options, const fs::path& dir) {
  const TextureVolume v = orientation_volume();
  ExportedTexture t;
  t.volume = v;
  t.object = v.values;
  t.scale = {1, 1, 1, 1};
  t.channels = {"u", "v", "w", "marker"};
  t.origin_box_units = Eigen::Vector3d::Constant(-1);
  t.spacing_box_units = Eigen::Vector3d(2.0 / 16, 2.0 / 12, 2.0 / 8);
  nlohmann::json side;
  side["schema"] = "raywarp.orientation";
  side["version"] = kExportSchemaVersion;
  side["raywarp"] = {{"version", kVersion}};
  side["dims"] = ivec(v.dims);
  side["expect"] =
      "Sampled at texture coordinate (u, v, w), the texture reads R = u, G = v, B = w (linear "
      "values: with sRGB on, they read darker) and A = 0 only within 2 texels of (0, 0, 0), the "
      "first texel in memory. dims differ per axis (16 x 12 x 8): a swapped axis shows a ramp of "
      "the wrong length; a flipped axis shows R, G or B falling where u, v or w rise; a "
      "mis-sliced atlas shows B jumping between slices.";
  side["encoding"] = kEncoding;
  side["mipmaps"] = kMipmaps;
  fs::create_directories(dir);
  nlohmann::json files = nlohmann::json::array();
  const std::string embedded = side.dump();
  for (ExportFormat f : options.formats) {
    const std::string name = std::string("orientation") + format_extension(f);
    const std::string path = (dir / name).string();
    const TextureVolume s = as_stored(t, options.storage);
    nlohmann::json e = {{"format", format_name(f)}, {"file", name}};
    if (f == ExportFormat::Ktx2) {
      const auto bytes = encode_ktx2(s, options.storage, {{"raywarp.orientation", embedded}});
      write_file_atomic(path, bytes.data(), bytes.size());
    } else if (f == ExportFormat::Dds) {
      const auto bytes =
          encode_dds(s, options.storage, options.dds_legacy ? DdsHeader::Legacy : DdsHeader::Dx10);
      write_file_atomic(path, bytes.data(), bytes.size());
    } else if (f == ExportFormat::Vdb) {
      VdbGrid rgb, a;
      Eigen::Matrix4d index_to_world = Eigen::Matrix4d::Identity();
      index_to_world.topLeftCorner<3, 3>() = t.spacing_box_units.asDiagonal();
      index_to_world.topRightCorner<3, 1>() = t.origin_box_units + 0.5 * t.spacing_box_units;
      rgb.name = "uvw";
      rgb.index_to_world = index_to_world;
      rgb.volume = volume_from("uvw", v.dims, 3,
                               [&](int i, int j, int k, int c) { return v.at(i, j, k, c); });
      a.name = "marker";
      a.index_to_world = index_to_world;
      a.volume = volume_from("marker", v.dims, 1,
                             [&](int i, int j, int k, int) { return v.at(i, j, k, 3); });
      write_vdb(path, {rgb, a}, {{"raywarp.orientation", embedded}});
    } else {
      const AtlasLayout layout = atlas_layout(v.dims, options.atlas_border);
      e["tiles"] = {layout.tiles_x, layout.tiles_y};
      e["border"] = layout.border;
      if (f == ExportFormat::AtlasExr) {
        write_atlas_exr(path, s, layout, options.storage);
      } else {
        // Codes over [0, 1], so an engine's unorm read gives R = u, G = v, B = w as they are.
        UnormEncoding enc;
        enc.lo.assign(4, 0.0);
        enc.hi.assign(4, 1.0);
        write_atlas_png16(path, v, layout, enc);
        e["lo"] = enc.lo;
        e["hi"] = enc.hi;
      }
    }
    e["bytes"] = fs::file_size(path);
    files.push_back(e);
  }
  side["files"] = files;
  write_file_atomic((dir / "orientation.json").string(), side.dump(2) + "\n");
  return side;
}

nlohmann::json export_animation(const Scene& scene, size_t index) {
  const BoxSpec& b = scene.boxes[index];
  if (!b.then.empty() || b.mapping.cylindrical || scene.render.sampling == Sampling::Bounded)
    return {};
  const char* axes = "xyz";
  if (b.deformer.type == "twist" && b.deformer.angle_deg != 0.0) {
    const int a = b.deformer.axis;
    return {{"parameter", "angle_deg"},
            {"baked", b.deformer.angle_deg},
            {"axis", std::string(1, axes[a])},
            {"lipschitz_add", 1.0},
            {"texture_map",
             "a twist of angle t between 0 and the baked angle A (of A's sign) is the baked twist "
             "read at M p': s = t / A, M the identity but for row `axis`: M[axis][axis] = s, "
             "M[axis][3] = s - 1 (box units; object units: h_axis (s - 1)), a scale along the axis "
             "about the box's lower face; add lipschitz_add to render.lipschitz"}};
  }
  if (b.deformer.type == "peel") {
    const int a = 3 - b.deformer.axis - b.deformer.from_axis;
    return {{"parameter", "hinge"},
            {"baked", b.deformer.hinge},
            {"axis", std::string(1, axes[a])},
            {"lipschitz_add", 0.0},
            {"texture_map",
             "a peel of hinge g at or above the baked hinge b is the baked peel read at M p': M "
             "the identity but for M[axis][3] = -(g - b) / h_axis (box units; object units: "
             "-(g - b)), a translation along the peel direction `axis`"}};
  }
  return {};
}

BakeJob export_job(const Scene& scene, size_t index, MeshPtr mesh) {
  // A box an engine animates through M has D's texel centres on its lower faces, as raywarp
  // render --frames bakes it.
  BakeJob job = make_job(scene, index, std::move(mesh), !export_animation(scene, index).is_null());
  job.texture_bits = 32;
  // The step bounds where the box can use them (a cylindrical texture has none: no Lipschitz
  // bound of its D is measured, and bounded tracing refuses it).
  // A depth cube has none either: its |f| bounds no distance.
  if (!scene.boxes[index].mapping.cylindrical && job.spec.implicit.type != "depth_cube")
    job.sampling = Sampling::Bounded;
  return job;
}

}  // namespace raywarp
