// Private to the bridge's .cc files: what the pimpl handles hold. Rust never sees this.
#pragma once

#include <openvdb/openvdb.h>

#include "activeskin/cpp/vdb_bridge.h"

namespace activeskin {
namespace bridge {

struct FloatGrid::Impl {
  openvdb::FloatGrid::Ptr grid;
};

struct GridWriter::Impl {
  openvdb::GridPtrVec grids;
};

GridClass to_class(openvdb::GridClass c);
openvdb::GridClass from_class(GridClass c);
bool is_uniform_linear(const openvdb::math::Transform &xf);
// A uniform scale plus translation built as OpenVDB builds its own (bit-exact voxel size).
openvdb::math::Transform::Ptr make_transform(const openvdb::Mat4d &m);

// openvdb::initialize() exactly once, from whichever entry point runs first.
void ensure_initialized();

// Opens a file for reading, without delayed loading (nothing stays memory-mapped).
std::unique_ptr<openvdb::io::File> open_file(rust::Str path);

// Points held by a point data grid; 0 for any other grid (vdb_points.cc).
uint64_t point_count(const openvdb::GridBase &grid);

// Wraps a grid in a handle (the grid is shared, not copied).
std::unique_ptr<FloatGrid> wrap(openvdb::FloatGrid::Ptr grid);

}  // namespace bridge
}  // namespace activeskin
