// The Open field's completion (editor/path_completion.h): the entries of the typed folder that
// start with the typed rest, folders first with a trailing /, only files the editor opens, hidden
// ones only when asked for, and Tab extends to what the completions share.
#include "editor/path_completion.h"

#include <gtest/gtest.h>

#include <fstream>

#include "tests/temp_folder.h"

namespace raywarp::editor {
namespace {

namespace fs = std::filesystem;

class PathCompletion : public TempFolderTest {};

TEST_F(PathCompletion, ListsFoldersThenOpenableFilesThatStartWithTheTypedRest) {
  fs::create_directories(dir_ / "meshes");
  fs::create_directories(dir_ / ".hidden");
  for (const char* name :
       {"bunny.json", "bunny_twist.json", "bunny.ply.xz", "bunny.txt", "horse.obj"})
    std::ofstream(dir_ / name) << "x";
  const std::string d = dir_.string() + "/";
  EXPECT_EQ(
      path_completions(d + "bu"),
      (std::vector<std::string>{d + "bunny.json", d + "bunny.ply.xz", d + "bunny_twist.json"}));
  EXPECT_EQ(path_completions(d + "m"), std::vector<std::string>{d + "meshes/"});
  const std::vector<std::string> all = path_completions(d);
  ASSERT_EQ(all.size(), 5u);  // no .hidden, no bunny.txt
  EXPECT_EQ(all.front(), d + "meshes/");
  EXPECT_EQ(path_completions(d + ".h"), std::vector<std::string>{d + ".hidden/"});
  EXPECT_TRUE(path_completions(d + "nowhere/x").empty());
  EXPECT_EQ(path_completions(d, 2).size(), 2u);

  EXPECT_EQ(complete_path(d + "bu"), d + "bunny");  // what the three share
  EXPECT_EQ(complete_path(d + "h"), d + "horse.obj");
  EXPECT_EQ(complete_path(d + "me"), d + "meshes/");
  EXPECT_EQ(complete_path(d + "zz"), d + "zz");
  EXPECT_TRUE(opens_file("A.PLY"));
  EXPECT_TRUE(opens_file("scan.glb.xz"));
  EXPECT_FALSE(opens_file("notes.txt"));
}

}  // namespace
}  // namespace raywarp::editor
