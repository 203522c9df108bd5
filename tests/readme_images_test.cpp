// Named after no one source: the README's pictures end to end.
// The README's pictures (docs/images/NAME.png, rendered from examples/NAME.json at 400 x 400 with
// the scene's own camera) re-render within 1/255 per channel: a refactoring that changes what
// raywarp draws fails here. The PNGs are read back by stb_image, not by raywarp.
#include <gtest/gtest.h>
#include <stb_image.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

struct Pixels {
  int width = 0, height = 0;
  std::vector<unsigned char> rgba;
};

Pixels read_png(const fs::path& path) {
  Pixels p;
  int channels = 0;
  unsigned char* data = stbi_load(path.c_str(), &p.width, &p.height, &channels, 4);
  if (!data) return p;
  p.rgba.assign(data, data + size_t(p.width) * p.height * 4);
  stbi_image_free(data);
  return p;
}

std::vector<std::string> pictured_examples() {
  std::vector<std::string> names;
  const fs::path source(RAYWARP_SOURCE_DIR);
  for (const auto& entry : fs::directory_iterator(source / "docs/images")) {
    const fs::path png = entry.path();
    if (png.extension() != ".png") continue;
    if (fs::exists(source / "examples" / (png.stem().string() + ".json")))
      names.push_back(png.stem().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

class ReadmeImage : public ::testing::TestWithParam<std::string> {};

TEST_P(ReadmeImage, ReRendersWithinOneLevel) {
  const std::string name = GetParam();
  const fs::path source(RAYWARP_SOURCE_DIR);
  const fs::path out = fs::temp_directory_path() / ("raywarp_readme_" + name + ".png");
  const std::string cmd = std::string(RAYWARP_BINARY) + " render " +
                          (source / "examples" / (name + ".json")).string() + " -o " +
                          out.string() + " --width 400 --height 400 > /dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const Pixels now = read_png(out);
  const Pixels then = read_png(source / "docs/images" / (name + ".png"));
  ASSERT_EQ(now.width, then.width);
  ASSERT_EQ(now.height, then.height);
  ASSERT_FALSE(now.rgba.empty());
  int worst = 0;
  long differing = 0;
  for (size_t i = 0; i < now.rgba.size(); ++i) {
    const int d = std::abs(int(now.rgba[i]) - int(then.rgba[i]));
    worst = std::max(worst, d);
    differing += d > 0;
  }
  std::printf("[figures] %s: largest channel difference %d/255, %ld channels differ\n",
              name.c_str(), worst, differing);
  EXPECT_LE(worst, 1) << name;
  fs::remove(out);
}

INSTANTIATE_TEST_SUITE_P(Readme, ReadmeImage, ::testing::ValuesIn(pictured_examples()),
                         [](const auto& info) { return info.param; });

}  // namespace
