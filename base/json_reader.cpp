#include "base/json_reader.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

namespace raywarp {

using json = nlohmann::json;

// Integers as integers, anything else in the shortest form that reads back exactly.
std::string format_number(double x) {
  char buf[32];
  if (x == std::round(x) && std::abs(x) < 1e7) {
    std::snprintf(buf, sizeof buf, "%.0f", x);
    return buf;
  }
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, x);
    if (std::strtod(buf, nullptr) == x) break;
  }
  return buf;
}

// A value as the user wrote it, shortened so that a message stays one line.
std::string show(const json& v) {
  std::string s = v.dump(-1, ' ', false, json::error_handler_t::replace);
  if (s.size() > 80) s = s.substr(0, 77) + "...";
  return s;
}

std::string child(const std::string& field, const std::string& key) {
  return field.empty() ? key : field + "." + key;
}

std::string element(const std::string& field, size_t i) {
  return field + "[" + std::to_string(i) + "]";
}

namespace {

// Builds the document from nlohmann's SAX events (its SAX parser keeps an explicit stack, so no
// input depth reaches the C++ stack), knowing at each event the field being read.
class PathSax {
 public:
  explicit PathSax(json& root) : root_(root) {}

  bool null() { return put(nullptr); }
  bool boolean(bool b) { return put(b); }
  bool number_integer(json::number_integer_t v) { return put(v); }
  bool number_unsigned(json::number_unsigned_t v) { return put(v); }
  bool number_float(json::number_float_t v, const json::string_t&) { return put(v); }
  bool string(json::string_t& v) { return put(std::move(v)); }
  bool binary(json::binary_t& v) { return put(json::binary(std::move(v))); }
  bool start_object(std::size_t) { return open(json::object()); }
  bool start_array(std::size_t) { return open(json::array()); }
  bool key(json::string_t& k) {
    key_ = k;
    have_key_ = true;
    return true;
  }
  bool end_object() { return close(); }
  bool end_array() { return close(); }
  bool parse_error(std::size_t position, const std::string& token,
                   const nlohmann::detail::exception& e) {
    error_position = position;
    error_token = token;
    error_id = e.id;
    error_message = e.what();
    return false;
  }

  // The field the next value lands in: "boxes[0].deformer.angle_deg"; "" at the root.
  std::string field() const {
    std::string f;
    for (size_t i = 1; i < stack_.size(); ++i) {  // where stack_[i] sits in stack_[i - 1]
      const json& parent = *stack_[i - 1];
      f = parent.is_array() ? element(f, parent.size() - 1) : child(f, keys_[i]);
    }
    if (!stack_.empty()) {  // the slot the next value fills
      const json& top = *stack_.back();
      if (top.is_array())
        f = element(f, top.size());
      else if (have_key_)
        f = child(f, key_);
    }
    return f;
  }

  bool too_deep = false;
  size_t error_position = 0;
  int error_id = 0;
  std::string error_token, error_message;

 private:
  json* place(json&& v) {
    if (stack_.empty()) {
      root_ = std::move(v);
      return &root_;
    }
    json& top = *stack_.back();
    if (top.is_array()) {
      top.push_back(std::move(v));
      return &top.back();
    }
    json& slot = top[key_];
    slot = std::move(v);
    return &slot;
  }
  bool put(json&& v) {
    place(std::move(v));
    have_key_ = false;
    return true;
  }
  bool open(json&& container) {
    if (stack_.size() >= kMaxJsonDepth) {
      too_deep = true;
      return false;
    }
    json* slot = place(std::move(container));
    keys_.push_back(have_key_ ? key_ : std::string());
    have_key_ = false;
    stack_.push_back(slot);
    return true;
  }
  bool close() {
    stack_.pop_back();
    keys_.pop_back();
    have_key_ = false;
    return true;
  }

  json& root_;
  std::vector<json*> stack_;
  std::vector<std::string> keys_;  // keys_[i]: the key stack_[i] sits under in its parent
  std::string key_;
  bool have_key_ = false;
};

std::string line_and_column(const std::string& text, size_t position) {
  size_t line = 1, column = 1;
  for (size_t i = 0; i < position && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  return "line " + std::to_string(line) + ", column " + std::to_string(column);
}

}  // namespace

json parse_json(const std::string& text, const std::string& file) {
  json root;
  PathSax sax(root);
  const bool ok = json::sax_parse(text, &sax, json::input_format_t::json, true, true);
  if (ok) return root;
  const std::string field = sax.field();
  const std::string where = field.empty() ? "" : " in " + field;
  if (sax.too_deep)
    throw Error(file + ": " + (field.empty() ? "the document" : field) + " nests arrays and " +
                "objects deeper than " + std::to_string(kMaxJsonDepth) + " levels, the most " +
                "raywarp reads");
  if (sax.error_id == 406) {
    // nlohmann's "number overflow parsing '1e999'": a number beyond double range.
    std::string token = sax.error_token;
    if (token.size() > 40) token = token.substr(0, 37) + "...";
    throw Error(file + ": " + (field.empty() ? "the document" : field) + " = " + token +
                ": must be a finite number (at most 1.8e308 in magnitude)");
  }
  std::string message = sax.error_message;
  const size_t colon = message.find(": ", message.find("parse error"));
  if (message.rfind("[json.exception", 0) == 0 && colon != std::string::npos)
    message = message.substr(colon + 2);
  throw Error(file + ": not valid JSON at " + line_and_column(text, sax.error_position) + where +
              ": " + message);
}

json read_json_file(const std::filesystem::path& path, const std::string& what) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw Error(path.string() + ": cannot open the " + what + " (no such file)");
  const auto size = std::filesystem::file_size(path, ec);
  constexpr std::uintmax_t kMaxBytes = 64u << 20;
  if (ec || size > kMaxBytes)
    throw Error(path.string() + ": the " + what + " is larger than 64 MiB, the most raywarp reads");
  std::ifstream in(path, std::ios::binary);
  std::string text(static_cast<size_t>(size), '\0');
  if (!in || !in.read(text.data(), static_cast<std::streamsize>(size)))
    throw Error(path.string() + ": cannot read the " + what);
  return parse_json(text, path.string());
}

}  // namespace raywarp
