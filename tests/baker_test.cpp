// The editor's background baker (editor/baker.h): a bake under way is cancelled by a newer
// submission, its result never arrives, and it leaves nothing behind in the cache: the folder
// holds exactly the entries that a bake of the newer scene alone writes, and no temporary file.
#include "editor/baker.h"

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <set>
#include <string>
#include <thread>

#include "library/scene.h"
#include "tests/temp_folder.h"

namespace raywarp::editor {
namespace {

namespace fs = std::filesystem;

std::set<std::string> entries(const fs::path& dir) {
  std::set<std::string> names;
  if (fs::exists(dir))
    for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
  return names;
}

class BakerTest : public TempFolderTest {};

TEST_F(BakerTest, ABakeCancelledByANewerEditLeavesNothingBehind) {
  Scene slow = load_scene(std::string(RAYWARP_SOURCE_DIR) + "/examples/bunny_twist.json");
  slow.boxes[0].implicit.resolution = 256;  // long enough to be caught in its first stage
  Scene next = slow;
  next.boxes[0].implicit.resolution = 48;
  next.boxes[0].deformation_resolution = 32;
  next.boxes[0].deformer.angle_deg = 45;

  const fs::path dir = dir_ / "cache";
  Baker baker(std::make_unique<BakeCache>(dir));
  baker.submit(slow, 1);
  // Wait until the slow bake is in its distance grid, then submit the newer scene.
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < until) {
    const Baker::Progress p = baker.progress();
    if (p.busy && p.generation == 1 && p.stage == "distance") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_EQ(baker.progress().stage, "distance");
  baker.submit(next, 2);
  std::optional<Baker::Result> result;
  while (!result && std::chrono::steady_clock::now() < until) {
    result = baker.take();
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_TRUE(result.has_value());
  EXPECT_EQ(result->generation, 2);  // the cancelled one's never arrives
  ASSERT_TRUE(result->prepared) << result->error;
  EXPECT_EQ(baker.cancelled(), 1);
  EXPECT_FALSE(baker.progress().busy);

  // The newer scene alone, into a folder of its own.
  const fs::path alone = dir_ / "alone";
  {
    BakeCache cache(alone);
    BakeSession session(&cache);
    bake_scene(next, session);
  }
  const std::set<std::string> written = entries(dir), expected = entries(alone);
  EXPECT_FALSE(expected.empty());
  EXPECT_EQ(written, expected);
  for (const std::string& name : written) EXPECT_EQ(name.find(".tmp"), std::string::npos) << name;
}

}  // namespace
}  // namespace raywarp::editor
