// The benches' Markdown output: a table written between the markers <!-- NAME:begin --> and
// <!-- NAME:end --> of a file, the rest of the file kept; a file without them is written anew,
// with `heading` above the block. Atomic (base/atomic_file.h); throws Error when it cannot write.
#pragma once
#include <fstream>
#include <sstream>
#include <string>

#include "base/atomic_file.h"

namespace raywarp::bench {

inline void write_marked_block(const std::string& path, const std::string& name,
                               const std::string& table, const std::string& heading) {
  const std::string begin = "<!-- " + name + ":begin -->", end = "<!-- " + name + ":end -->";
  std::string text;
  {
    std::ifstream in(path);
    std::stringstream buffer;
    buffer << in.rdbuf();
    text = buffer.str();
  }
  const size_t b = text.find(begin), e = text.find(end);
  const std::string block = begin + "\n" + table + end;
  if (b != std::string::npos && e != std::string::npos && e > b)
    text = text.substr(0, b) + block + text.substr(e + end.size());
  else
    text = "# " + heading + "\n\n" + block + "\n";
  write_file_atomic(path, text.data(), text.size());
}

}  // namespace raywarp::bench
