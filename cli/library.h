// `raywarp library`: a library of deformation textures built from a folder of scene files (or a
// JSON file of deformer presets on one mesh), each entry exported (cli/export.h) with its
// shaders and a thumbnail, an index (JSON), a contact sheet and the browser viewer beside it.
//
// Layout of OUT (docs/export.md#libraries):
//   index.json                 every complete entry, in the input's order
//   contact_sheet.png          one thumbnail per entry, named
//   viewer/                    the static WebGL2 viewer (reads ../index.json)
//   meshes/HASH.bin            each mesh the entries use, once (write_mesh_bin)
//   entries/NAME/              entry.json, the sidecars and textures, the shaders, thumbnail.png
// An entry is built in entries/.NAME.tmp-PID and renamed into place whole, so a job killed or
// failing mid-way leaves the previous entry (or none), never a mixture. An entry whose
// input_hash (the scene's document, the mesh's bytes, the export options, raywarp's version) is
// unchanged is skipped. Entries are independent jobs: `--emit-jobs FILE` writes one command per
// entry for GNU parallel or a Slurm job array, and `--index-only` merges what is there.
#pragma once
#include <filesystem>
#include <iosfwd>
#include <string>

#include "library/export.h"

namespace raywarp {

struct LibraryOptions {
  std::filesystem::path input;  // a folder of scene files, or a presets file (JSON)
  std::filesystem::path out = "out/library";
  ExportOptions export_options;
  std::string context = "auto";  // OpenGL context of the thumbnails
  int thumbnail_size = 192;
  std::string entry;                // build only this entry (what an emitted job runs); no index
  std::filesystem::path emit_jobs;  // write the jobs' commands here instead of building
  bool index_only = false;          // merge the entries present into the index and sheet
  bool force = false;               // rebuild entries whose input hash is unchanged
  std::filesystem::path cache_dir;  // bake cache (empty: the default folder)
  bool no_cache = false;
};

// Runs the command; progress and each entry's outcome on `log`. Returns the exit status.
int run_library(const LibraryOptions& options, std::ostream& log);

}  // namespace raywarp
