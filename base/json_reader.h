// Reading validated values out of JSON documents (scene files, deformer parameters): every error
// names the file, the field (a path such as boxes[0].deformer.angle_deg), the value and what is
// allowed, and throws Error.
#pragma once
#include <Eigen/Core>
#include <filesystem>
#include <initializer_list>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "base/error.h"

namespace raywarp {

// Integers as integers, anything else in the shortest form that reads back exactly.
std::string format_number(double x);
// A value as the user wrote it, shortened so that a message stays one line.
std::string show(const nlohmann::json& v);
// "a.b" from "a" and "b" ("b" when a is empty); "a[i]".
std::string child(const std::string& field, const std::string& key);
std::string element(const std::string& field, size_t i);

// How deeply arrays and objects may nest in a document raywarp reads (a scene needs 4 levels).
constexpr size_t kMaxJsonDepth = 64;

// Parses a JSON document without recursion, nesting at most kMaxJsonDepth levels. A syntax error
// names `file`, the line and column, and the field being read; a number beyond double range names
// its field ("boxes[0].deformer.angle_deg = 1e999: ..."). Throws Error.
nlohmann::json parse_json(const std::string& text, const std::string& file);
// parse_json of a file's contents; `what` names the kind of file in messages ("scene file").
nlohmann::json read_json_file(const std::filesystem::path& path, const std::string& what);

// An interval of allowed numbers; infinite bounds mean "any finite number" on that side.
struct Interval {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false, hi_open = false;
  bool hi_is_sanity_limit = false;  // hi only refuses absurd values: say "> lo" first

  bool contains(double x) const {
    return std::isfinite(x) && (lo_open ? x > lo : x >= lo) && (hi_open ? x < hi : x <= hi);
  }
  // `kind` with its article: "a number", "an integer".
  std::string describe(const std::string& kind) const {
    bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
    if (!has_lo && !has_hi) return "must be " + kind + "; any finite value";
    if (hi_is_sanity_limit)
      return std::string("must be ") + (lo_open ? "> " : ">= ") + format_number(lo) +
             " (and at most " + format_number(hi) + ")";
    if (!has_hi) return std::string("must be ") + (lo_open ? "> " : ">= ") + format_number(lo);
    if (!has_lo) return std::string("must be ") + (hi_open ? "< " : "<= ") + format_number(hi);
    return "must be " + kind + " in " + (lo_open ? "(" : "[") + format_number(lo) + ", " +
           format_number(hi) + (hi_open ? ")" : "]");
  }
};

inline Interval closed(double lo, double hi) { return {lo, hi, false, false}; }

// Reads and validates one scene document; every error names the scene file, the field (a path
// such as boxes[0].deformer.type), the value and what is allowed.
class JsonReader {
 public:
  explicit JsonReader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const std::string& field, const nlohmann::json& value,
                         const std::string& allowed) const {
    throw Error(file_ + ": " + field + " = " + show(value) + ": " + allowed);
  }
  [[noreturn]] void missing(const std::string& field, const std::string& hint) const {
    throw Error(file_ + ": " + field + ": missing; " + hint);
  }

  void require_object(const nlohmann::json& j, const std::string& field,
                      const std::string& hint) const {
    if (!j.is_object()) fail(field, j, "must be a JSON object like " + hint);
  }

  // Unknown keys are errors (they are usually typos) that list the allowed keys.
  void check_keys(const nlohmann::json& j, const std::string& field,
                  std::initializer_list<const char*> allowed) const {
    for (const auto& [key, value] : j.items()) {
      bool known = false;
      for (const char* k : allowed) known = known || key == k;
      if (known) continue;
      std::string list;
      for (const char* k : allowed) list += (list.empty() ? "" : ", ") + std::string(k);
      fail(child(field, key), value, "unknown field; allowed: " + list);
    }
  }

  const nlohmann::json& required(const nlohmann::json& j, const std::string& field, const char* key,
                                 const std::string& hint) const {
    if (!j.contains(key)) missing(child(field, key), hint);
    return j[key];
  }

  double number(const nlohmann::json& v, const std::string& field, const Interval& allowed) const {
    double x = v.is_number() ? v.get<double>() : std::numeric_limits<double>::quiet_NaN();
    if (!allowed.contains(x)) fail(field, v, allowed.describe("a number"));
    return x;
  }

  int integer(const nlohmann::json& v, const std::string& field, int lo, int hi) const {
    // Compared as double: exact for every integer in range, and huge or unsigned values
    // cannot wrap around into the range.
    Interval allowed = closed(lo, hi);
    if (!v.is_number_integer() || !allowed.contains(v.get<double>()))
      fail(field, v, allowed.describe("an integer"));
    return v.get<int>();
  }

  Eigen::Vector3d vec3(const nlohmann::json& v, const std::string& field,
                       const Interval& allowed) const {
    if (!v.is_array() || v.size() != 3) fail(field, v, "must be an array of 3 numbers");
    Eigen::Vector3d out;
    for (int i = 0; i < 3; ++i) out[i] = number(v[i], element(field, i), allowed);
    return out;
  }

  std::string one_of(const nlohmann::json& v, const std::string& field,
                     std::initializer_list<const char*> allowed,
                     const std::string& note = "") const {
    std::string list;
    for (const char* k : allowed) {
      if (v.is_string() && v.get<std::string>() == k) return k;
      list += (list.empty() ? "" : ", ") + std::string(k);
    }
    fail(field, v, "must be one of " + list + note);
  }
  std::string one_of(const nlohmann::json& v, const std::string& field,
                     const std::vector<std::string>& allowed, const std::string& note = "") const {
    std::string list;
    for (const std::string& k : allowed) {
      if (v.is_string() && v.get<std::string>() == k) return k;
      list += (list.empty() ? "" : ", ") + k;
    }
    fail(field, v, "must be one of " + list + note);
  }

  // An existing file named relative to the scene file's folder.
  // `folder_ok`: a folder is accepted too.
  std::filesystem::path existing_file(const nlohmann::json& v, const std::string& field,
                                      const std::filesystem::path& folder,
                                      bool folder_ok = false) const {
    if (!v.is_string() || v.get<std::string>().empty())
      fail(field, v, "must be a path (string) relative to the scene file");
    std::filesystem::path resolved = (folder / v.get<std::string>()).lexically_normal();
    std::error_code ec;
    if (!std::filesystem::exists(resolved, ec))
      fail(field, v, "no such file: " + resolved.string());
    if (folder_ok && std::filesystem::is_directory(resolved, ec)) return resolved;
    if (!std::filesystem::is_regular_file(resolved, ec))
      fail(field, v,
           std::string(folder_ok ? "neither a regular file nor a folder: "
                                 : "not a regular file: ") +
               resolved.string());
    return resolved;
  }

  const std::string& file() const { return file_; }

 private:
  std::string file_;
};

}  // namespace raywarp
