// Mesh files read whole and checked before assimp parses them (see mesh_file.h).
#include "library/mesh_file.h"

#include <lzma.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string_view>
#include <vector>

#include "base/error.h"

namespace raywarp {
namespace {

[[noreturn]] void fail(const std::string& path, const std::string& message) {
  throw Error(path + ": cannot read mesh: " + message);
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string number_text(double x) {
  std::ostringstream s;
  s.precision(9);
  s << x;
  return s.str();
}

// A coordinate the renderer can hold: finite, and within float range (textures and vertex
// buffers are float).
void check_coordinate(double x, const std::string& path, const std::string& where, char axis) {
  if (std::isfinite(x) && std::fabs(x) <= FLT_MAX) return;
  fail(path, where + " has " + axis + " = " + number_text(x) +
                 ": coordinates must be finite numbers within float range (|x| <= 3.4e38)");
}

bool parse_double(std::string_view token, double& out) {
  if (token.empty() || token.size() > 64) return false;
  char buffer[65];
  std::memcpy(buffer, token.data(), token.size());
  buffer[token.size()] = '\0';
  char* end = nullptr;
  errno = 0;
  out = std::strtod(buffer, &end);
  return end == buffer + token.size();  // overflow gives +-HUGE_VAL: caught as not finite
}

bool parse_integer(std::string_view token, long long& out) {
  if (token.empty() || token.size() > 24) return false;
  char buffer[25];
  std::memcpy(buffer, token.data(), token.size());
  buffer[token.size()] = '\0';
  char* end = nullptr;
  errno = 0;
  out = std::strtoll(buffer, &end, 10);
  return end == buffer + token.size() && errno == 0;
}

// Whitespace-separated tokens of a text, with the line each starts on.
class Tokens {
 public:
  Tokens(std::string_view text, size_t start, size_t line)
      : text_(text), pos_(start), line_(line) {}
  bool next(std::string_view& token) {
    while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) {
      if (text_[pos_] == '\n') ++line_;
      ++pos_;
    }
    if (pos_ >= text_.size()) return false;
    const size_t begin = pos_;
    while (pos_ < text_.size() && !std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
    token = text_.substr(begin, pos_ - begin);
    return true;
  }
  size_t line() const { return line_; }
  size_t remaining() const { return text_.size() - std::min(pos_, text_.size()); }

 private:
  std::string_view text_;
  size_t pos_;
  size_t line_;
};

// --- PLY -------------------------------------------------------------------------------------

struct PlyType {
  int size = 0;
  char kind = 0;  // 'i' signed, 'u' unsigned, 'f' floating point
};

bool ply_type(const std::string& name, PlyType& t) {
  static const struct {
    const char* name;
    int size;
    char kind;
  } kTypes[] = {{"char", 1, 'i'},  {"int8", 1, 'i'},    {"uchar", 1, 'u'},  {"uint8", 1, 'u'},
                {"short", 2, 'i'}, {"int16", 2, 'i'},   {"ushort", 2, 'u'}, {"uint16", 2, 'u'},
                {"int", 4, 'i'},   {"int32", 4, 'i'},   {"uint", 4, 'u'},   {"uint32", 4, 'u'},
                {"float", 4, 'f'}, {"float32", 4, 'f'}, {"double", 8, 'f'}, {"float64", 8, 'f'}};
  for (const auto& k : kTypes)
    if (name == k.name) {
      t = {k.size, k.kind};
      return true;
    }
  return false;
}

struct PlyProperty {
  std::string name;
  bool list = false;
  PlyType count;  // list only
  PlyType value;
};

struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

enum class PlyFormat { Ascii, LittleEndian, BigEndian };

template <typename T>
double load_as(const unsigned char* b) {
  T v;
  std::memcpy(&v, b, sizeof v);
  return static_cast<double>(v);
}

double read_binary(const std::string& bytes, size_t at, const PlyType& t, bool little) {
  unsigned char b[8];
  std::memcpy(b, bytes.data() + at, static_cast<size_t>(t.size));
  if (!little) std::reverse(b, b + t.size);
  switch (t.kind) {
    case 'i':
      return t.size == 1   ? load_as<int8_t>(b)
             : t.size == 2 ? load_as<int16_t>(b)
                           : load_as<int32_t>(b);
    case 'u':
      return t.size == 1   ? load_as<uint8_t>(b)
             : t.size == 2 ? load_as<uint16_t>(b)
                           : load_as<uint32_t>(b);
    default:
      return t.size == 4 ? load_as<float>(b) : load_as<double>(b);
  }
}

void walk_ply(const std::string& bytes, const std::string& path, PolygonSoup* soup) {
  // Header: lines up to end_header.
  size_t pos = 0, line_no = 0;
  auto next_line = [&](std::string& line) {
    if (pos >= bytes.size()) return false;
    size_t end = bytes.find('\n', pos);
    if (end == std::string::npos) end = bytes.size();
    line.assign(bytes, pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = std::min(end + 1, bytes.size() + 1);
    ++line_no;
    return true;
  };
  std::string line;
  if (!next_line(line) || line != "ply") fail(path, "not a PLY file (it must start with \"ply\")");
  PlyFormat format = PlyFormat::Ascii;
  bool have_format = false, ended = false;
  std::vector<PlyElement> elements;
  while (next_line(line)) {
    for (char ch : line)
      if (static_cast<unsigned char>(ch) < 32 && ch != '\t')
        fail(path, "PLY header line " + std::to_string(line_no + 0) +
                       " holds a control character (" + std::to_string(int(ch)) +
                       "): a header is lines of text");
    std::istringstream words(line);
    std::string word;
    words >> word;
    const std::string where = "PLY header line " + std::to_string(line_no);
    if (word.empty() || word == "comment" || word == "obj_info") continue;
    if (word == "end_header") {
      if (line.find_last_not_of(" \t") + 1 != std::string("end_header").size() ||
          line.rfind("end_header", 0) != 0)
        fail(path, "PLY header line " + std::to_string(line_no) + ": \"" + line.substr(0, 40) +
                       "\": the header must end with a line end_header");
      ended = true;
      break;
    }
    if (word == "format") {
      std::string f;
      words >> f;
      if (f == "ascii")
        format = PlyFormat::Ascii;
      else if (f == "binary_little_endian")
        format = PlyFormat::LittleEndian;
      else if (f == "binary_big_endian")
        format = PlyFormat::BigEndian;
      else
        fail(path,
             where + ": format " + f + ": allowed ascii, binary_little_endian, binary_big_endian");
      have_format = true;
    } else if (word == "element") {
      PlyElement e;
      std::string count;
      words >> e.name >> count;
      long long n = -1;
      if (e.name.empty() || !parse_integer(count, n) || n < 0)
        fail(path, where + ": \"" + line + "\": an element needs a name and a count >= 0");
      e.count = static_cast<uint64_t>(n);
      elements.push_back(e);
    } else if (word == "property") {
      if (elements.empty()) fail(path, where + ": a property before any element");
      PlyProperty p;
      std::string type;
      words >> type;
      if (type == "list") {
        std::string count_type, value_type;
        words >> count_type >> value_type >> p.name;
        p.list = true;
        if (!ply_type(count_type, p.count) || p.count.kind == 'f' || !ply_type(value_type, p.value))
          fail(path,
               where + ": \"" + line + "\": a list needs an integer count type and a value type");
      } else {
        words >> p.name;
        if (!ply_type(type, p.value)) fail(path, where + ": unknown property type " + type);
      }
      if (p.name.empty()) fail(path, where + ": a property needs a name");
      elements.back().properties.push_back(p);
    } else {
      fail(path, where + ": unknown keyword " + word);
    }
  }
  if (!ended) fail(path, "the PLY header has no end_header line");
  if (!have_format) fail(path, "the PLY header has no format line");

  uint64_t vertex_count = 0;
  bool have_vertices = false;
  for (const PlyElement& e : elements) {
    if (e.name != "vertex") continue;
    have_vertices = true;
    vertex_count = e.count;
    for (const char* axis : {"x", "y", "z"}) {
      bool found = false;
      for (const PlyProperty& p : e.properties) found = found || (p.name == axis && !p.list);
      if (!found) fail(path, std::string("the PLY element vertex has no property ") + axis);
    }
  }
  if (!have_vertices) fail(path, "the PLY header declares no vertex element");

  const size_t body = std::min(pos, bytes.size());
  const bool binary = format != PlyFormat::Ascii;
  const bool little = format == PlyFormat::LittleEndian;
  Tokens tokens(bytes, body, line_no + 1);
  size_t at = body;  // binary cursor

  for (const PlyElement& e : elements) {
    if (e.properties.empty() || e.count == 0) continue;
    // Each row holds at least its scalars and list counts: refuse a count the file cannot hold
    // before walking it.
    uint64_t least = 0;
    for (const PlyProperty& p : e.properties)
      least += binary ? static_cast<uint64_t>(p.list ? p.count.size : p.value.size) : 2;
    const uint64_t left = binary ? bytes.size() - at : tokens.remaining() + 1;
    if (e.count > left / least) {
      fail(path, "the PLY header declares " + std::to_string(e.count) + " " + e.name +
                     " elements of at least " + std::to_string(least) + " bytes each, but " +
                     std::to_string(left) + " bytes are left in the file: it is cut short or " +
                     "its header is wrong");
    }
    const bool is_vertex = e.name == "vertex", is_face = e.name == "face";
    if (soup && is_vertex) soup->vertices.reserve(static_cast<size_t>(e.count));
    for (uint64_t row = 0; row < e.count; ++row) {
      std::array<double, 3> xyz = {0, 0, 0};
      auto where = [&] {
        return std::string("PLY ") + e.name + " " + std::to_string(row) +
               (binary ? "" : " (line " + std::to_string(tokens.line()) + ")");
      };
      auto value = [&](const PlyType& t, const std::string& what) -> double {
        if (binary) {
          if (bytes.size() - at < static_cast<size_t>(t.size))
            fail(path, where() + ": the file ends inside its " + what + " (the header declares " +
                           std::to_string(e.count) + " " + e.name + " elements): it is cut short");
          const double v = read_binary(bytes, at, t, little);
          at += static_cast<size_t>(t.size);
          return v;
        }
        std::string_view token;
        if (!tokens.next(token))
          fail(path, where() + ": the file ends before its " + what + " (the header declares " +
                         std::to_string(e.count) + " " + e.name + " elements): it is cut short");
        double v = 0;
        if (!parse_double(token, v))
          fail(path, where() + ": " + what + " = \"" + std::string(token.substr(0, 32)) +
                         "\": not a number");
        if (t.kind != 'f' && v != std::floor(v))
          fail(path, where() + ": " + what + " = " + number_text(v) + ": must be an integer");
        return v;
      };
      for (const PlyProperty& p : e.properties) {
        if (!p.list) {
          const double v = value(p.value, "property " + p.name);
          if (is_vertex && p.name.size() == 1 && (p.name[0] >= 'x' && p.name[0] <= 'z')) {
            check_coordinate(v, path, "PLY vertex " + std::to_string(row), p.name[0]);
            xyz[static_cast<size_t>(p.name[0] - 'x')] = v;
          }
          continue;
        }
        const double n = value(p.count, "list " + p.name + "'s count");
        if (n < 0) fail(path, where() + ": list " + p.name + " has " + number_text(n) + " entries");
        const bool indices = is_face && (p.name == "vertex_indices" || p.name == "vertex_index");
        for (double k = 0; k < n; ++k) {
          const double v = value(p.value, "list " + p.name);
          if (indices && !(v >= 0 && v < static_cast<double>(vertex_count) && v == std::floor(v)))
            fail(path, where() + " uses vertex " + number_text(v) + ", allowed [0, " +
                           std::to_string(vertex_count) + ")");
          if (indices && soup) soup->corners.push_back(static_cast<int>(v));
        }
        if (indices && soup) soup->sizes.push_back(static_cast<int>(n));
      }
      if (soup && is_vertex) soup->vertices.push_back(xyz);
    }
  }
}

// --- OBJ -------------------------------------------------------------------------------------

void check_obj(const std::string& bytes, const std::string& path) {
  long long vertices = 0, largest = 0;
  size_t largest_line = 0, line_no = 0, pos = 0;
  while (pos < bytes.size()) {
    size_t end = bytes.find('\n', pos);
    if (end == std::string::npos) end = bytes.size();
    const std::string_view line(bytes.data() + pos, end - pos);
    pos = end + 1;
    ++line_no;
    Tokens tokens(line, 0, line_no);
    std::string_view word;
    if (!tokens.next(word)) continue;
    const std::string where = "OBJ line " + std::to_string(line_no);
    if (word == "v") {
      const std::string vertex =
          "OBJ vertex " + std::to_string(vertices + 1) + " (line " + std::to_string(line_no) + ")";
      for (char axis : {'x', 'y', 'z'}) {
        std::string_view token;
        double x = 0;
        if (!tokens.next(token)) fail(path, vertex + ": needs x, y and z");
        if (!parse_double(token, x))
          fail(path, vertex + ": " + axis + " = \"" + std::string(token.substr(0, 32)) +
                         "\": not a number");
        check_coordinate(x, path, vertex, axis);
      }
      ++vertices;
    } else if (word == "f") {
      std::string_view token;
      while (tokens.next(token)) {
        const std::string_view index = token.substr(0, token.find('/'));
        long long i = 0;
        if (!parse_integer(index, i) || i == 0)
          fail(path, where + ": face corner \"" + std::string(token.substr(0, 32)) +
                         "\": the vertex index must be a non-zero integer (1-based, or negative "
                         "for relative)");
        if (i < 0 && -i > vertices)
          fail(path, where + ": face corner " + std::to_string(i) +
                         " points before the first vertex (" + std::to_string(vertices) +
                         " vertices so far)");
        if (i > largest) {
          largest = i;
          largest_line = line_no;
        }
      }
    }
  }
  if (largest > vertices)
    fail(path, "OBJ line " + std::to_string(largest_line) + ": a face uses vertex " +
                   std::to_string(largest) + ", but the file has " + std::to_string(vertices) +
                   " vertices");
}

// --- STL -------------------------------------------------------------------------------------

void check_stl(const std::string& bytes, const std::string& path) {
  uint32_t facets = 0;
  if (bytes.size() >= 84) std::memcpy(&facets, bytes.data() + 80, 4);
  const bool binary_size = bytes.size() >= 84 && bytes.size() - 84 == uint64_t(facets) * 50;
  if (!binary_size && bytes.compare(0, 5, "solid") == 0) {
    // ASCII: every "vertex x y z".
    Tokens tokens(bytes, 0, 1);
    std::string_view word;
    long long vertex = 0;
    while (tokens.next(word)) {
      if (word != "vertex") continue;
      const std::string where =
          "STL vertex " + std::to_string(vertex) + " (line " + std::to_string(tokens.line()) + ")";
      for (char axis : {'x', 'y', 'z'}) {
        std::string_view token;
        double x = 0;
        if (!tokens.next(token) || !parse_double(token, x))
          fail(path, where + ": needs three numbers");
        check_coordinate(x, path, where, axis);
      }
      ++vertex;
    }
    return;
  }
  if (bytes.size() < 84)
    fail(path,
         "a binary STL needs at least 84 bytes; the file has " + std::to_string(bytes.size()));
  if (bytes.size() - 84 < uint64_t(facets) * 50)
    fail(path, "the binary STL header declares " + std::to_string(facets) + " facets (" +
                   std::to_string(84 + uint64_t(facets) * 50) + " bytes), but the file has " +
                   std::to_string(bytes.size()) + " bytes: it is cut short");
  for (uint32_t f = 0; f < facets; ++f)
    for (int c = 0; c < 3; ++c)
      for (int a = 0; a < 3; ++a) {
        float x;
        std::memcpy(&x, bytes.data() + 84 + size_t(f) * 50 + 12 + size_t(c) * 12 + size_t(a) * 4,
                    4);
        check_coordinate(x, path, "STL facet " + std::to_string(f) + " corner " + std::to_string(c),
                         static_cast<char>('x' + a));
      }
}

// --- OFF -------------------------------------------------------------------------------------

void check_off(const std::string& bytes, const std::string& path) {
  // Lines without comments; the header "OFF" (or COFF, NOFF, ...) is optional.
  size_t pos = 0, line_no = 0;
  auto next_line = [&](std::string_view& line) {
    while (pos < bytes.size()) {
      size_t end = bytes.find('\n', pos);
      if (end == std::string::npos) end = bytes.size();
      line = std::string_view(bytes.data() + pos, end - pos);
      pos = end + 1;
      ++line_no;
      line = line.substr(0, line.find('#'));
      if (line.find_first_not_of(" \t\r") != std::string_view::npos) return true;
    }
    return false;
  };
  std::string_view line;
  if (!next_line(line)) fail(path, "the OFF file is empty");
  Tokens header(line, 0, line_no);
  std::string_view word;
  header.next(word);
  if (word.size() >= 3 && word.substr(word.size() - 3) == "OFF") {
    if (!header.next(word)) {
      if (!next_line(line)) fail(path, "the OFF file has no vertex and face counts");
      header = Tokens(line, 0, line_no);
      header.next(word);
    }
  }
  long long nv = -1, nf = -1;
  std::string_view second;
  if (!parse_integer(word, nv) || !header.next(second) || !parse_integer(second, nf) || nv < 0 ||
      nf < 0)
    fail(path, "OFF line " + std::to_string(line_no) + ": needs the vertex and face counts (>= 0)");
  if (static_cast<uint64_t>(nv) + static_cast<uint64_t>(nf) > bytes.size())
    fail(path, "the OFF header declares " + std::to_string(nv) + " vertices and " +
                   std::to_string(nf) + " faces, more lines than the file's " +
                   std::to_string(bytes.size()) +
                   " bytes hold: it is cut short or its header is wrong");
  for (long long v = 0; v < nv; ++v) {
    if (!next_line(line))
      fail(path, "the file ends at OFF vertex " + std::to_string(v) + " of " + std::to_string(nv) +
                     ": it is cut short");
    Tokens t(line, 0, line_no);
    const std::string where =
        "OFF vertex " + std::to_string(v) + " (line " + std::to_string(line_no) + ")";
    for (char axis : {'x', 'y', 'z'}) {
      std::string_view token;
      double x = 0;
      if (!t.next(token) || !parse_double(token, x)) fail(path, where + ": needs three numbers");
      check_coordinate(x, path, where, axis);
    }
  }
  for (long long f = 0; f < nf; ++f) {
    if (!next_line(line))
      fail(path, "the file ends at OFF face " + std::to_string(f) + " of " + std::to_string(nf) +
                     ": it is cut short");
    Tokens t(line, 0, line_no);
    const std::string where =
        "OFF face " + std::to_string(f) + " (line " + std::to_string(line_no) + ")";
    std::string_view token;
    long long n = 0;
    if (!t.next(token) || !parse_integer(token, n) || n < 0)
      fail(path, where + ": needs a corner count");
    for (long long k = 0; k < n; ++k) {
      long long i = -1;
      if (!t.next(token) || !parse_integer(token, i))
        fail(path, where + ": needs " + std::to_string(n) + " vertex indices");
      if (i < 0 || i >= nv)
        fail(path, where + " uses vertex " + std::to_string(i) + ", allowed [0, " +
                       std::to_string(nv) + ")");
    }
  }
}

std::string decompress_xz(const std::string& packed, const std::string& path) {
  lzma_stream stream = LZMA_STREAM_INIT;
  if (lzma_stream_decoder(&stream, UINT64_MAX, LZMA_CONCATENATED) != LZMA_OK)
    fail(path, "cannot start the xz decoder");
  std::string out;
  std::vector<uint8_t> chunk(1 << 20);
  stream.next_in = reinterpret_cast<const uint8_t*>(packed.data());
  stream.avail_in = packed.size();
  lzma_ret ret = LZMA_OK;
  while (ret == LZMA_OK) {
    stream.next_out = chunk.data();
    stream.avail_out = chunk.size();
    ret = lzma_code(&stream, LZMA_FINISH);
    const size_t produced = chunk.size() - stream.avail_out;
    if (out.size() + produced > kMaxMeshFileBytes) {
      lzma_end(&stream);
      fail(path, "decompressed, it is larger than " + std::to_string(kMaxMeshFileBytes >> 20) +
                     " MiB, the most raywarp reads");
    }
    out.append(reinterpret_cast<const char*>(chunk.data()), produced);
  }
  lzma_end(&stream);
  if (ret != LZMA_STREAM_END)
    fail(path, "not a valid xz file (lzma error " + std::to_string(ret) + ")");
  return out;
}

}  // namespace

MeshFileBytes read_mesh_file(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) fail(path, "no such file");
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) fail(path, "cannot read its size: " + ec.message());
  if (size > kMaxMeshFileBytes)
    fail(path, std::to_string(size >> 20) + " MiB: larger than " +
                   std::to_string(kMaxMeshFileBytes >> 20) + " MiB, the most raywarp reads");
  std::ifstream in(path, std::ios::binary);
  MeshFileBytes file;
  file.bytes.resize(size);
  if (!in.read(file.bytes.data(), static_cast<std::streamsize>(size)))
    fail(path, "cannot read the file");
  std::filesystem::path name(path);
  file.format = lower(name.extension().string());
  if (file.format == ".xz") {
    file.bytes = decompress_xz(file.bytes, path);
    file.format = lower(name.stem().extension().string());
  }
  if (!file.format.empty()) file.format.erase(0, 1);
  return file;
}

PolygonSoup read_ply(const std::string& bytes, const std::string& path) {
  PolygonSoup soup;
  walk_ply(bytes, path, &soup);
  return soup;
}

bool mesh_format_is_checked(const std::string& format) {
  return format == "ply" || format == "obj" || format == "stl" || format == "off";
}

void check_mesh_bytes(const std::string& bytes, const std::string& format,
                      const std::string& path) {
  if (format == "ply")
    walk_ply(bytes, path, nullptr);
  else if (format == "obj")
    check_obj(bytes, path);
  else if (format == "stl")
    check_stl(bytes, path);
  else if (format == "off")
    check_off(bytes, path);
}

}  // namespace raywarp
