// Vector grids (velocities) for activeskin's OpenVDB bridge: read any vec3 grid leaf by
// leaf, write one for fixtures. Collocated and staggered (MAC) grids travel alike; the
// class says which, and Rust samples each component where it lives.
#include "activeskin/cpp/vdb_impl.h"

#include <openvdb/io/File.h>

#include "activeskin/src/io/vdb/ffi.rs.h"

namespace activeskin {
namespace bridge {

namespace {

template <typename GridT>
VectorBuffers copy_vectors(const GridT &grid) {
  using TreeT = typename GridT::TreeType;
  using LeafT = typename TreeT::LeafNodeType;
  VectorBuffers out;
  out.name = grid.getName();
  out.value_type = grid.valueType();
  out.staggered = grid.getGridClass() == openvdb::GRID_STAGGERED;
  const openvdb::Mat4d m = grid.transform().baseMap()->getAffineMap()->getMat4();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out.matrix[4 * r + c] = m(r, c);
  out.uniform_linear = is_uniform_linear(grid.transform());
  const auto bg = grid.background();
  out.background = {float(bg[0]), float(bg[1]), float(bg[2])};
  const TreeT &tree = grid.tree();
  for (auto leaf = tree.cbeginLeaf(); leaf; ++leaf) {
    const openvdb::Coord o = leaf->origin();
    out.origins.push_back(o.x());
    out.origins.push_back(o.y());
    out.origins.push_back(o.z());
    for (openvdb::Index i = 0; i < LeafT::SIZE; ++i) {
      const auto v = leaf->getValue(i);
      out.values.push_back(float(v[0]));
      out.values.push_back(float(v[1]));
      out.values.push_back(float(v[2]));
    }
    const auto &mask = leaf->getValueMask();
    for (openvdb::Index w = 0; w < LeafT::NodeMaskType::WORD_COUNT; ++w)
      out.masks.push_back(mask.template getWord<uint64_t>(w));
  }
  // Active tiles above leaf level: uniform regions of velocity.
  for (auto it = tree.cbeginValueOn(); it; ++it) {
    if (it.isVoxelValue()) continue;
    openvdb::CoordBBox box;
    it.getBoundingBox(box);
    out.tile_origins.push_back(box.min().x());
    out.tile_origins.push_back(box.min().y());
    out.tile_origins.push_back(box.min().z());
    out.tile_dims.push_back(uint32_t(box.dim().x()));
    const auto v = *it;
    out.tile_values.push_back(float(v[0]));
    out.tile_values.push_back(float(v[1]));
    out.tile_values.push_back(float(v[2]));
  }
  return out;
}

}  // namespace

VectorBuffers read_vector_grid(rust::Str path, rust::Str name) {
  auto file = open_file(path);
  const std::string wanted(name);
  openvdb::GridPtrVecPtr metas = file->readAllGridMetadata();
  std::string listing;
  for (const auto &meta : *metas) {
    if (!listing.empty()) listing += ", ";
    listing += "'" + meta->getName() + "' (" + meta->valueType() + ")";
    if (!wanted.empty() && meta->getName() != wanted) continue;
    const std::string type = meta->valueType();
    if (type != "vec3s" && type != "vec3d") {
      if (!wanted.empty())
        throw openvdb::TypeError("grid '" + wanted + "' holds " + type + " values, not vectors");
      continue;
    }
    openvdb::GridBase::Ptr base = file->readGrid(meta->getName());
    file->close();
    if (auto g = openvdb::gridPtrCast<openvdb::Vec3SGrid>(base)) return copy_vectors(*g);
    if (auto g = openvdb::gridPtrCast<openvdb::Vec3DGrid>(base)) return copy_vectors(*g);
    throw openvdb::TypeError("grid '" + meta->getName() + "' is not a vec3s or vec3d grid");
  }
  if (listing.empty()) listing = "none";
  if (!wanted.empty())
    throw openvdb::LookupError("no grid named '" + wanted + "' (grids: " + listing + ")");
  throw openvdb::LookupError("no vector grid (grids: " + listing + ")");
}

void GridWriter::add_vectors(rust::Str name, bool staggered, double voxel_size,
                             rust::Slice<const int32_t> coords, rust::Slice<const float> values,
                             bool half_float) {
  if (coords.size() != values.size())
    throw openvdb::ValueError("add_vectors: one vector per coordinate triple");
  auto grid = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.0f));
  grid->setName(std::string(name));
  grid->setTransform(openvdb::math::Transform::createLinearTransform(voxel_size));
  grid->setGridClass(staggered ? openvdb::GRID_STAGGERED : openvdb::GRID_UNKNOWN);
  // Velocities, staggered or not: displacements per time, which a transform of the grid
  // carries as it carries a displacement (what Houdini gives its `v` and `vel`).
  grid->setVectorType(openvdb::VEC_CONTRAVARIANT_RELATIVE);
  auto accessor = grid->getAccessor();
  for (size_t i = 0; i + 2 < coords.size(); i += 3) {
    accessor.setValue(openvdb::Coord(coords[i], coords[i + 1], coords[i + 2]),
                      openvdb::Vec3s(values[i], values[i + 1], values[i + 2]));
  }
  grid->setSaveFloatAsHalf(half_float);
  impl_->grids.push_back(grid);
}

}  // namespace bridge
}  // namespace activeskin
