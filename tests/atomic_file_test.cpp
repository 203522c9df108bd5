// The atomic file writer (base/atomic_file.h): whole files or none, errors naming the path and
// the system's reason, no temporary left behind.
#include "base/atomic_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <ostream>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "base/error.h"
#include "tests/temp_folder.h"

namespace raywarp {
namespace {

namespace fs = std::filesystem;

class AtomicFile : public TempFolderTest {
 protected:
  static std::string read(const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
};

TEST_F(AtomicFile, WritesBytesTextAndStreams) {
  write_file_atomic(path("a.bin"), "\0\1\2", 3);
  EXPECT_EQ(read(path("a.bin")), std::string("\0\1\2", 3));
  write_file_atomic(path("b.txt"), std::string("text"));
  EXPECT_EQ(read(path("b.txt")), "text");
  // Larger than the writer's buffer, in pieces of every size.
  std::string expected;
  write_file_atomic(path("c.txt"), [&](std::ostream& out) {
    for (int i = 0; i < 20000; ++i) {
      const std::string piece(static_cast<size_t>(i % 97), char('a' + i % 26));
      out << piece << i << '\n';
      expected += piece + std::to_string(i) + "\n";
    }
  });
  EXPECT_EQ(read(path("c.txt")), expected);
  write_file_atomic(path("empty"), "", 0);
  EXPECT_EQ(read(path("empty")), "");
  EXPECT_EQ(listing(), (std::vector<std::string>{"a.bin", "b.txt", "c.txt", "empty"}));
}

TEST_F(AtomicFile, ReplacesWithTheUsualMode) {
  write_file_atomic(path("f"), std::string("first version"));
  write_file_atomic(path("f"), std::string("second"));
  EXPECT_EQ(read(path("f")), "second");
  const mode_t mask = ::umask(0);
  ::umask(mask);
  struct stat st {};
  ASSERT_EQ(::stat(path("f").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0666 & ~mask);
  EXPECT_EQ(listing(), std::vector<std::string>{"f"});
}

TEST_F(AtomicFile, AnExceptionWhileWritingKeepsTheOldFile) {
  write_file_atomic(path("f"), std::string("old"));
  EXPECT_THROW(write_file_atomic(path("f"),
                                 [](std::ostream& out) {
                                   out << std::string(200000, 'x');
                                   throw std::runtime_error("encoder failed");
                                 }),
               std::runtime_error);
  EXPECT_EQ(read(path("f")), "old");
  EXPECT_EQ(listing(), std::vector<std::string>{"f"});
}

TEST_F(AtomicFile, ErrorsNameThePathAndTheReason) {
  auto message = [](const std::function<void()>& write) {
    try {
      write();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string missing = path("missing/out.bin");
  EXPECT_EQ(message([&] { write_file_atomic(missing, "x", 1); }),
            missing + ": cannot write: No such file or directory");
  // Over a folder: the rename fails, and the temporary goes.
  fs::create_directories(path("folder"));
  const std::string m = message([&] { write_file_atomic(path("folder"), std::string("x")); });
  EXPECT_EQ(m.rfind(path("folder") + ": cannot write: ", 0), 0u) << m;
  EXPECT_EQ(listing(), std::vector<std::string>{"folder"});
}

}  // namespace
}  // namespace raywarp
