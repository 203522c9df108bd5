// Tests the documents, not a source: every pointer from docs/ and the README to a symbol in a
// source file names a symbol that is in that file, so that a renamed or moved function does not
// leave the docs pointing at nothing. The pointers are written as `symbol` (`file`),
// (`symbol`, `file`) or `symbol` in `file`; the symbol's last `::` component must appear in the
// file as a whole word. And the tests' own map of the sources: each tests/NAME_test.cpp tests
// the source NAME (a NAME.cpp, .h or .glsl in a source folder), or its first line says why not.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

struct Pointer {
  std::string doc, text, symbol, file;
};

std::vector<Pointer> doc_pointers() {
  const fs::path root = RAYWARP_SOURCE_DIR;
  std::vector<fs::path> docs = {root / "README.md"};
  for (const auto& e : fs::directory_iterator(root / "docs"))
    if (e.path().extension() == ".md") docs.push_back(e.path());
  const std::string symbol = R"(`([A-Za-z_][\w:]*)(?:\(\))?`)";
  const std::string file = R"(`([\w./-]+\.(?:h|cpp|glsl|py|sh|cmake))`)";
  const std::regex forms[] = {std::regex(symbol + " \\(" + file),
                              std::regex("\\(" + symbol + ", " + file),
                              std::regex(symbol + " in " + file)};
  std::vector<Pointer> out;
  for (const fs::path& doc : docs) {
    const std::string text = read_text(doc);
    for (const std::regex& form : forms)
      for (auto m = std::sregex_iterator(text.begin(), text.end(), form);
           m != std::sregex_iterator(); ++m)
        out.push_back({doc.filename().string(), m->str(), (*m)[1].str(), (*m)[2].str()});
  }
  return out;
}

TEST(Docs, PointersNameSymbolsInTheirFiles) {
  const fs::path root = RAYWARP_SOURCE_DIR;
  const std::vector<Pointer> pointers = doc_pointers();
  int stale = 0;
  for (const Pointer& p : pointers) {
    const fs::path file = root / p.file;
    if (!fs::is_regular_file(file)) {
      ADD_FAILURE() << p.doc << ": " << p.text << ": no file " << p.file;
      ++stale;
      continue;
    }
    const std::string name =
        p.symbol.substr(p.symbol.rfind(':') == std::string::npos ? 0 : p.symbol.rfind(':') + 1);
    if (!std::regex_search(read_text(file), std::regex("\\b" + name + "\\b"))) {
      ADD_FAILURE() << p.doc << ": " << p.text << ": " << p.file << " has no " << name;
      ++stale;
    }
  }
  std::printf("[figures] %zu pointers from docs/ and the README to symbols in files, %d stale\n",
              pointers.size(), stale);
  EXPECT_GT(pointers.size(), 50u);  // the forms still match how the docs write pointers
}

}  // namespace

namespace {

// The tests' files are named after what they test (docs/testing.md).
TEST(Docs, EveryTestFileIsNamedAfterItsSourceOrSaysWhyNot) {
  const fs::path root = RAYWARP_SOURCE_DIR;
  const std::string suffix = "_test.cpp";
  int files = 0;
  for (const auto& entry : fs::directory_iterator(root / "tests")) {
    const std::string name = entry.path().filename().string();
    if (name.size() <= suffix.size() ||
        name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0)
      continue;
    ++files;
    const std::string stem = name.substr(0, name.size() - suffix.size());
    bool source = false;
    for (const auto& folder : fs::directory_iterator(root)) {
      if (!folder.is_directory() || folder.path().filename() == "tests") continue;
      for (const char* ext : {".cpp", ".h", ".glsl"})
        source = source || fs::exists(folder.path() / (stem + ext));
    }
    if (source) continue;
    const std::string text = read_text(entry.path());
    const std::string first = text.substr(0, text.find('\n'));
    EXPECT_TRUE(first.rfind("// Named after no one source: ", 0) == 0 ||
                first.find("not a source") != std::string::npos)
        << "tests/" << name << " tests no source named " << stem
        << ": rename it after the source it tests, or begin it with \"// Named after no one "
           "source: \" and why";
  }
  EXPECT_GT(files, 50);
}

}  // namespace
