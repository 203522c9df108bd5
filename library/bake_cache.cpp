#include "library/bake_cache.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>

#include "base/atomic_file.h"
#include "base/error.h"

namespace raywarp {

namespace fs = std::filesystem;

namespace {

constexpr char kMagic[] = "RAYWARP-BAKE-CACHE-2\n";
constexpr std::uint64_t kMaxEntryBytes = std::uint64_t(8) << 30;

std::string hex(std::uint64_t h) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

bool is_entry(const fs::path& p) {
  const std::string name = p.filename().string();
  return p.extension() == ".bin" && name.find('-') != std::string::npos;
}

}  // namespace

std::uint64_t fnv1a(const void* data, size_t size, std::uint64_t h) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < size; ++i) {
    h ^= p[i];
    h *= 0x100000001b3ull;
  }
  return h;
}

std::string file_hash(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path.string() + ": cannot read the file to hash it");
  std::uint64_t h = 0xcbf29ce484222325ull;
  std::vector<char> buf(1 << 20);
  while (in) {
    in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    h = fnv1a(buf.data(), static_cast<size_t>(in.gcount()), h);
  }
  return hex(h);
}

const std::string& executable_hash() {
  static const std::string hash = [] {
    try {
      return file_hash("/proc/self/exe");
    } catch (const Error&) {
      return std::string("unknown-executable");
    }
  }();
  return hash;
}

std::string key_number(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%a", x);
  return buf;
}

void CacheWriter::text(const std::string& s) {
  integer(static_cast<std::int64_t>(s.size()));
  raw(s.data(), s.size());
}

void CacheWriter::raw(const void* p, size_t n) {
  const char* c = static_cast<const char*>(p);
  bytes_.insert(bytes_.end(), c, c + n);
}

double CacheReader::number() {
  double x = 0;
  raw(&x, sizeof x);
  return x;
}

std::int64_t CacheReader::integer() {
  std::int64_t x = 0;
  raw(&x, sizeof x);
  return x;
}

std::string CacheReader::text() {
  const std::int64_t n = integer();
  if (!ok_ || n < 0 || static_cast<std::uint64_t>(n) > remaining()) {
    ok_ = false;
    return {};
  }
  std::string s(static_cast<size_t>(n), '\0');
  raw(s.data(), s.size());
  return s;
}

void CacheReader::raw(void* p, size_t n) {
  if (!ok_ || n > remaining()) {
    ok_ = false;
    std::memset(p, 0, n);
    return;
  }
  std::memcpy(p, bytes_.data() + pos_, n);
  pos_ += n;
}

BakeCache::BakeCache(fs::path dir) : dir_(std::move(dir)) {}

fs::path BakeCache::default_dir() {
  if (const char* d = std::getenv("RAYWARP_CACHE_DIR"); d && *d) return d;
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return fs::path(x) / "raywarp";
  if (const char* h = std::getenv("HOME"); h && *h) return fs::path(h) / ".cache" / "raywarp";
  return {};
}

fs::path BakeCache::entry_path(const std::string& kind, const std::string& key) const {
  const std::string full = executable_hash() + "\n" + key;
  return dir_ / (kind + "-" + hex(fnv1a(full.data(), full.size())) + ".bin");
}

std::optional<std::vector<char>> BakeCache::get(const std::string& kind, const std::string& key) {
  const fs::path path = entry_path(kind, key);
  std::ifstream in(path, std::ios::binary);
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  if (!in || ec || size > kMaxEntryBytes) {
    ++misses;
    return std::nullopt;
  }
  std::vector<char> file(size);
  in.read(file.data(), static_cast<std::streamsize>(size));
  // Layout: magic, key (length, bytes), payload (length, bytes), checksum of the payload.
  std::optional<std::vector<char>> payload;
  const size_t magic = sizeof kMagic - 1;
  auto read_u64 = [&](size_t at, std::uint64_t& v) {
    if (at + 8 > file.size()) return false;
    std::memcpy(&v, file.data() + at, 8);
    return true;
  };
  const std::string expected_key = executable_hash() + "\n" + key;
  std::uint64_t key_size = 0, data_size = 0, checksum = 0;
  if (in.gcount() == static_cast<std::streamsize>(size) && file.size() >= magic &&
      std::memcmp(file.data(), kMagic, magic) == 0 && read_u64(magic, key_size) &&
      key_size == expected_key.size() && magic + 8 + key_size <= file.size() &&
      std::memcmp(file.data() + magic + 8, expected_key.data(), key_size) == 0) {
    const size_t data_at = magic + 8 + key_size + 8;
    if (read_u64(data_at - 8, data_size) && data_size <= file.size() &&
        data_at + data_size + 8 == file.size() && read_u64(data_at + data_size, checksum) &&
        checksum == fnv1a(file.data() + data_at, data_size))
      payload.emplace(file.begin() + data_at, file.begin() + data_at + data_size);
  }
  if (!payload) {
    ++misses;
    return std::nullopt;
  }
  ++hits;
  return payload;
}

bool BakeCache::put(const std::string& kind, const std::string& key,
                    const std::vector<char>& payload, std::string* error) {
  try {
    fs::create_directories(dir_);
    CacheWriter w;
    w.text(executable_hash() + "\n" + key);
    w.integer(static_cast<std::int64_t>(payload.size()));
    std::vector<char> file(kMagic, kMagic + sizeof kMagic - 1);
    file.reserve(file.size() + w.bytes().size() + payload.size() + 8);
    file.insert(file.end(), w.bytes().begin(), w.bytes().end());
    file.insert(file.end(), payload.begin(), payload.end());
    const std::uint64_t checksum = fnv1a(payload.data(), payload.size());
    const char* c = reinterpret_cast<const char*>(&checksum);
    file.insert(file.end(), c, c + 8);
    write_file_atomic(entry_path(kind, key).string(), file.data(), file.size());
    ++stores;
    return true;
  } catch (const std::exception& e) {
    if (error) *error = e.what();
    return false;
  }
}

BakeCache::Contents BakeCache::contents(const fs::path& dir) {
  Contents c;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return c;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_regular_file() && is_entry(e.path())) {
      ++c.entries;
      c.bytes += e.file_size();
    }
  return c;
}

long BakeCache::clear(const fs::path& dir) {
  long removed = 0;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return 0;
  std::vector<fs::path> entries;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_regular_file() && is_entry(e.path())) entries.push_back(e.path());
  for (const auto& p : entries)
    if (fs::remove(p, ec)) ++removed;
  if (fs::is_empty(dir, ec)) fs::remove(dir, ec);
  return removed;
}

}  // namespace raywarp
