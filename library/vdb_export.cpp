#include "library/vdb_export.h"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <unistd.h>

#include <Eigen/LU>
#include <atomic>
#include <cmath>
#include <exception>
#include <filesystem>
#include <set>
#include <sstream>
#include <string>
#include <system_error>

#include "base/error.h"

namespace raywarp {
namespace {

std::string grid_label(const std::string& path, size_t index, const std::string& name) {
  return path + ": grid " + std::to_string(index) + " (\"" + name + "\")";
}

void check_grid(const std::string& path, size_t index, const VdbGrid& g, const std::string& name) {
  const std::string where = grid_label(path, index, name);
  const TextureVolume& v = g.volume;
  if (name.empty()) throw Error(path + ": grid " + std::to_string(index) + ": empty name");
  if (v.channels != 1 && v.channels != 3)
    throw Error(where + ": channels = " + std::to_string(v.channels) +
                ": must be 1 (FloatGrid) or 3 (Vec3SGrid)");
  if (v.dims.minCoeff() < 1)
    throw Error(where + ": dims = " + std::to_string(v.dims.x()) + " x " +
                std::to_string(v.dims.y()) + " x " + std::to_string(v.dims.z()) +
                ": each must be >= 1");
  if (v.values.size() != v.texels() * static_cast<size_t>(v.channels))
    throw Error(where + ": " + std::to_string(v.values.size()) + " values: must be " +
                std::to_string(v.texels() * v.channels) + " (dims x channels)");
  const Eigen::Matrix4d& m = g.index_to_world;
  if (!m.allFinite() || m.row(3) != Eigen::RowVector4d(0, 0, 0, 1))
    throw Error(where + ": index_to_world must be finite with last row (0, 0, 0, 1) (affine)");
  const double det = m.topLeftCorner<3, 3>().determinant();
  const double scale = m.topLeftCorner<3, 3>().cwiseAbs().maxCoeff();
  if (!(std::abs(det) > 1e-12 * scale * scale * scale))
    throw Error(where + ": index_to_world's 3 x 3 part is singular: it must be invertible");
}

// OpenVDB applies a Mat4d to row vectors (world = (i, j, k, 1) * M, translation in the last
// row), so the column-vector matrix is stored transposed.
openvdb::math::Transform::Ptr make_transform(const Eigen::Matrix4d& index_to_world) {
  openvdb::math::Mat4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = index_to_world(c, r);
  return openvdb::math::Transform::createLinearTransform(m);
}

openvdb::GridBase::Ptr make_grid(const VdbGrid& g, const std::string& name) {
  const TextureVolume& v = g.volume;
  openvdb::GridBase::Ptr base;
  if (v.channels == 1) {
    auto grid = openvdb::FloatGrid::create(g.background);
    auto acc = grid->getAccessor();
    for (int k = 0; k < v.dims.z(); ++k)
      for (int j = 0; j < v.dims.y(); ++j)
        for (int i = 0; i < v.dims.x(); ++i) {
          const float value = v.at(i, j, k, 0);
          if (value != g.background) acc.setValue(openvdb::Coord(i, j, k), value);
        }
    grid->tree().prune();
    grid->setGridClass(g.level_set ? openvdb::GRID_LEVEL_SET : openvdb::GRID_FOG_VOLUME);
    base = grid;
  } else {
    const openvdb::Vec3s background(g.background);
    auto grid = openvdb::Vec3SGrid::create(background);
    auto acc = grid->getAccessor();
    for (int k = 0; k < v.dims.z(); ++k)
      for (int j = 0; j < v.dims.y(); ++j)
        for (int i = 0; i < v.dims.x(); ++i) {
          const openvdb::Vec3s value(v.at(i, j, k, 0), v.at(i, j, k, 1), v.at(i, j, k, 2));
          if (value != background) acc.setValue(openvdb::Coord(i, j, k), value);
        }
    grid->tree().prune();
    grid->setGridClass(g.level_set ? openvdb::GRID_LEVEL_SET : openvdb::GRID_UNKNOWN);
    grid->setVectorType(g.vector_is_displacement ? openvdb::VEC_CONTRAVARIANT_RELATIVE
                                                 : openvdb::VEC_INVARIANT);
    base = grid;
  }
  base->setName(name);
  base->setTransform(make_transform(g.index_to_world));
  base->setSaveFloatAsHalf(false);
  return base;
}

}  // namespace

void write_vdb(const std::string& path, const std::vector<VdbGrid>& grids,
               const std::vector<std::pair<std::string, std::string>>& file_metadata) {
  std::set<std::string> names;
  for (size_t n = 0; n < grids.size(); ++n) {
    const std::string name = grids[n].name.empty() ? grids[n].volume.name : grids[n].name;
    check_grid(path, n, grids[n], name);
    if (!names.insert(name).second)
      throw Error(grid_label(path, n, name) + ": duplicate name: grid names must be unique");
  }
  openvdb::initialize();  // registers the grid, map and metadata types; safe to call again

  openvdb::MetaMap meta;
  for (const auto& [key, value] : file_metadata)
    meta.insertMeta(key, openvdb::StringMetadata(value));
  openvdb::GridPtrVec out;
  for (size_t n = 0; n < grids.size(); ++n) {
    const std::string name = grids[n].name.empty() ? grids[n].volume.name : grids[n].name;
    openvdb::GridBase::Ptr grid = make_grid(grids[n], name);
    for (const auto& [key, value] : file_metadata)
      grid->insertMeta(key, openvdb::StringMetadata(value));
    out.push_back(grid);
  }

  // io::File writes to a path itself (seekable, with the grid offsets readers use for delayed
  // loading), so the file goes to a temporary beside the target and is renamed over it.
  static std::atomic<unsigned> counter{0};
  const std::string temp =
      path + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
  try {
    openvdb::io::File file(temp);
    file.setCompression(openvdb::io::COMPRESS_ZIP | openvdb::io::COMPRESS_ACTIVE_MASK);
    file.write(out, meta);
    file.close();
    std::filesystem::rename(temp, path);
  } catch (const std::exception& e) {
    std::error_code ignored;
    std::filesystem::remove(temp, ignored);
    throw Error(path + ": cannot write OpenVDB file: " + e.what());
  }
}

}  // namespace raywarp
