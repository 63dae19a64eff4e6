// OpenVDB point data grids (what Houdini's VDB from Points writes): positions and pscale
// out to flat arrays for the particle reader; a writer for tests and the sample data.
// Kept apart so the points headers compile in their own translation unit.
#include "activeskin/cpp/vdb_impl.h"

#include <algorithm>

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

namespace {
// A leaf's values of one attribute, visited as the positions are (voxel by voxel, index
// order), appended as floats.
template <typename T>
void append_values(const openvdb::points::PointDataTree::LeafNodeType &leaf,
                   const openvdb::points::AttributeArray &array, std::vector<float> &out) {
  openvdb::points::AttributeHandle<T> handle(array);
  for (auto voxel = leaf.cbeginValueAll(); voxel; ++voxel) {
    for (auto index = leaf.beginIndexVoxel(voxel.getCoord()); index; ++index) {
      const T value = handle.get(*index);
      if constexpr (openvdb::VecTraits<T>::IsVec) {
        for (int k = 0; k < 3; ++k) out.push_back(static_cast<float>(value[k]));
      } else {
        out.push_back(static_cast<float>(value));
      }
    }
  }
}

template <typename T>
void append_ids(const openvdb::points::PointDataTree::LeafNodeType &leaf, size_t position,
                rust::Vec<int64_t> &out) {
  openvdb::points::AttributeHandle<T> handle(leaf.constAttributeArray(position));
  for (auto voxel = leaf.cbeginValueAll(); voxel; ++voxel) {
    for (auto index = leaf.beginIndexVoxel(voxel.getCoord()); index; ++index) {
      out.push_back(static_cast<int64_t>(handle.get(*index)));
    }
  }
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
  // The attributes read besides P, pscale and v: `id`, and those of one or three numbers
  // (as floats), in the descriptor's order; every leaf shares the descriptor.
  struct Column {
    std::string name;
    size_t position;
    std::string type;
    uint32_t components;
    std::vector<float> values;
  };
  std::vector<Column> columns;
  std::string id_type;
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
    const size_t id = descriptor.find("id");
    const std::string leaf_id_type =
        id == openvdb::points::AttributeSet::INVALID_POS ? "" : descriptor.valueType(id);
    if (first) {
      out.has_radius = has_radius;
      out.has_velocity = has_velocity;
      id_type = leaf_id_type == "int32" || leaf_id_type == "int64" ? leaf_id_type : "";
      std::vector<std::pair<size_t, std::string>> ordered;
      for (const auto &[name, position] : descriptor.map()) ordered.emplace_back(position, name);
      std::sort(ordered.begin(), ordered.end());
      for (const auto &[position, name] : ordered) {
        if (name == "P" || (name == "pscale" && has_radius) || (name == "v" && has_velocity) ||
            (name == "id" && !id_type.empty())) {
          continue;
        }
        const std::string type = descriptor.valueType(position);
        uint32_t components = 0;
        if (type == "float" || type == "double" || type == "int32") components = 1;
        if (type == "vec3s" || type == "vec3d" || type == "vec3i") components = 3;
        if (components > 0) columns.push_back({name, position, type, components, {}});
      }
      first = false;
    } else if (has_radius != out.has_radius) {
      throw openvdb::KeyError("grid '" + grid_name + "' has pscale on some leaves only");
    } else if (has_velocity != out.has_velocity) {
      throw openvdb::KeyError("grid '" + grid_name + "' has v on some leaves only");
    }
    for (const auto &column : columns) {
      const size_t at = descriptor.find(column.name);
      if (at != column.position || descriptor.valueType(at) != column.type) {
        throw openvdb::KeyError("grid '" + grid_name + "' has " + column.name +
                                " on some leaves only");
      }
    }
    if (!id_type.empty() && leaf_id_type != id_type) {
      throw openvdb::KeyError("grid '" + grid_name + "' has id on some leaves only");
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
    // The other attributes, in the same order as the positions (index order per voxel).
    if (id_type == "int32") append_ids<int32_t>(*leaf, id, out.attributes.ids);
    if (id_type == "int64") append_ids<int64_t>(*leaf, id, out.attributes.ids);
    for (auto &column : columns) {
      const auto &array = leaf->constAttributeArray(column.position);
      if (column.type == "float") append_values<float>(*leaf, array, column.values);
      if (column.type == "double") append_values<double>(*leaf, array, column.values);
      if (column.type == "int32") append_values<int32_t>(*leaf, array, column.values);
      if (column.type == "vec3s") append_values<openvdb::Vec3f>(*leaf, array, column.values);
      if (column.type == "vec3d") append_values<openvdb::Vec3d>(*leaf, array, column.values);
      if (column.type == "vec3i") append_values<openvdb::Vec3i>(*leaf, array, column.values);
    }
  }
  for (const auto &column : columns) {
    out.attributes.names.push_back(rust::String(column.name));
    out.attributes.components.push_back(column.components);
    for (float x : column.values) out.attributes.values.push_back(x);
  }
  return out;
}

namespace {

openvdb::points::PointDataGrid::Ptr make_points(rust::Slice<const float> positions,
                                                rust::Slice<const float> radii,
                                                rust::Slice<const float> velocities,
                                                const PointAttributes *attributes,
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
  if (attributes) {
    if (!attributes->ids.empty()) {
      if (attributes->ids.size() != n) throw openvdb::ValueError("one id per point, or none");
      std::vector<int64_t> ids(attributes->ids.begin(), attributes->ids.end());
      openvdb::points::appendAttribute<int64_t>(grid->tree(), "id");
      openvdb::points::populateAttribute(grid->tree(), index->tree(), "id",
                                         openvdb::points::PointAttributeVector<int64_t>(ids));
    }
    if (attributes->names.size() != attributes->components.size()) {
      throw openvdb::ValueError("a component count per attribute");
    }
    size_t at = 0;
    for (size_t k = 0; k < attributes->names.size(); ++k) {
      const std::string attribute(attributes->names[k]);
      const uint32_t c = attributes->components[k];
      if ((c != 1 && c != 3) || at + c * n > attributes->values.size()) {
        throw openvdb::ValueError("attribute " + attribute + ": 1 or 3 values per point");
      }
      if (c == 1) {
        std::vector<float> values(attributes->values.begin() + at,
                                  attributes->values.begin() + at + n);
        openvdb::points::appendAttribute<float>(grid->tree(), attribute);
        openvdb::points::populateAttribute(grid->tree(), index->tree(), attribute,
                                           openvdb::points::PointAttributeVector<float>(values));
      } else {
        std::vector<openvdb::Vec3f> values(n);
        for (size_t i = 0; i < n; ++i) {
          const float *x = attributes->values.data() + at + 3 * i;
          values[i] = openvdb::Vec3f(x[0], x[1], x[2]);
        }
        openvdb::points::appendAttribute<openvdb::Vec3f>(grid->tree(), attribute);
        openvdb::points::populateAttribute(
            grid->tree(), index->tree(), attribute,
            openvdb::points::PointAttributeVector<openvdb::Vec3f>(values));
      }
      at += c * n;
    }
  }
  grid->setName(std::string(name));
  return grid;
}

}  // namespace

void write_points(rust::Str path, rust::Slice<const float> positions,
                  rust::Slice<const float> radii, rust::Slice<const float> velocities,
                  const PointAttributes &attributes, double voxel_size, rust::Str name) {
  auto grid = make_points(positions, radii, velocities, &attributes, voxel_size, name);
  openvdb::io::File file{std::string(path)};
  file.write({grid});
  file.close();
}

void write_points_beside(rust::Str path, rust::Slice<const float> positions,
                         double voxel_size, rust::Str name, const FloatGrid &beside) {
  auto grid = make_points(positions, {}, {}, nullptr, voxel_size, name);
  openvdb::io::File file{std::string(path)};
  file.write({beside.impl().grid, grid});
  file.close();
}

}  // namespace bridge
}  // namespace activeskin
