// An on-disk cache of baked textures, so that a second render of a scene (or one with only a
// new camera or new render settings) bakes nothing.
//
// An entry is found by a key: text that names every input of its bake (the mesh file's bytes by
// their hash, the box, the deformer's parameters, resolutions), plus the hash of the running
// executable, so a rebuilt raywarp never reads an entry an older bake algorithm wrote. The entry
// file DIR/KIND-HASH.bin holds the key itself, the payload and its checksum; a key that differs
// (a hash collision), a short or corrupt file, or a payload larger than the memory budget is a
// miss, never an error. Entries are written to a temporary file and renamed, so a killed run
// leaves no half-written entry. The cache is never trimmed: `raywarp cache --clear` empties it.
#pragma once
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "base/grid.h"

namespace raywarp {

// FNV-1a, 64 bits, of `size` bytes (continuing from `h`).
std::uint64_t fnv1a(const void* data, size_t size, std::uint64_t h = 0xcbf29ce484222325ull);
// The hash of a file's bytes, as 16 hex digits; throws Error naming the file when unreadable.
std::string file_hash(const std::filesystem::path& path);
// The hash of the running executable (/proc/self/exe), computed once.
const std::string& executable_hash();
// Exact text of a number (hex float), for keys.
std::string key_number(double x);

// A byte buffer the pipeline writes its baked structs into, and reads them back from.
class CacheWriter {
 public:
  void number(double x) { raw(&x, sizeof x); }
  void integer(std::int64_t x) { raw(&x, sizeof x); }
  void text(const std::string& s);
  template <class T>
  void grid(const Grid3<T>& g) {
    for (int a = 0; a < 3; ++a) number(g.origin[a]);
    for (int a = 0; a < 3; ++a) number(g.spacing[a]);
    for (int a = 0; a < 3; ++a) integer(g.dims[a]);
    raw(g.data.data(), g.data.size() * sizeof(T));
  }
  const std::vector<char>& bytes() const { return bytes_; }

 private:
  void raw(const void* p, size_t n);
  std::vector<char> bytes_;
};

// Reads what CacheWriter wrote; every read checks the remaining size and sets !ok() instead of
// reading past the end.
class CacheReader {
 public:
  explicit CacheReader(const std::vector<char>& bytes) : bytes_(bytes) {}
  double number();
  std::int64_t integer();
  std::string text();
  template <class T>
  bool grid(Grid3<T>& g, std::uint64_t max_bytes) {
    Eigen::Vector3d origin;
    for (int a = 0; a < 3; ++a) origin[a] = number();
    Eigen::Vector3d spacing;
    for (int a = 0; a < 3; ++a) spacing[a] = number();
    Eigen::Vector3i dims;
    std::uint64_t count = 1;
    for (int a = 0; a < 3; ++a) {
      const std::int64_t d = integer();
      if (!ok_ || d < 1 || d > (1 << 20)) return ok_ = false;
      dims[a] = static_cast<int>(d);
      count *= static_cast<std::uint64_t>(d);
    }
    if (count * sizeof(T) > max_bytes || count * sizeof(T) > remaining()) return ok_ = false;
    T zero;
    std::memset(static_cast<void*>(&zero), 0, sizeof zero);
    g = Grid3<T>(origin, spacing, dims, zero);
    raw(g.data.data(), count * sizeof(T));
    return ok_;
  }
  bool ok() const { return ok_; }
  bool at_end() const { return pos_ == bytes_.size(); }

 private:
  size_t remaining() const { return bytes_.size() - pos_; }
  void raw(void* p, size_t n);
  const std::vector<char>& bytes_;
  size_t pos_ = 0;
  bool ok_ = true;
};

class BakeCache {
 public:
  // Entries live in `dir`, created at the first store.
  explicit BakeCache(std::filesystem::path dir);
  // $RAYWARP_CACHE_DIR, else $XDG_CACHE_HOME/raywarp, else $HOME/.cache/raywarp; empty when none
  // of them is set.
  static std::filesystem::path default_dir();
  const std::filesystem::path& dir() const { return dir_; }

  // The payload stored under (kind, key), or nothing.
  std::optional<std::vector<char>> get(const std::string& kind, const std::string& key);
  // Stores a payload; returns false (and says why in `error`) when it cannot be written.
  bool put(const std::string& kind, const std::string& key, const std::vector<char>& payload,
           std::string* error = nullptr);

  // The entry files in `dir` and their total size.
  struct Contents {
    long entries = 0;
    std::uint64_t bytes = 0;
  };
  static Contents contents(const std::filesystem::path& dir);
  // Removes the entry files (and the folder when it is left empty); returns how many.
  static long clear(const std::filesystem::path& dir);

  long hits = 0, misses = 0, stores = 0;

 private:
  std::filesystem::path entry_path(const std::string& kind, const std::string& key) const;
  std::filesystem::path dir_;
};

}  // namespace raywarp
