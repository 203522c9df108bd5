#include "library/gif.h"

#include <gif_lib.h>

#include <array>
#include <limits>
#include <ostream>

#include "base/error.h"

namespace raywarp {

namespace {

// A palette index per 5-bit-per-channel colour, filled on demand (nearest palette entry).
class NearestColour {
 public:
  explicit NearestColour(const ColorMapObject& map) : map_(map) { cache_.fill(-1); }
  GifByteType operator()(uint8_t r, uint8_t g, uint8_t b) {
    const int key = (r >> 3) << 10 | (g >> 3) << 5 | (b >> 3);
    if (cache_[key] < 0) {
      long best = std::numeric_limits<long>::max();
      for (int i = 0; i < map_.ColorCount; ++i) {
        const GifColorType& c = map_.Colors[i];
        long dr = c.Red - r, dg = c.Green - g, db = c.Blue - b;
        long d = dr * dr + dg * dg + db * db;
        if (d < best) {
          best = d;
          cache_[key] = i;
        }
      }
    }
    return static_cast<GifByteType>(cache_[key]);
  }

 private:
  const ColorMapObject& map_;
  std::array<int, 1 << 15> cache_;
};

// giflib's output function: the bytes into the std::ostream in UserData.
int write_to_stream(GifFileType* gif, const GifByteType* bytes, int size) {
  auto& out = *static_cast<std::ostream*>(gif->UserData);
  out.write(reinterpret_cast<const char*>(bytes), size);
  return out ? size : 0;
}

struct GifCloser {
  GifFileType* gif = nullptr;
  ~GifCloser() {
    if (gif) EGifCloseFile(gif, nullptr);
  }
};

}  // namespace

void write_gif(const std::string& path, const std::vector<Image>& frames, int delay_cs) {
  if (frames.empty()) throw Error(path + ": no frames to write");
  const int w = frames[0].width, h = frames[0].height;
  if (w <= 0 || h <= 0 || w > 65535 || h > 65535)
    throw Error(path + ": a GIF frame must be 1 to 65535 pixels on a side, not " +
                std::to_string(w) + "x" + std::to_string(h));
  for (const Image& f : frames)
    if (f.width != w || f.height != h) throw Error(path + ": the frames differ in size");

  // The palette, from a sample of every frame's pixels.
  const size_t pixels = size_t(w) * h;
  const size_t budget = size_t(1) << 22;
  const size_t stride = std::max<size_t>(1, pixels * frames.size() / budget);
  std::vector<GifByteType> red, green, blue;
  for (const Image& f : frames)
    for (size_t i = 0; i < pixels; i += stride) {
      red.push_back(f.rgba[4 * i]);
      green.push_back(f.rgba[4 * i + 1]);
      blue.push_back(f.rgba[4 * i + 2]);
    }
  std::vector<GifByteType> indices(red.size());
  int colours = 256;
  ColorMapObject* map = GifMakeMapObject(colours, nullptr);
  if (!map) throw Error(path + ": out of memory for the GIF palette");
  struct MapFree {
    ColorMapObject* m;
    ~MapFree() { GifFreeMapObject(m); }
  } map_free{map};
  if (GifQuantizeBuffer(static_cast<unsigned>(red.size()), 1, &colours, red.data(), green.data(),
                        blue.data(), indices.data(), map->Colors) == GIF_ERROR)
    throw Error(path + ": could not choose the GIF palette");
  NearestColour nearest(*map);

  // Written whole (write_file_atomic), through giflib's output function into the stream.
  write_file_atomic(path, [&](std::ostream& stream) {
    int error = 0;
    GifCloser out;
    out.gif = EGifOpen(&stream, &write_to_stream, &error);
    if (!out.gif) throw Error(path + ": cannot write (" + std::string(GifErrorString(error)) + ")");
    auto fail = [&](const char* what) {
      throw Error(path + ": " + what + " (" + GifErrorString(out.gif->Error) + ")");
    };
    EGifSetGifVersion(out.gif, true);
    if (EGifPutScreenDesc(out.gif, w, h, 8, 0, map) == GIF_ERROR) fail("cannot write the header");
    // Loop forever (the NETSCAPE2.0 application extension).
    const unsigned char netscape[] = "NETSCAPE2.0";
    const unsigned char loop[] = {1, 0, 0};
    if (EGifPutExtensionLeader(out.gif, APPLICATION_EXT_FUNC_CODE) == GIF_ERROR ||
        EGifPutExtensionBlock(out.gif, 11, netscape) == GIF_ERROR ||
        EGifPutExtensionBlock(out.gif, 3, loop) == GIF_ERROR ||
        EGifPutExtensionTrailer(out.gif) == GIF_ERROR)
      fail("cannot write the loop extension");
    std::vector<GifByteType> line(w);
    for (const Image& f : frames) {
      GraphicsControlBlock gcb{};
      gcb.DisposalMode = DISPOSE_DO_NOT;
      gcb.DelayTime = delay_cs;
      gcb.TransparentColor = NO_TRANSPARENT_COLOR;
      GifByteType ext[4];
      const size_t len = EGifGCBToExtension(&gcb, ext);
      if (EGifPutExtension(out.gif, GRAPHICS_EXT_FUNC_CODE, static_cast<int>(len), ext) ==
          GIF_ERROR)
        fail("cannot write a frame's delay");
      if (EGifPutImageDesc(out.gif, 0, 0, w, h, false, nullptr) == GIF_ERROR)
        fail("cannot write a frame");
      for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
          const uint8_t* p = &f.rgba[4 * (size_t(y) * w + x)];
          line[x] = nearest(p[0], p[1], p[2]);
        }
        if (EGifPutLine(out.gif, line.data(), w) == GIF_ERROR) fail("cannot write a frame");
      }
    }
    GifFileType* gif = out.gif;
    out.gif = nullptr;
    if (EGifCloseFile(gif, &error) == GIF_ERROR)
      throw Error(path + ": cannot finish the file (" + std::string(GifErrorString(error)) + ")");
  });
}

}  // namespace raywarp
