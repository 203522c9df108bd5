// Runs the raywarp binary with `args` (a shell command line's tail), its standard output and error
// appended to `output`; returns its exit status, or -1 when it did not exit normally.
#pragma once
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace raywarp::testing {

inline int run_raywarp(const std::string& args, std::string* output) {
  const std::string cmd = std::string(RAYWARP_BINARY) + " " + args + " 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) return -1;
  std::array<char, 4096> buf;
  while (size_t n = fread(buf.data(), 1, buf.size(), pipe)) output->append(buf.data(), n);
  const int status = pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace raywarp::testing
