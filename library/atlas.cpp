#include "library/atlas.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStdIO.h>
#include <png.h>

#include <algorithm>
#include <cmath>
#include <csetjmp>
#include <cstdint>
#include <cstring>
#include <exception>
#include <fstream>
#include <iterator>
#include <ostream>
#include <string>
#include <vector>

#include "base/atomic_file.h"
#include "base/error.h"

namespace raywarp {
namespace {

std::string dims_text(const Eigen::Vector3i& d) {
  return std::to_string(d.x()) + " x " + std::to_string(d.y()) + " x " + std::to_string(d.z());
}

void check_channels(const std::string& path, int channels) {
  if (channels != 1 && channels != 2 && channels != 4)
    throw Error(path + ": channels = " + std::to_string(channels) + ": must be 1, 2 or 4");
}

void check_layout(const std::string& path, const AtlasLayout& layout) {
  if (layout.dims.minCoeff() < 1)
    throw Error(path + ": dims = " + dims_text(layout.dims) + ": each must be >= 1");
  if (layout.border != 0 && layout.border != 1)
    throw Error(path + ": atlas border = " + std::to_string(layout.border) + ": must be 0 or 1");
  if (layout.tiles_x < 1 || layout.tiles_y < 1 ||
      static_cast<long long>(layout.tiles_x) * layout.tiles_y < layout.dims.z())
    throw Error(path + ": atlas of " + std::to_string(layout.tiles_x) + " x " +
                std::to_string(layout.tiles_y) + " tiles: must hold all " +
                std::to_string(layout.dims.z()) + " slices");
  const long long w =
      static_cast<long long>(layout.tiles_x) * (layout.dims.x() + 2 * layout.border);
  const long long h =
      static_cast<long long>(layout.tiles_y) * (layout.dims.y() + 2 * layout.border);
  if (w > kMaxAtlasSize || h > kMaxAtlasSize)
    throw Error(path + ": atlas of " + std::to_string(w) + " x " + std::to_string(h) +
                " pixels for a " + dims_text(layout.dims) +
                " volume: each side must be <= " + std::to_string(kMaxAtlasSize));
}

void check_volume(const std::string& path, const TextureVolume& v, const AtlasLayout& layout) {
  check_channels(path, v.channels);
  if (v.dims.minCoeff() < 1)
    throw Error(path + ": dims = " + dims_text(v.dims) + ": each must be >= 1");
  if (v.values.size() != v.texels() * static_cast<size_t>(v.channels))
    throw Error(path + ": " + std::to_string(v.values.size()) + " values: must be " +
                std::to_string(v.texels() * v.channels) + " (dims x channels)");
  if (layout.dims != v.dims)
    throw Error(path + ": atlas layout for " + dims_text(layout.dims) + " texels: must match the " +
                dims_text(v.dims) + " volume");
  check_layout(path, layout);
}

TextureVolume empty_volume(const AtlasLayout& layout, int channels) {
  TextureVolume v;
  v.dims = layout.dims;
  v.channels = channels;
  v.values.assign(v.texels() * channels, 0.0f);
  return v;
}

// ---- PNG (libpng) ----
// libpng reports errors through longjmp; the callbacks keep the message and jump back to the
// setjmp in the same function, so no C++ frame is skipped.

struct PngIo {
  std::ostream* out = nullptr;
  const std::string* in = nullptr;
  size_t in_pos = 0;
  std::string error;
};

void png_error_callback(png_structp png, png_const_charp message) {
  static_cast<PngIo*>(png_get_error_ptr(png))->error = message;
  png_longjmp(png, 1);
}
void png_warning_callback(png_structp, png_const_charp) {}

void png_write_callback(png_structp png, png_bytep data, png_size_t size) {
  static_cast<PngIo*>(png_get_io_ptr(png))
      ->out->write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
}
void png_flush_callback(png_structp) {}

void png_read_callback(png_structp png, png_bytep data, png_size_t size) {
  auto* io = static_cast<PngIo*>(png_get_io_ptr(png));
  if (io->in->size() - io->in_pos < size) png_error(png, "file is truncated");
  std::memcpy(data, io->in->data() + io->in_pos, size);
  io->in_pos += size;
}

int png_color_type(int channels) {
  return channels == 1   ? PNG_COLOR_TYPE_GRAY
         : channels == 2 ? PNG_COLOR_TYPE_GRAY_ALPHA
                         : PNG_COLOR_TYPE_RGB_ALPHA;
}

// Writes `samples` (host-order 16-bit, rows from the top); returns libpng's message on failure.
std::string encode_png16(std::ostream& out, int width, int height, int channels,
                         std::vector<std::uint16_t>& samples) {
  PngIo io;
  io.out = &out;
  std::vector<png_bytep> rows(static_cast<size_t>(height));
  for (int y = 0; y < height; ++y)
    rows[y] =
        reinterpret_cast<png_bytep>(samples.data() + static_cast<size_t>(y) * width * channels);
  png_structp png =
      png_create_write_struct(PNG_LIBPNG_VER_STRING, &io, png_error_callback, png_warning_callback);
  if (png == nullptr) return "cannot create a libpng writer";
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_write_struct(&png, nullptr);
    return "cannot create a libpng writer";
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return io.error;
  }
  png_set_write_fn(png, &io, png_write_callback, png_flush_callback);
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 16,
               png_color_type(channels), PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  // Linear data: gAMA 1.0 (file gamma 100000 / 100000), no sRGB chunk.
  png_set_gAMA_fixed(png, info, PNG_FP_1);
  png_write_info(png, info);
  png_set_swap(png);  // PNG samples are big-endian; ours are in host order
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return {};
}

// Decodes a 16-bit PNG of the given size and colour type into host-order samples.
std::string decode_png16(const std::string& bytes, int width, int height, int channels,
                         std::vector<std::uint16_t>& samples) {
  PngIo io;
  io.in = &bytes;
  samples.assign(static_cast<size_t>(width) * height * channels, 0);
  std::vector<png_bytep> rows(static_cast<size_t>(height));
  for (int y = 0; y < height; ++y)
    rows[y] =
        reinterpret_cast<png_bytep>(samples.data() + static_cast<size_t>(y) * width * channels);
  png_structp png =
      png_create_read_struct(PNG_LIBPNG_VER_STRING, &io, png_error_callback, png_warning_callback);
  if (png == nullptr) return "cannot create a libpng reader";
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    return "cannot create a libpng reader";
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return io.error;
  }
  png_set_read_fn(png, &io, png_read_callback);
  png_read_info(png, info);
  if (png_get_image_width(png, info) != static_cast<png_uint_32>(width) ||
      png_get_image_height(png, info) != static_cast<png_uint_32>(height))
    png_error(png, "image size differs from the atlas layout's");
  if (png_get_bit_depth(png, info) != 16 ||
      png_get_color_type(png, info) != png_color_type(channels) ||
      png_get_interlace_type(png, info) != PNG_INTERLACE_NONE)
    png_error(png, "not a 16-bit, non-interlaced image of the expected channels");
  png_set_swap(png);
  png_read_update_info(png, info);
  png_read_image(png, rows.data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return {};
}

void check_encoding(const std::string& path, const UnormEncoding& enc, int channels) {
  if (enc.lo.size() != static_cast<size_t>(channels) || enc.hi.size() != enc.lo.size())
    throw Error(path + ": unorm16 encoding of " + std::to_string(enc.lo.size()) + " / " +
                std::to_string(enc.hi.size()) + " channels (lo / hi): must be " +
                std::to_string(channels));
  for (int c = 0; c < channels; ++c)
    if (!std::isfinite(enc.lo[c]) || !std::isfinite(enc.hi[c]) || !(enc.hi[c] > enc.lo[c]))
      throw Error(path + ": unorm16 encoding of channel " + std::to_string(c) +
                  ": lo = " + std::to_string(enc.lo[c]) + ", hi = " + std::to_string(enc.hi[c]) +
                  ": must be finite with hi > lo");
}

// ---- OpenEXR ----

const char* const kExrNames[4][4] = {{"R"}, {"R", "G"}, {}, {"R", "G", "B", "A"}};

}  // namespace

AtlasLayout atlas_layout(const Eigen::Vector3i& dims, int border, int tiles_x) {
  if (dims.minCoeff() < 1)
    throw Error("atlas layout: dims = " + dims_text(dims) + ": each must be >= 1");
  if (border != 0 && border != 1)
    throw Error("atlas layout: border = " + std::to_string(border) + ": must be 0 or 1");
  if (tiles_x < 0)
    throw Error("atlas layout: tiles_x = " + std::to_string(tiles_x) +
                ": must be >= 1, or 0 for ceil(sqrt(nz))");
  AtlasLayout layout;
  layout.dims = dims;
  layout.border = border;
  const int nz = dims.z();
  if (tiles_x == 0) {
    // Engines cut tiles_x * tiles_y slices out of the atlas (Godot, Unreal), so a grid with no
    // empty tile is best: the divisor of nz nearest sqrt(nz) within a factor of 2 of it (96
    // slices: 8 x 12). Otherwise (a prime nz) ceil(sqrt(nz)) columns and a last row part empty.
    const double root = std::sqrt(static_cast<double>(nz));
    int best = 0;
    for (int d = 1; d <= nz; ++d)
      if (nz % d == 0 && d >= root / 2 && d <= 2 * root &&
          (best == 0 || std::abs(d - root) < std::abs(best - root)))
        best = d;
    tiles_x = best > 0 ? best : static_cast<int>(std::ceil(root));
  }
  layout.tiles_x = tiles_x;
  layout.tiles_y = (nz + tiles_x - 1) / tiles_x;
  return layout;
}

std::vector<float> atlas_pixels(const TextureVolume& v, const AtlasLayout& layout) {
  const int w = layout.width(), h = layout.height(), ch = v.channels, b = layout.border;
  std::vector<float> pixels(static_cast<size_t>(w) * h * ch, 0.0f);
  for (int k = 0; k < v.dims.z(); ++k)
    for (int j = -b; j < v.dims.y() + b; ++j)
      for (int i = -b; i < v.dims.x() + b; ++i) {
        const Eigen::Vector2i p = layout.texel(i, j, k);
        const int si = std::clamp(i, 0, v.dims.x() - 1), sj = std::clamp(j, 0, v.dims.y() - 1);
        for (int c = 0; c < ch; ++c)
          pixels[(static_cast<size_t>(p.y()) * w + p.x()) * ch + c] = v.at(si, sj, k, c);
      }
  return pixels;
}

double UnormEncoding::max_error() const {
  double e = 0;
  for (size_t c = 0; c < lo.size() && c < hi.size(); ++c)
    e = std::max(e, (hi[c] - lo[c]) / 65535.0 / 2.0);
  return e;
}

UnormEncoding unorm_encoding(const TextureVolume& v) {
  UnormEncoding enc;
  for (int c = 0; c < v.channels; ++c) {
    double lo = INFINITY, hi = -INFINITY;
    for (size_t t = c; t < v.values.size(); t += v.channels) {
      if (!std::isfinite(v.values[t])) continue;
      lo = std::min(lo, static_cast<double>(v.values[t]));
      hi = std::max(hi, static_cast<double>(v.values[t]));
    }
    if (!(lo <= hi)) lo = hi = 0;  // no finite value
    enc.lo.push_back(lo);
    enc.hi.push_back(hi > lo ? hi : lo + 1);
  }
  return enc;
}

UnormEncoding write_atlas_png16(const std::string& path, const TextureVolume& v,
                                const AtlasLayout& layout) {
  check_volume(path, v, layout);
  UnormEncoding enc = unorm_encoding(v);
  write_atlas_png16(path, v, layout, enc);
  return enc;
}

void write_atlas_png16(const std::string& path, const TextureVolume& v, const AtlasLayout& layout,
                       const UnormEncoding& encoding) {
  check_volume(path, v, layout);
  check_encoding(path, encoding, v.channels);
  for (size_t t = 0; t < v.values.size(); ++t)
    if (!std::isfinite(v.values[t]))
      throw Error(path + ": texel value " + std::to_string(v.values[t]) + " (value index " +
                  std::to_string(t) + "): a 16-bit PNG stores finite values only");
  const std::vector<float> pixels = atlas_pixels(v, layout);
  std::vector<std::uint16_t> samples(pixels.size());
  const int ch = v.channels;
  for (size_t s = 0; s < pixels.size(); ++s) {
    const int c = static_cast<int>(s % ch);
    const double lo = encoding.lo[c], hi = encoding.hi[c];
    const double code = std::round((pixels[s] - lo) / (hi - lo) * 65535.0);
    samples[s] = static_cast<std::uint16_t>(std::clamp(code, 0.0, 65535.0));
  }
  // Unused tiles hold code 0 (the value lo), as the zero texels of the float formats.
  write_file_atomic(path, [&](std::ostream& out) {
    const std::string error = encode_png16(out, layout.width(), layout.height(), ch, samples);
    if (!error.empty()) throw Error(path + ": cannot write PNG: " + error);
  });
}

TextureVolume read_atlas_png16(const std::string& path, const AtlasLayout& layout,
                               const UnormEncoding& encoding, int channels) {
  check_channels(path, channels);
  check_layout(path, layout);
  check_encoding(path, encoding, channels);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::vector<std::uint16_t> samples;
  const std::string error = decode_png16(bytes, layout.width(), layout.height(), channels, samples);
  if (!error.empty()) throw Error(path + ": cannot read PNG: " + error);
  TextureVolume v = empty_volume(layout, channels);
  for (int k = 0; k < v.dims.z(); ++k)
    for (int j = 0; j < v.dims.y(); ++j)
      for (int i = 0; i < v.dims.x(); ++i) {
        const Eigen::Vector2i p = layout.texel(i, j, k);
        for (int c = 0; c < channels; ++c) {
          const std::uint16_t code =
              samples[(static_cast<size_t>(p.y()) * layout.width() + p.x()) * channels + c];
          v.values[v.index(i, j, k, c)] = static_cast<float>(
              encoding.lo[c] + code / 65535.0 * (encoding.hi[c] - encoding.lo[c]));
        }
      }
  return v;
}

void write_atlas_exr(const std::string& path, const TextureVolume& v, const AtlasLayout& layout,
                     Storage storage) {
  check_volume(path, v, layout);
  const int w = layout.width(), h = layout.height(), ch = v.channels;
  const std::vector<float> pixels = atlas_pixels(v, layout);
  std::vector<std::uint16_t> halves;
  if (storage == Storage::Half) {
    halves.resize(pixels.size());
    for (size_t s = 0; s < pixels.size(); ++s) halves[s] = float_to_half_bits(pixels[s]);
  }
  const Imf::PixelType type = storage == Storage::Half ? Imf::HALF : Imf::FLOAT;
  const size_t sample_size = storage == Storage::Half ? sizeof(std::uint16_t) : sizeof(float);
  char* base = storage == Storage::Half
                   ? reinterpret_cast<char*>(halves.data())
                   : reinterpret_cast<char*>(const_cast<float*>(pixels.data()));
  std::string bytes;
  try {
    // Scanlines from the top (INCREASING_Y, data window (0, 0) to (w - 1, h - 1)), pixel
    // aspect 1, ZIP (lossless, 16 scanlines a block). The file lists its channels by name,
    // sorted (A, B, G, R); readers find them by name.
    Imf::Header header(w, h);
    header.compression() = Imf::ZIP_COMPRESSION;
    Imf::FrameBuffer frame;
    for (int c = 0; c < ch; ++c) {
      header.channels().insert(kExrNames[ch - 1][c], Imf::Channel(type));
      frame.insert(kExrNames[ch - 1][c], Imf::Slice(type, base + c * sample_size, sample_size * ch,
                                                    sample_size * ch * static_cast<size_t>(w)));
    }
    Imf::StdOSStream stream;
    {
      Imf::OutputFile file(stream, header);
      file.setFrameBuffer(frame);
      file.writePixels(h);
    }
    bytes = stream.str();
  } catch (const std::exception& e) {
    throw Error(path + ": cannot write OpenEXR: " + e.what());
  }
  write_file_atomic(path, bytes);
}

TextureVolume read_atlas_exr(const std::string& path, const AtlasLayout& layout, int channels) {
  check_channels(path, channels);
  check_layout(path, layout);
  const int w = layout.width(), h = layout.height();
  std::vector<float> pixels(static_cast<size_t>(w) * h * channels);
  try {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i window = file.header().dataWindow();
    if (window.min.x != 0 || window.min.y != 0 || window.max.x != w - 1 || window.max.y != h - 1)
      throw Error(path + ": data window (" + std::to_string(window.min.x) + ", " +
                  std::to_string(window.min.y) + ") - (" + std::to_string(window.max.x) + ", " +
                  std::to_string(window.max.y) + "): must be (0, 0) - (" + std::to_string(w - 1) +
                  ", " + std::to_string(h - 1) + ") for the atlas layout");
    Imf::FrameBuffer frame;
    for (int c = 0; c < channels; ++c) {
      const char* name = kExrNames[channels - 1][c];
      if (file.header().channels().findChannel(name) == nullptr)
        throw Error(path + ": no channel " + name + ": expected " + std::to_string(channels) +
                    " channels");
      frame.insert(name, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(pixels.data() + c),
                                    sizeof(float) * channels,
                                    sizeof(float) * channels * static_cast<size_t>(w)));
    }
    file.setFrameBuffer(frame);
    file.readPixels(0, h - 1);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(path + ": cannot read OpenEXR: " + e.what());
  }
  TextureVolume v = empty_volume(layout, channels);
  for (int k = 0; k < v.dims.z(); ++k)
    for (int j = 0; j < v.dims.y(); ++j)
      for (int i = 0; i < v.dims.x(); ++i) {
        const Eigen::Vector2i p = layout.texel(i, j, k);
        for (int c = 0; c < channels; ++c)
          v.values[v.index(i, j, k, c)] =
              pixels[(static_cast<size_t>(p.y()) * w + p.x()) * channels + c];
      }
  return v;
}

}  // namespace raywarp
