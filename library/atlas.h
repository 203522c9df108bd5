// Tiled 2D atlases of a 3D texture, for engines that build a volume texture from a 2D image
// (Unreal 5's volume texture from a 2D texture, Godot 4's Texture3D by slices, Unity's flipbook
// import) and for tools that sample the atlas directly.
//
// The layout is the engines' one: slice z sits in tile column z % tiles_x, tile row z / tiles_x,
// tile row 0 at the top of the image; within a tile texel (i, j) of the slice is pixel column i,
// row j counted from the tile's top, so texel (0, 0) is the tile's top-left pixel. Tiles past
// the last slice are zero. An optional border of one texel around each tile repeats the slice's
// edge texels (clamp-to-edge), so that bilinear filtering of the 2D atlas does not bleed between
// slices; with border 0 the atlas is exactly what the engines cut into slices.
//
// Two files: a 16-bit PNG (grey, grey+alpha or RGBA, each channel an affine unorm16 encoding of
// the values, see UnormEncoding) and an OpenEXR image (half or float channels R, G, B, A).
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

#include "library/texture_volume.h"

namespace raywarp {

constexpr int kMaxAtlasSize = 16384;  // pixels per side: the largest 2D texture engines import

struct AtlasLayout {
  Eigen::Vector3i dims = Eigen::Vector3i::Ones();  // the volume's texels along x, y, z
  int tiles_x = 1;                                 // tile columns
  int tiles_y = 1;                                 // tile rows
  int border = 0;                                  // 0 or 1 texel around each tile

  int tile_width() const { return dims.x() + 2 * border; }
  int tile_height() const { return dims.y() + 2 * border; }
  int width() const { return tiles_x * tile_width(); }
  int height() const { return tiles_y * tile_height(); }
  // The pixel (column, row from the top) of texel (i, j) of slice k. i and j may reach into the
  // border: -border <= i < dims.x() + border.
  Eigen::Vector2i texel(int i, int j, int k) const {
    return {(k % tiles_x) * tile_width() + border + i, (k / tiles_x) * tile_height() + border + j};
  }
};

// tiles_x = 0 picks the divisor of nz nearest sqrt(nz) within a factor of 2 of it, so that
// tiles_x * tiles_y = nz (no empty tile), else ceil(sqrt(nz)); tiles_y = ceil(nz / tiles_x). Throws
// Error for dims < 1, a border other than 0 or 1, or tiles_x < 0. (The size limit is checked by the
// writers.)
AtlasLayout atlas_layout(const Eigen::Vector3i& dims, int border = 0, int tiles_x = 0);

// The atlas as floats, channels interleaved, rows from the top: width * height * channels.
std::vector<float> atlas_pixels(const TextureVolume& v, const AtlasLayout& layout);

// Per channel c: code = round((v - lo[c]) / (hi[c] - lo[c]) * 65535), clamped to [0, 65535];
// decoded v = lo[c] + code / 65535 * (hi[c] - lo[c]).
struct UnormEncoding {
  std::vector<double> lo, hi;
  // The largest |decoded - v| for v in [lo, hi]: half a code step of the widest channel. (A
  // reader that rounds the decoded value to float adds up to half a float ulp.)
  double max_error() const;
};
// lo, hi: each channel's min and max over the volume (hi = lo + 1 where they are equal).
UnormEncoding unorm_encoding(const TextureVolume& v);

// 16-bit PNG: 1 channel -> grey 16, 2 -> grey+alpha 16, 4 -> RGBA 16. The data are linear, so
// the file carries gAMA 1.0 and no sRGB chunk; engines must import it with sRGB off (Unreal:
// sRGB unchecked, compression HDR or uncompressed; Godot: no sRGB conversion; Unity: sRGB
// (Color Texture) off). The encoding goes in the caller's sidecar. Throws Error naming the path
// for bad input (channels not 1, 2 or 4, dims < 1, a layout of other dims, an atlas over
// kMaxAtlasSize per side, non-finite values, an encoding that is not finite with hi > lo) and
// for a failure to write. Written atomically.
UnormEncoding write_atlas_png16(const std::string& path, const TextureVolume& v,
                                const AtlasLayout& layout);
void write_atlas_png16(const std::string& path, const TextureVolume& v, const AtlasLayout& layout,
                       const UnormEncoding& encoding);
// Reads such a PNG back (through libpng) and decodes it; the border is ignored.
TextureVolume read_atlas_png16(const std::string& path, const AtlasLayout& layout,
                               const UnormEncoding& encoding, int channels);

// OpenEXR, scanlines from the top, ZIP compression (lossless), channels R (1 channel), R G (2)
// or R G B A (4), each HALF (Storage::Half, round to nearest even, magnitudes clamped to 65504)
// or FLOAT. Throws Error as write_atlas_png16 (any finite or non-finite value is allowed).
void write_atlas_exr(const std::string& path, const TextureVolume& v, const AtlasLayout& layout,
                     Storage storage);
// Reads such a file back through OpenEXR's InputFile (half channels widen to float exactly).
TextureVolume read_atlas_exr(const std::string& path, const AtlasLayout& layout, int channels);

}  // namespace raywarp
