// OpenVDB tools used to validate activeskin: volumeToMesh, LevelSetMeasure, checkLevelSet.
// Kept apart from vdb_bridge.cc so the two heavy translation units compile in parallel.
#include "activeskin/cpp/vdb_impl.h"

#include <openvdb/tools/Diagnostics.h>
#include <openvdb/tools/LevelSetAdvect.h>
#include <openvdb/tools/LevelSetFilter.h>
#include <openvdb/tools/LevelSetMeasure.h>
#include <openvdb/tools/LevelSetMorph.h>

#include <chrono>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/VolumeToMesh.h>

#include "activeskin/src/io/vdb/ffi.rs.h"

namespace activeskin {
namespace bridge {

MeshBuffers volume_to_mesh(const FloatGrid &handle, double isovalue, double adaptivity) {
  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec3I> triangles;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(*handle.impl().grid, points, triangles, quads, isovalue,
                               adaptivity);
  MeshBuffers out;
  out.points.reserve(3 * points.size());
  for (const auto &p : points) {
    out.points.push_back(p[0]);
    out.points.push_back(p[1]);
    out.points.push_back(p[2]);
  }
  out.triangles.reserve(3 * triangles.size());
  for (const auto &t : triangles)
    for (int k = 0; k < 3; ++k) out.triangles.push_back(t[k]);
  out.quads.reserve(4 * quads.size());
  for (const auto &q : quads)
    for (int k = 0; k < 4; ++k) out.quads.push_back(q[k]);
  return out;
}

LevelSetMeasures measure_level_set(const FloatGrid &handle) {
  const auto &grid = *handle.impl().grid;
  if (grid.getGridClass() != openvdb::GRID_LEVEL_SET) {
    throw openvdb::TypeError("LevelSetMeasure needs a grid of class level set");
  }
  openvdb::tools::LevelSetMeasure<openvdb::FloatGrid> measure(grid);
  LevelSetMeasures m;
  m.area = measure.area(true);
  m.volume = measure.volume(true);
  m.mean_curvature = measure.avgMeanCurvature(true);
  m.euler_characteristic = measure.eulerCharacteristic();
  m.genus = measure.genus();
  return m;
}

std::unique_ptr<FloatGrid> mesh_to_level_set(rust::Slice<const float> points,
                                             rust::Slice<const uint32_t> triangles,
                                             double voxel_size, float half_width) {
  if (points.size() % 3 != 0 || triangles.size() % 3 != 0) {
    throw openvdb::ValueError("mesh buffers must hold whole points and triangles");
  }
  const auto transform = openvdb::math::Transform::createLinearTransform(voxel_size);
  std::vector<openvdb::Vec3s> world_points;
  world_points.reserve(points.size() / 3);
  for (size_t i = 0; i < points.size(); i += 3) {
    world_points.emplace_back(points[i], points[i + 1], points[i + 2]);
  }
  std::vector<openvdb::Vec3I> faces;
  faces.reserve(triangles.size() / 3);
  for (size_t i = 0; i < triangles.size(); i += 3) {
    for (size_t k = 0; k < 3; ++k) {
      if (triangles[i + k] >= world_points.size()) {
        throw openvdb::IndexError("triangle refers to a missing point");
      }
    }
    faces.emplace_back(triangles[i], triangles[i + 1], triangles[i + 2]);
  }
  std::vector<openvdb::Vec4I> quads;
  auto grid = openvdb::tools::meshToLevelSet<openvdb::FloatGrid>(*transform, world_points, faces,
                                                                 quads, half_width);
  grid->setName("surface");
  return wrap(grid);
}

namespace {
// Times `work` (which returns its iteration count) on `grid`.
template <typename Work>
MorphTiming timed(const openvdb::FloatGrid &grid, Work &&work) {
  const auto start = std::chrono::steady_clock::now();
  const size_t iterations = work();
  const std::chrono::duration<double> elapsed = std::chrono::steady_clock::now() - start;
  MorphTiming t;
  t.seconds = elapsed.count();
  t.iterations = iterations;
  t.active_voxels = grid.activeVoxelCount();
  return t;
}

MorphTiming morph(openvdb::FloatGrid &grid, const openvdb::FloatGrid &target, double duration) {
  return timed(grid, [&] {
    openvdb::tools::LevelSetMorphing<openvdb::FloatGrid> morph(grid, target);
    return morph.advect(0.0f, static_cast<float>(duration));
  });
}
}  // namespace

MorphTiming morph_timing(const FloatGrid &source, const FloatGrid &target, double duration) {
  auto copy = source.impl().grid->deepCopy();
  return morph(*copy, *target.impl().grid, duration);
}

MorphTiming morph_advance(FloatGrid &grid, const FloatGrid &target, double duration) {
  return morph(*grid.impl().grid, *target.impl().grid, duration);
}

namespace {
// A rigid rotation about the z axis through the origin, in world space, for
// LevelSetAdvection (which samples it through the grid's transform).
struct RotationField {
  using ValueType = double;
  using VectorType = openvdb::Vec3d;
  double omega;
  openvdb::math::Transform transform() const { return openvdb::math::Transform(); }
  VectorType operator()(const openvdb::Vec3d &xyz, ValueType) const {
    return VectorType(-omega * xyz[1], omega * xyz[0], 0.0);
  }
  VectorType operator()(const openvdb::Coord &ijk, ValueType t) const {
    return (*this)(ijk.asVec3d(), t);
  }
};
}  // namespace

MorphTiming advect_rotation(FloatGrid &handle, double omega, double duration) {
  auto &grid = *handle.impl().grid;
  if (grid.getGridClass() != openvdb::GRID_LEVEL_SET) {
    throw openvdb::TypeError("advection needs a grid of class level set");
  }
  return timed(grid, [&] {
    RotationField field{omega};
    openvdb::tools::LevelSetAdvection<openvdb::FloatGrid, RotationField> advect(grid, field);
    return advect.advect(0.0, duration);
  });
}

MorphTiming mean_curvature_flow(FloatGrid &handle, uint32_t iterations) {
  auto &grid = *handle.impl().grid;
  if (grid.getGridClass() != openvdb::GRID_LEVEL_SET) {
    throw openvdb::TypeError("mean-curvature flow needs a grid of class level set");
  }
  return timed(grid, [&] {
    openvdb::tools::LevelSetFilter<openvdb::FloatGrid> filter(grid);
    for (uint32_t i = 0; i < iterations; ++i) filter.meanCurvature();
    return static_cast<size_t>(iterations);
  });
}

uint64_t mem_usage(const FloatGrid &grid) { return grid.impl().grid->memUsage(); }

rust::String check_level_set(const FloatGrid &handle) {
  return rust::String(openvdb::tools::checkLevelSet(*handle.impl().grid));
}

}  // namespace bridge
}  // namespace activeskin
