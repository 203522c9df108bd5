#include "cli/library.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <ostream>
#include <regex>
#include <set>
#include <sstream>

#include "base/atomic_file.h"
#include "base/clock.h"
#include "base/error.h"
#include "base/format.h"
#include "base/version.h"
#include "cli/engine_bundles.h"
#include "cli/export.h"
#include "cli/viewer_assets.h"
#include "gl/context.h"
#include "gl/renderer.h"
#include "library/bake_cache.h"
#include "library/image.h"
#include "library/prepare.h"

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#include <stb/stb_easy_font.h>
#pragma GCC diagnostic pop

namespace raywarp {

namespace fs = std::filesystem;

namespace {

constexpr int kIndexVersion = 1;

// One entry to build: its name, its scene document, and the file its relative paths resolve
// against (the scene file, or the presets file).
struct EntrySource {
  std::string name;
  nlohmann::json document;
  fs::path path;
};

nlohmann::json read_json(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw Error(path.string() + ": cannot read");
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw Error(path.string() + ": not JSON: " + e.what());
  }
}

void check_name(const std::string& name, const std::string& where) {
  static const std::regex ok("[A-Za-z0-9][A-Za-z0-9_.-]{0,99}");
  if (!std::regex_match(name, ok))
    throw Error(where + " = \"" + name +
                "\": an entry name is 1 to 100 letters, digits, '_', '-' or '.', starting with a "
                "letter or digit (it names a folder)");
}

// A presets file: {"mesh", "camera", "render" (optional), "box": the box every preset starts
// from, "presets": [{"name", "deformer", ... any other box field, overriding "box"}]}.
std::vector<EntrySource> read_presets(const fs::path& path) {
  const nlohmann::json doc = read_json(path);
  const std::string where = path.string();
  if (!doc.is_object() || !doc.contains("presets") || !doc["presets"].is_array())
    throw Error(where +
                ": presets: missing; a presets file is {\"mesh\": ..., \"camera\": ..., "
                "\"box\": {...}, \"presets\": [{\"name\": ..., \"deformer\": {...}}, ...]}");
  for (const char* key : {"mesh", "camera", "box"})
    if (!doc.contains(key)) throw Error(where + ": " + key + ": missing");
  if (!doc["box"].is_object()) throw Error(where + ": box: must be an object (a scene box)");
  std::vector<EntrySource> out;
  for (size_t i = 0; i < doc["presets"].size(); ++i) {
    const nlohmann::json& p = doc["presets"][i];
    const std::string field = "presets[" + std::to_string(i) + "]";
    if (!p.is_object() || !p.contains("name") || !p["name"].is_string())
      throw Error(where + ": " + field + ".name: missing (a string naming the entry)");
    const std::string name = p["name"].get<std::string>();
    check_name(name, where + ": " + field + ".name");
    nlohmann::json box = doc["box"];
    for (auto it = p.begin(); it != p.end(); ++it)
      if (it.key() != "name") box[it.key()] = it.value();
    nlohmann::json scene = {{"mesh", doc["mesh"]}, {"camera", doc["camera"]}, {"boxes", {box}}};
    if (doc.contains("render")) scene["render"] = doc["render"];
    out.push_back({name, scene, path});
  }
  return out;
}

std::vector<EntrySource> list_entries(const fs::path& input) {
  std::vector<EntrySource> out;
  if (fs::is_directory(input)) {
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(input))
      if (e.is_regular_file() && e.path().extension() == ".json") files.push_back(e.path());
    std::sort(files.begin(), files.end());
    for (const fs::path& f : files) {
      const std::string name = f.stem().string();
      check_name(name, f.string() + ": the entry's name (the file's stem)");
      out.push_back({name, read_scene_document(f), f});
    }
    if (out.empty())
      throw Error(input.string() +
                  ": no scene files (*.json) in this folder; a library is built "
                  "from a folder of scene files or a presets file");
  } else if (fs::is_regular_file(input)) {
    out = read_presets(input);
  } else {
    throw Error(input.string() +
                ": no such folder or file (give a folder of scene files or a presets file)");
  }
  std::set<std::string> names;
  for (const auto& e : out)
    if (!names.insert(e.name).second)
      throw Error(e.path.string() + ": entry \"" + e.name + "\" appears twice");
  return out;
}

std::string hex64(std::uint64_t h) {
  char s[17];
  std::snprintf(s, sizeof s, "%016llx", static_cast<unsigned long long>(h));
  return s;
}

// Everything an entry's files depend on.
std::string entry_hash(const EntrySource& e, const Scene& scene, const LibraryOptions& o) {
  std::string text = std::string("raywarp ") + kVersion + "\nlibrary " +
                     std::to_string(kIndexVersion) + "\nscene " + e.document.dump() + "\nmesh " +
                     file_hash(scene.mesh) + "\ncamera " +
                     (scene.camera ? camera_to_json(*scene.camera).dump() : "none") +
                     "\nthumbnail " + std::to_string(o.thumbnail_size) + "\nexport " +
                     export_input_hash("", nlohmann::json(), o.export_options);
  return hex64(fnv1a(text.data(), text.size()));
}

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// The options a job repeats, as command-line arguments.
std::string option_arguments(const LibraryOptions& o) {
  std::string formats;
  for (ExportFormat f : o.export_options.formats) {
    if (!formats.empty()) formats += ',';
    formats += format_name(f);
  }
  std::string a = " --format ";
  a += formats;
  if (o.export_options.storage == Storage::Float) a += " --float";
  if (o.export_options.atlas_border) a += " --atlas-border 1";
  if (o.export_options.dds_legacy) a += " --dds-legacy";
  a += " --thumbnail-size " + std::to_string(o.thumbnail_size);
  a += " --context " + o.context;
  if (o.no_cache) a += " --no-cache";
  if (!o.cache_dir.empty()) a += " --cache-dir " + shell_quote(fs::absolute(o.cache_dir).string());
  if (o.force) a += " --force";
  return a;
}

Image render_textures(const Scene& scene, const Mesh& mesh, const std::vector<BoxTextures>& boxes,
                      int width, int height) {
  gl::Renderer renderer;
  renderer.set_mesh(mesh);
  renderer.set_boxes(boxes);
  return renderer.render(*scene.camera, width, height, scene.render);
}

// The largest size of the camera's aspect within side x side.
Eigen::Vector2i thumbnail_size(const Eigen::Vector2i& full, int side) {
  const double s = double(side) / std::max(full.x(), full.y());
  return {std::max(1, int(std::lround(full.x() * s))), std::max(1, int(std::lround(full.y() * s)))};
}

// Builds one entry into OUT/entries/NAME (see the header); returns its record.
nlohmann::json build_entry(const EntrySource& e, const LibraryOptions& o, BakeSession& session,
                           const std::string& hash, std::ostream& report) {
  const fs::path entries = o.out / "entries";
  const fs::path final_dir = entries / e.name;
  const fs::path tmp = entries / ("." + e.name + ".tmp-" + std::to_string(::getpid()));
  fs::remove_all(tmp);
  fs::create_directories(tmp);
  try {
    const Scene scene = load_scene_json(e.document, e.path);
    if (!scene.camera)
      throw Error(e.path.string() +
                  ": camera: missing; a library entry needs a camera for its "
                  "thumbnail and the viewer");
    MeshPtr mesh = session.mesh(scene.mesh);
    std::vector<BoxTextures> shown;
    nlohmann::json boxes = nlohmann::json::array();
    long warnings = 0;
    const bool has_ktx2 =
        std::find(o.export_options.formats.begin(), o.export_options.formats.end(),
                  ExportFormat::Ktx2) != o.export_options.formats.end();
    for (size_t i = 0; i < scene.boxes.size(); ++i) {
      const std::string tag = e.name + " box " + std::to_string(i) + ": ";
      const BakedBox baked = bake_logged(session, export_job(scene, i, mesh), report, tag);
      warnings += static_cast<long>(baked.report.warnings.size());
      ExportSource source = export_source(scene, e.document, i, *mesh);
      source.input_hash = hash;
      const std::string stem = e.name + "_box" + std::to_string(i);
      export_box(baked, source, o.export_options, tmp, stem);
      boxes.push_back(stem + ".json");
      // What a consumer loads: the KTX2 files read back (else the baked textures).
      shown.push_back(has_ktx2 ? import_box(tmp / (stem + ".json"), ExportFormat::Ktx2)
                               : baked.textures);
    }
    const nlohmann::json shaders = write_shader_bundle(shown, scene.render, tmp, e.name);
    for (size_t i = 0; i < scene.boxes.size(); ++i) {
      const std::string stem = e.name + "_box" + std::to_string(i);
      write_engine_bundles(
          read_json(tmp / (stem + ".json")), tmp, stem,
          BundleShaders{gl::raycast_variant(shown[i], scene.render), scene.render});
    }
    const Eigen::Vector2i full = image_size(scene, *scene.camera, 0, 0);
    const Eigen::Vector2i thumb = thumbnail_size(full, o.thumbnail_size);
    write_png((tmp / "thumbnail.png").string(),
              render_textures(scene, mesh->mesh, shown, thumb.x(), thumb.y()));
    const std::string mesh_file = "meshes/" + mesh->hash + ".bin";
    if (!fs::exists(o.out / mesh_file)) {
      fs::create_directories(o.out / "meshes");
      write_mesh_bin(mesh->mesh, o.out / mesh_file);
    }
    nlohmann::json record = {{"name", e.name},
                             {"source", e.path.filename().string()},
                             {"input_hash", hash},
                             {"raywarp", kVersion},
                             {"mesh", mesh_file},
                             {"camera", camera_to_json(*scene.camera)},
                             {"width", full.x()},
                             {"height", full.y()},
                             {"render", render_settings_to_json(scene.render)},
                             {"boxes", boxes},
                             {"shaders", shaders},
                             {"thumbnail", "thumbnail.png"},
                             {"warnings", warnings}};
    write_file_atomic((tmp / "entry.json").string(), record.dump(2) + "\n");
    // The whole folder replaces the previous entry at once.
    const fs::path old = entries / ("." + e.name + ".old-" + std::to_string(::getpid()));
    if (fs::exists(final_dir)) fs::rename(final_dir, old);
    fs::rename(tmp, final_dir);
    fs::remove_all(old);
    return record;
  } catch (...) {
    std::error_code ignored;
    fs::remove_all(tmp, ignored);
    throw;
  }
}

// The entry record of OUT/entries/NAME when it is complete (its files all there), else null.
nlohmann::json read_entry(const fs::path& out, const std::string& name) {
  const fs::path dir = out / "entries" / name;
  try {
    const nlohmann::json r = read_json(dir / "entry.json");
    if (!fs::exists(dir / r.at("thumbnail").get<std::string>())) return nullptr;
    for (const auto& b : r.at("boxes"))
      if (!fs::exists(dir / b.get<std::string>())) return nullptr;
    if (!fs::exists(out / r.at("mesh").get<std::string>())) return nullptr;
    return r;
  } catch (const std::exception&) {
    return nullptr;
  }
}

// Draws `text` into `image` at (x, y) (top-left), `scale` pixels per font unit, in grey `grey`.
void draw_text(Image& image, int x, int y, const std::string& text, int scale, std::uint8_t grey) {
  std::vector<char> buffer(64 * 1024);
  std::string copy = text;
  unsigned char colour[4] = {grey, grey, grey, 255};
  const int quads = stb_easy_font_print(0, 0, copy.data(), colour, buffer.data(),
                                        static_cast<int>(buffer.size()));
  struct Vertex {
    float x, y, z;
    unsigned char c[4];
  };
  const Vertex* v = reinterpret_cast<const Vertex*>(buffer.data());
  for (int q = 0; q < quads; ++q) {
    const Vertex* c = v + 4 * q;
    const int x0 = x + int(c[0].x * scale), y0 = y + int(c[0].y * scale);
    const int x1 = x + int(c[2].x * scale), y1 = y + int(c[2].y * scale);
    for (int py = std::max(0, y0); py < std::min(image.height, y1); ++py)
      for (int px = std::max(0, x0); px < std::min(image.width, x1); ++px)
        for (int k = 0; k < 3; ++k) image.rgba[(size_t(py) * image.width + px) * 4 + k] = grey;
  }
}

// One thumbnail per entry in rows of up to 5, each named underneath.
void write_contact_sheet(const fs::path& file, const fs::path& out,
                         const std::vector<nlohmann::json>& entries, int side) {
  const int columns = std::max(1, std::min<int>(5, static_cast<int>(entries.size())));
  const int rows = std::max(1, (static_cast<int>(entries.size()) + columns - 1) / columns);
  const int label = 24, pad = 8;
  const int cell_w = side + pad, cell_h = side + label + pad;
  Image sheet(columns * cell_w + pad, rows * cell_h + pad);
  std::fill(sheet.rgba.begin(), sheet.rgba.end(), std::uint8_t(236));
  for (size_t n = 0; n < entries.size(); ++n) {
    const int cx = pad + static_cast<int>(n % columns) * cell_w;
    const int cy = pad + static_cast<int>(n / columns) * cell_h;
    const std::string name = entries[n]["name"].get<std::string>();
    const Image thumb =
        read_png((out / "entries" / name / entries[n]["thumbnail"].get<std::string>()).string());
    const int ox = cx + (side - thumb.width) / 2, oy = cy + (side - thumb.height) / 2;
    for (int y = 0; y < thumb.height; ++y)
      for (int x = 0; x < thumb.width; ++x) {
        const int sx = ox + x, sy = oy + y;
        if (sx < 0 || sy < 0 || sx >= sheet.width || sy >= sheet.height) continue;
        for (int k = 0; k < 4; ++k)
          sheet.rgba[(size_t(sy) * sheet.width + sx) * 4 + k] =
              thumb.rgba[(size_t(y) * thumb.width + x) * 4 + k];
      }
    // The name, shortened with ".." to the cell's width (stb_easy_font: about 6 units a letter).
    std::string label = name;
    while (label.size() > 3 && stb_easy_font_width(label.data()) * 2 > side - 8)
      label = label.substr(0, label.size() - 3) + "..";
    draw_text(sheet, cx + 4, cy + side + 6, label, 2, 40);
  }
  write_png(file.string(), sheet);
}

// Merges the complete entries of `sources` present in OUT into index.json and the contact sheet,
// and writes the viewer. Returns the number of entries indexed.
size_t write_index(const std::vector<EntrySource>& sources, const LibraryOptions& o,
                   std::ostream& log) {
  std::vector<nlohmann::json> entries;
  std::vector<std::string> missing;
  for (const auto& s : sources) {
    nlohmann::json r = read_entry(o.out, s.name);
    if (r.is_null()) {
      missing.push_back(s.name);
      continue;
    }
    entries.push_back(std::move(r));
  }
  nlohmann::json list = nlohmann::json::array();
  for (const auto& r : entries) {
    const std::string folder = "entries/" + r["name"].get<std::string>();
    nlohmann::json boxes = nlohmann::json::array();
    for (const auto& b : r["boxes"]) boxes.push_back(folder + "/" + b.get<std::string>());
    list.push_back({{"name", r["name"]},
                    {"source", r["source"]},
                    {"input_hash", r["input_hash"]},
                    {"folder", folder},
                    {"mesh", r["mesh"]},
                    {"camera", r["camera"]},
                    {"width", r["width"]},
                    {"height", r["height"]},
                    {"render", r["render"]},
                    {"boxes", boxes},
                    {"shaders", r["shaders"]},
                    {"thumbnail", folder + "/" + r["thumbnail"].get<std::string>()},
                    {"warnings", r["warnings"]}});
  }
  const nlohmann::json index = {{"schema", "raywarp.library"},
                                {"version", kIndexVersion},
                                {"raywarp", kVersion},
                                {"entries", list}};
  fs::create_directories(o.out);
  write_file_atomic((o.out / "index.json").string(), index.dump(2) + "\n");
  write_contact_sheet(o.out / "contact_sheet.png", o.out, entries, o.thumbnail_size);
  write_viewer(o.out / "viewer");
  log << "library: indexed " << entries.size() << " of " << sources.size() << " entries in "
      << (o.out / "index.json").string() << "; contact sheet "
      << (o.out / "contact_sheet.png").string() << "; viewer "
      << (o.out / "viewer" / "index.html").string() << "\n";
  if (!missing.empty()) {
    std::string names;
    for (const auto& m : missing) names += (names.empty() ? "" : ", ") + m;
    log << "library: " << missing.size() << " entries not built yet: " << names << "\n";
  }
  return entries.size();
}

void progress_bar(std::ostream& log, size_t done, size_t total, const std::string& what) {
  const int width = 24;
  const int filled = total ? static_cast<int>(width * done / total) : width;
  log << "library: [" << std::string(filled, '#') << std::string(width - filled, '.') << "] "
      << done << "/" << total << " " << what << "\n"
      << std::flush;
}

}  // namespace

int run_library(const LibraryOptions& o, std::ostream& log) {
  if (o.thumbnail_size < 16 || o.thumbnail_size > 1024)
    throw Error("--thumbnail-size " + std::to_string(o.thumbnail_size) + ": must be in [16, 1024]");
  const std::vector<EntrySource> sources = list_entries(o.input);
  if (!o.entry.empty() && std::none_of(sources.begin(), sources.end(),
                                       [&](const auto& s) { return s.name == o.entry; }))
    throw Error("--entry " + o.entry + ": " + o.input.string() + " has no such entry");

  if (!o.emit_jobs.empty()) {
    const std::string self = fs::canonical("/proc/self/exe").string();
    std::string text;
    for (const auto& s : sources)
      text += shell_quote(self) + " library " + shell_quote(fs::absolute(o.input).string()) +
              " --out " + shell_quote(fs::absolute(o.out).string()) + " --entry " +
              shell_quote(s.name) + option_arguments(o) + "\n";
    write_file_atomic(o.emit_jobs.string(), text);
    log << "library: wrote " << sources.size() << " jobs to " << o.emit_jobs.string()
        << ", one command per line. Run them, e.g. with GNU parallel:\n"
        << "  parallel --halt now,fail=1 < " << o.emit_jobs.string() << "\n"
        << "or as a Slurm array (sbatch --array=1-" << sources.size()
        << "): sed -n \"${SLURM_ARRAY_TASK_ID}p\" " << o.emit_jobs.string() << " | bash\n"
        << "then merge: raywarp library " << o.input.string() << " --out " << o.out.string()
        << " --index-only\n";
    return 0;
  }
  if (o.index_only) {
    write_index(sources, o, log);
    return 0;
  }

  std::unique_ptr<BakeCache> cache;
  if (!o.no_cache) {
    const fs::path dir = o.cache_dir.empty() ? BakeCache::default_dir() : o.cache_dir;
    if (!dir.empty()) cache = std::make_unique<BakeCache>(dir);
  }
  BakeSession session(cache.get());
  std::unique_ptr<gl::Context> context;
  size_t done = 0, built = 0, skipped = 0;
  std::vector<std::string> failed;
  const size_t total = o.entry.empty() ? sources.size() : 1;
  for (const auto& s : sources) {
    if (!o.entry.empty() && s.name != o.entry) continue;
    const auto start = std::chrono::steady_clock::now();
    std::stringstream report;
    try {
      const Scene scene = load_scene_json(s.document, s.path);
      const std::string hash = entry_hash(s, scene, o);
      const nlohmann::json present = read_entry(o.out, s.name);
      if (!o.force && !present.is_null() && present.value("input_hash", "") == hash) {
        ++skipped;
        progress_bar(log, ++done, total, s.name + ": unchanged, skipped");
        continue;
      }
      if (!context) {
        context = gl::create_context(o.context);
        log << "library: context " << context->description() << "\n";
      }
      const nlohmann::json r = build_entry(s, o, session, hash, report);
      ++built;
      const long w = r["warnings"].get<long>();
      progress_bar(log, ++done, total,
                   s.name + ": built in " + fmt("%.1f", seconds_since(start)) + " s" +
                       (w ? ", " + std::to_string(w) + " warnings" : std::string()));
      if (w)
        for (std::string line; std::getline(report, line);)
          if (line.find("warning:") != std::string::npos) log << "  " << line << "\n";
    } catch (const Error& e) {
      // One broken entry does not stop the others; the run fails at the end.
      failed.push_back(s.name);
      progress_bar(log, ++done, total, s.name + ": failed");
      log << "  " << e.what() << "\n";
    }
  }
  log << "library: " << built << " built, " << skipped << " unchanged, " << failed.size()
      << " failed\n";
  if (o.entry.empty()) write_index(sources, o, log);
  if (!failed.empty()) {
    std::string names;
    for (const auto& f : failed) names += (names.empty() ? "" : ", ") + f;
    throw Error("library: " + std::to_string(failed.size()) + " entries failed: " + names);
  }
  return 0;
}

}  // namespace raywarp
