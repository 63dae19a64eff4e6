// Thin C++ side of activeskin's OpenVDB bridge. No OpenVDB type appears here: grids are
// pimpl handles, data crosses as flat arrays. Declarations match src/io/vdb/ffi.rs.
#pragma once

#include <array>
#include <cstdint>
#include <exception>
#include <memory>

#include "rust/cxx.h"

// cxx turns a std::exception thrown by a `Result` function into an Err with its what();
// this also converts anything else that might be thrown, so nothing crosses unconverted.
namespace rust {
namespace behavior {
template <typename Try, typename Fail>
static void trycatch(Try &&func, Fail &&fail) noexcept try {
  func();
} catch (const std::exception &e) {
  fail(e.what());
} catch (...) {
  fail("unknown C++ exception");
}
}  // namespace behavior
}  // namespace rust

namespace activeskin {
namespace bridge {

enum class GridClass : ::std::uint8_t;
struct GridSummary;
struct GridHeader;
struct Tile;
struct MeshBuffers;
struct LevelSetMeasures;
struct MorphTiming;
struct FileMetadata;
struct PointBuffers;
struct PointAttributes;
struct VectorBuffers;

class FloatGrid {
 public:
  struct Impl;
  explicit FloatGrid(std::unique_ptr<Impl> impl);
  ~FloatGrid();

  GridHeader header() const;
  uint64_t active_voxel_count() const;
  void copy_leaves(rust::Slice<int32_t> origins, rust::Slice<float> values,
                   rust::Slice<uint64_t> masks) const;
  rust::Vec<Tile> tiles() const;
  void prune_level_set();

  const Impl &impl() const { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

class GridWriter {
 public:
  struct Impl;
  GridWriter();
  ~GridWriter();

  void add(const FloatGrid &grid, bool half_float);
  void add_vectors(rust::Str name, bool staggered, double voxel_size,
                   rust::Slice<const int32_t> coords, rust::Slice<const float> values,
                   bool half_float);
  void write(rust::Str path, const FileMetadata &metadata) const;

 private:
  std::unique_ptr<Impl> impl_;
};

rust::Vec<GridSummary> list_grids(rust::Str path);
bool log_openvdb_warning(rust::Str message);
std::unique_ptr<FloatGrid> read_float_grid(rust::Str path, rust::Str name);
std::unique_ptr<FloatGrid> new_float_grid(const GridHeader &header,
                                          rust::Slice<const int32_t> origins,
                                          rust::Slice<const float> values,
                                          rust::Slice<const uint64_t> masks,
                                          rust::Slice<const Tile> tiles);
std::unique_ptr<FloatGrid> make_level_set_sphere(float radius, std::array<float, 3> center,
                                                 float voxel_size, float half_width);
std::unique_ptr<GridWriter> new_grid_writer();
void write_vector_grid_file(rust::Str path);

MeshBuffers volume_to_mesh(const FloatGrid &grid, double isovalue, double adaptivity);
LevelSetMeasures measure_level_set(const FloatGrid &grid);
MorphTiming morph_timing(const FloatGrid &source, const FloatGrid &target, double duration);
MorphTiming morph_advance(FloatGrid &grid, const FloatGrid &target, double duration);
MorphTiming mean_curvature_flow(FloatGrid &grid, uint32_t iterations);
MorphTiming advect_rotation(FloatGrid &grid, double omega, double duration);
uint64_t mem_usage(const FloatGrid &grid);
PointBuffers read_points(rust::Str path, rust::Str name);
void write_points(rust::Str path, rust::Slice<const float> positions,
                  rust::Slice<const float> radii, rust::Slice<const float> velocities,
                  const PointAttributes &attributes, double voxel_size, rust::Str name);
void write_points_beside(rust::Str path, rust::Slice<const float> positions,
                         double voxel_size, rust::Str name, const FloatGrid &beside);
std::unique_ptr<FloatGrid> mesh_to_level_set(rust::Slice<const float> points,
                                             rust::Slice<const uint32_t> triangles,
                                             double voxel_size, float half_width);
rust::String check_level_set(const FloatGrid &grid);
VectorBuffers read_vector_grid(rust::Str path, rust::Str name);

}  // namespace bridge
}  // namespace activeskin
