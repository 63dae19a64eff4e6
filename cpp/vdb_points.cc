// OpenVDB point data grids (what Houdini's VDB from Points writes): positions and pscale
// out to flat arrays for the particle reader; a writer for tests and the sample data.
// Kept apart so the points headers compile in their own translation unit.
#include "activeskin/cpp/vdb_impl.h"

#include <openvdb/points/PointAttribute.h>
#include <openvdb/points/PointConversion.h>
#include <openvdb/points/PointCount.h>
#include <openvdb/points/PointDataGrid.h>

#include "activeskin/src/io/vdb/ffi.rs.h"

namespace activeskin {
namespace bridge {

namespace {
bool is_point_grid(const openvdb::GridBase &meta) {
  return meta.isType<openvdb::points::PointDataGrid>();
}
}  // namespace

uint64_t point_count(const openvdb::GridBase &grid) {
  const auto *points = dynamic_cast<const openvdb::points::PointDataGrid *>(&grid);
  return points ? openvdb::points::pointCount(points->tree()) : 0;
}

PointBuffers read_points(rust::Str path, rust::Str name) {
  auto file = open_file(path);
  const std::string wanted(name);
  openvdb::GridPtrVecPtr metas = file->readAllGridMetadata();
  std::string listing;
  openvdb::GridBase::Ptr base;
  for (const auto &meta : *metas) {
    if (!listing.empty()) listing += ", ";
    listing += "'" + meta->getName() + "' (" + meta->valueType() + ")";
    if (base || !(wanted.empty() || meta->getName() == wanted)) continue;
    if (!is_point_grid(*meta)) {
      if (!wanted.empty()) {
        throw openvdb::TypeError("grid '" + wanted + "' is a " + meta->valueType() +
                                 " grid, not a point data grid");
      }
      continue;
    }
    base = file->readGrid(meta->getName());
  }
  file->close();
  if (!base) {
    if (listing.empty()) listing = "none";
    throw openvdb::LookupError((wanted.empty() ? std::string("no point data grid")
                                               : "no grid named '" + wanted + "'") +
                               " (grids: " + listing + ")");
  }
  auto grid = openvdb::gridPtrCast<openvdb::points::PointDataGrid>(base);
  if (!grid) throw openvdb::TypeError("grid '" + base->getName() + "' is not a point grid");
  const auto &xf = grid->transform();

  const std::string grid_name = grid->getName();
  PointBuffers out;
  out.grid_name = grid_name;
  out.has_radius = false;
  out.has_velocity = false;
  bool first = true;
  for (auto leaf = grid->tree().cbeginLeaf(); leaf; ++leaf) {
    const auto &descriptor = leaf->attributeSet().descriptor();
    const size_t p = descriptor.find("P");
    if (p == openvdb::points::AttributeSet::INVALID_POS) {
      throw openvdb::KeyError("grid '" + grid_name + "' has no P attribute");
    }
    const size_t pscale = descriptor.find("pscale");
    const bool has_radius = pscale != openvdb::points::AttributeSet::INVALID_POS &&
                            descriptor.valueType(pscale) == "float";
    const size_t v = descriptor.find("v");
    const bool has_velocity = v != openvdb::points::AttributeSet::INVALID_POS &&
                              descriptor.valueType(v) == "vec3s";
    if (first) {
      out.has_radius = has_radius;
      out.has_velocity = has_velocity;
      first = false;
    } else if (has_radius != out.has_radius) {
      throw openvdb::KeyError("grid '" + grid_name + "' has pscale on some leaves only");
    } else if (has_velocity != out.has_velocity) {
      throw openvdb::KeyError("grid '" + grid_name + "' has v on some leaves only");
    }
    openvdb::points::AttributeHandle<openvdb::Vec3f> position(leaf->constAttributeArray(p));
    std::unique_ptr<openvdb::points::AttributeHandle<float>> radius;
    if (has_radius) {
      radius = std::make_unique<openvdb::points::AttributeHandle<float>>(
          leaf->constAttributeArray(pscale));
    }
    std::unique_ptr<openvdb::points::AttributeHandle<openvdb::Vec3f>> velocity;
    if (has_velocity) {
      velocity = std::make_unique<openvdb::points::AttributeHandle<openvdb::Vec3f>>(
          leaf->constAttributeArray(v));
    }
    for (auto voxel = leaf->cbeginValueAll(); voxel; ++voxel) {
      const openvdb::Vec3d ijk = voxel.getCoord().asVec3d();
      for (auto index = leaf->beginIndexVoxel(voxel.getCoord()); index; ++index) {
        const openvdb::Vec3d world = xf.indexToWorld(ijk + position.get(*index));
        out.positions.push_back(static_cast<float>(world[0]));
        out.positions.push_back(static_cast<float>(world[1]));
        out.positions.push_back(static_cast<float>(world[2]));
        if (radius) out.radii.push_back(radius->get(*index));
        if (velocity) {
          const openvdb::Vec3f u = velocity->get(*index);
          out.velocities.push_back(u[0]);
          out.velocities.push_back(u[1]);
          out.velocities.push_back(u[2]);
        }
      }
    }
  }
  return out;
}

namespace {

openvdb::points::PointDataGrid::Ptr make_points(rust::Slice<const float> positions,
                                                rust::Slice<const float> radii,
                                                rust::Slice<const float> velocities,
                                                double voxel_size, rust::Str name) {
  ensure_initialized();
  if (positions.size() % 3 != 0) {
    throw openvdb::ValueError("positions must hold whole points");
  }
  const size_t n = positions.size() / 3;
  if (!radii.empty() && radii.size() != n) {
    throw openvdb::ValueError("one radius per point, or none");
  }
  if (!velocities.empty() && velocities.size() != 3 * n) {
    throw openvdb::ValueError("one velocity per point, or none");
  }
  std::vector<openvdb::Vec3f> points(n);
  for (size_t i = 0; i < n; ++i) {
    points[i] = openvdb::Vec3f(positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]);
  }
  auto xf = openvdb::math::Transform::createLinearTransform(voxel_size);
  // As Houdini writes them by default: positions relative to their voxel, 16-bit fixed
  // point.
  openvdb::points::PointAttributeVector<openvdb::Vec3f> wrapper(points);
  auto index = openvdb::tools::createPointIndexGrid<openvdb::tools::PointIndexGrid>(wrapper, *xf);
  auto grid = openvdb::points::createPointDataGrid<openvdb::points::FixedPointCodec<false>,
                                                   openvdb::points::PointDataGrid>(
      *index, wrapper, *xf);
  if (!radii.empty()) {
    std::vector<float> r(radii.begin(), radii.end());
    openvdb::points::appendAttribute<float>(grid->tree(), "pscale");
    openvdb::points::populateAttribute(grid->tree(), index->tree(), "pscale",
                                       openvdb::points::PointAttributeVector<float>(r));
  }
  if (!velocities.empty()) {
    std::vector<openvdb::Vec3f> u(n);
    for (size_t i = 0; i < n; ++i) {
      u[i] = openvdb::Vec3f(velocities[3 * i], velocities[3 * i + 1], velocities[3 * i + 2]);
    }
    openvdb::points::appendAttribute<openvdb::Vec3f>(grid->tree(), "v");
    openvdb::points::populateAttribute(grid->tree(), index->tree(), "v",
                                       openvdb::points::PointAttributeVector<openvdb::Vec3f>(u));
  }
  grid->setName(std::string(name));
  return grid;
}

}  // namespace

void write_points(rust::Str path, rust::Slice<const float> positions,
                  rust::Slice<const float> radii, rust::Slice<const float> velocities,
                  double voxel_size, rust::Str name) {
  auto grid = make_points(positions, radii, velocities, voxel_size, name);
  openvdb::io::File file{std::string(path)};
  file.write({grid});
  file.close();
}

void write_points_beside(rust::Str path, rust::Slice<const float> positions,
                         double voxel_size, rust::Str name, const FloatGrid &beside) {
  auto grid = make_points(positions, {}, {}, voxel_size, name);
  openvdb::io::File file{std::string(path)};
  file.write({beside.impl().grid, grid});
  file.close();
}

}  // namespace bridge
}  // namespace activeskin
