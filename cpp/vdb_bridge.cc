// File I/O and grid transfer for activeskin's OpenVDB bridge (see src/io/vdb/ffi.rs).
#include "activeskin/cpp/vdb_impl.h"

#include <openvdb/io/File.h>
#include <openvdb/tree/LeafManager.h>
#include <tbb/parallel_for.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/Prune.h>

#include <dlfcn.h>
#include <link.h>

#include <cstring>
#include <mutex>
#include <sstream>

#include "activeskin/src/io/vdb/ffi.rs.h"

namespace activeskin {
namespace bridge {

using openvdb::Coord;
using openvdb::FloatTree;
using LeafT = FloatTree::LeafNodeType;
constexpr size_t kLeafVoxels = LeafT::SIZE;           // 512
constexpr size_t kMaskWords = LeafT::NodeMaskType::WORD_COUNT;  // 8

// OpenVDB's own log: Debian builds OpenVDB with log4cplus, whose appender writes its
// WARN lines to stdout with colour codes, into `info`'s listing and every pipe. They are
// sent to stderr instead, plain. log4cplus's headers do not come with OpenVDB's, so its C
// API is looked up in the process, where OpenVDB loaded it: nothing is linked that a
// build without log4cplus would lack.
static const char *const kLogToStderr =
    "log4cplus.logger.openvdb=WARN, STDERR\n"
    "log4cplus.additivity.openvdb=false\n"
    "log4cplus.appender.STDERR=log4cplus::ConsoleAppender\n"
    "log4cplus.appender.STDERR.logToStdErr=true\n"
    "log4cplus.appender.STDERR.layout=log4cplus::PatternLayout\n"
    "log4cplus.appender.STDERR.layout.ConversionPattern=OpenVDB %p: %m%n\n";

// Looked up in log4cplus itself, not by name in the whole process: other libraries bundle
// their own copy under the same names (DCMTK's liboflog, loaded by Blender before it,
// takes the configuration for a file name).
static void *log4cplus_library() {
  static void *handle = [] {
    void *found = nullptr;
    dl_iterate_phdr(
        [](struct dl_phdr_info *info, size_t, void *data) {
          if (info->dlpi_name && std::strstr(info->dlpi_name, "/liblog4cplus")) {
            *static_cast<void **>(data) = dlopen(info->dlpi_name, RTLD_LAZY | RTLD_NOLOAD);
            return 1;
          }
          return 0;
        },
        &found);
    return found;
  }();
  return handle;
}

template <typename F>
static F log4cplus_function(const char *name) {
  void *library = log4cplus_library();
  return library ? reinterpret_cast<F>(dlsym(library, name)) : nullptr;
}

void ensure_initialized() {
  static std::once_flag once;
  std::call_once(once, [] {
    openvdb::initialize();
    if (auto configure = log4cplus_function<int (*)(const char *)>("log4cplus_str_configure")) {
      configure(kLogToStderr);
    }
  });
}

bool log_openvdb_warning(rust::Str message) {
  ensure_initialized();
  // log4cplus_logger_log_str(logger, level, message); 30000 is WARN_LOG_LEVEL.
  auto log = log4cplus_function<int (*)(const char *, int, const char *)>(
      "log4cplus_logger_log_str");
  if (!log) return false;
  log("openvdb", 30000, std::string(message).c_str());
  return true;
}

std::unique_ptr<FloatGrid> wrap(openvdb::FloatGrid::Ptr grid) {
  auto impl = std::make_unique<FloatGrid::Impl>();
  impl->grid = std::move(grid);
  return std::make_unique<FloatGrid>(std::move(impl));
}

FloatGrid::FloatGrid(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
FloatGrid::~FloatGrid() = default;

GridClass to_class(openvdb::GridClass c) {
  switch (c) {
    case openvdb::GRID_LEVEL_SET: return GridClass::LevelSet;
    case openvdb::GRID_FOG_VOLUME: return GridClass::FogVolume;
    case openvdb::GRID_STAGGERED: return GridClass::Staggered;
    default: return GridClass::Unknown;
  }
}

openvdb::GridClass from_class(GridClass c) {
  switch (c) {
    case GridClass::LevelSet: return openvdb::GRID_LEVEL_SET;
    case GridClass::FogVolume: return openvdb::GRID_FOG_VOLUME;
    case GridClass::Staggered: return openvdb::GRID_STAGGERED;
    default: return openvdb::GRID_UNKNOWN;
  }
}

bool is_uniform_linear(const openvdb::math::Transform &xf) {
  return xf.isLinear() && xf.hasUniformScale();
}

// A pure uniform scale plus translation is built the way OpenVDB builds its own, so the
// voxel size reads back bit for bit. (A Transform constructed from a map "simplifies" it
// and recovers the scale as (d + t) - t, which loses the last bit.)
openvdb::math::Transform::Ptr make_transform(const openvdb::Mat4d &m) {
  const double d = m(0, 0);
  const bool scale_translate = m(1, 1) == d && m(2, 2) == d && m(0, 1) == 0 && m(0, 2) == 0 &&
                               m(1, 0) == 0 && m(1, 2) == 0 && m(2, 0) == 0 && m(2, 1) == 0;
  if (!scale_translate) return openvdb::math::Transform::createLinearTransform(m);
  auto xf = openvdb::math::Transform::createLinearTransform(d);
  xf->postTranslate(openvdb::Vec3d(m(3, 0), m(3, 1), m(3, 2)));
  return xf;
}

namespace {

bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof(float)) == 0; }

std::array<double, 3> to_array(const openvdb::Vec3d &v) { return {v[0], v[1], v[2]}; }

}  // namespace

// Opens without delayed loading: nothing stays memory-mapped, so the file can be
// overwritten while its grids are alive.
std::unique_ptr<openvdb::io::File> open_file(rust::Str path) {
  ensure_initialized();
  auto file = std::make_unique<openvdb::io::File>(std::string(path));
  file->open(/*delayLoad=*/false);
  return file;
}


rust::Vec<GridSummary> list_grids(rust::Str path) {
  auto file = open_file(path);
  // Grid by grid: one that OpenVDB cannot decode (an attribute codec it does not
  // register, as Mantaflow's int32_trnc) is listed from its metadata with the reason, and
  // hides nothing else.
  openvdb::GridPtrVecPtr metas = file->readAllGridMetadata();
  // Each grid's unique name as printed ("a[1]", "[0]" where names repeat or are empty),
  // in the order of the metadata (both walk the file's descriptors): read by it, a
  // repeated name is that grid and not the first, and OpenVDB has nothing to warn about.
  std::vector<std::string> unique;
  for (auto it = file->beginName(); it != file->endName(); ++it) unique.push_back(it.gridName());
  if (unique.size() != metas->size()) throw openvdb::IoError("inconsistent grid descriptors");
  rust::Vec<GridSummary> out;
  for (size_t i = 0; i < metas->size(); ++i) {
    const auto &meta = (*metas)[i];
    GridSummary s;
    s.name = unique[i];
    s.value_type = meta->valueType();
    s.grid_class = to_class(meta->getGridClass());
    const auto &xf = meta->transform();
    s.voxel_size = to_array(xf.voxelSize());
    s.uniform_linear = is_uniform_linear(xf);
    s.active_voxels = 0;
    s.points = 0;
    s.has_bbox = false;
    s.bbox_min = {0, 0, 0};
    s.bbox_max = {0, 0, 0};
    s.background = "?";
    openvdb::GridBase::Ptr grid;
    try {
      grid = file->readGrid(unique[i]);
    } catch (const std::exception &e) {
      s.error = e.what();
      // What the writer recorded of it (OpenVDB's file_* statistics).
      if (auto count = meta->getMetadata<openvdb::Int64Metadata>("file_voxel_count")) {
        s.active_voxels = static_cast<uint64_t>(count->value());
      }
      auto lo = meta->getMetadata<openvdb::Vec3IMetadata>("file_bbox_min");
      auto hi = meta->getMetadata<openvdb::Vec3IMetadata>("file_bbox_max");
      if (lo && hi && s.active_voxels > 0) {
        const openvdb::CoordBBox box(openvdb::Coord(lo->value()), openvdb::Coord(hi->value()));
        const openvdb::BBoxd world = xf.indexToWorld(box);
        s.has_bbox = true;
        s.bbox_min = to_array(world.min());
        s.bbox_max = to_array(world.max());
      }
      out.push_back(std::move(s));
      continue;
    }
    s.active_voxels = grid->activeVoxelCount();
    s.points = point_count(*grid);
    const openvdb::CoordBBox box = grid->evalActiveVoxelBoundingBox();
    s.has_bbox = s.active_voxels > 0 && !box.empty();
    if (s.has_bbox) {
      const openvdb::BBoxd world = xf.indexToWorld(box);
      s.bbox_min = to_array(world.min());
      s.bbox_max = to_array(world.max());
    }
    std::ostringstream bg;
    const bool known = grid->apply<openvdb::GridTypes>(
        [&bg](const auto &typed) { bg << typed.background(); });
    s.background = known ? bg.str() : "?";
    out.push_back(std::move(s));
  }
  file->close();
  return out;
}

// Reads one float grid with its leaves decompressed on all threads: the file is mapped
// (delayed loading, no private copy), every leaf buffer is loaded in parallel, then the
// file is closed. Once loaded, no leaf refers to the mapping any more, so, as with
// open_file, nothing stays mapped and the file can be overwritten.
static std::unique_ptr<FloatGrid> read_loaded(openvdb::io::File &file, const std::string &name) {
  auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid(name));
  if (!grid) throw openvdb::TypeError("grid '" + name + "' is not a float grid");
  openvdb::tree::LeafManager<const FloatTree> leaves(grid->tree());
  tbb::parallel_for(leaves.leafRange(), [](const auto &range) {
    // Reading a voxel loads the leaf's buffer.
    for (auto leaf = range.begin(); leaf; ++leaf) leaf->getValue(openvdb::Index(0));
  });
  file.close();
  return wrap(grid);
}

std::unique_ptr<FloatGrid> read_float_grid(rust::Str path, rust::Str name) {
  ensure_initialized();
  auto file = std::make_unique<openvdb::io::File>(std::string(path));
  file->setCopyMaxBytes(0);
  file->open(/*delayLoad=*/true);
  std::string wanted(name);
  std::string found_types;
  if (!wanted.empty() && file->hasGrid(wanted)) {
    // By the file's unique name as printed ("a[1]", "[0]": what Rust chose from the
    // layout), which OpenVDB's lookup resolves where the grids' names repeat or are empty.
    openvdb::GridBase::Ptr meta = file->readGridMetadata(wanted);
    if (meta->valueType() != "float") {
      throw openvdb::TypeError("grid '" + wanted + "' holds " + meta->valueType() +
                               " values, not float");
    }
    return read_loaded(*file, wanted);
  }
  openvdb::GridPtrVecPtr metas = file->readAllGridMetadata();
  for (const auto &meta : *metas) {
    const bool name_ok = wanted.empty() || meta->getName() == wanted;
    if (!name_ok) continue;
    if (meta->valueType() != "float") {
      if (!wanted.empty()) {
        throw openvdb::TypeError("grid '" + wanted + "' holds " + meta->valueType() +
                                 " values, not float");
      }
      continue;
    }
    return read_loaded(*file, meta->getName());
  }
  std::string listing;
  for (const auto &meta : *metas) {
    if (!listing.empty()) listing += ", ";
    listing += "'" + meta->getName() + "' (" + meta->valueType() + ")";
  }
  if (listing.empty()) listing = "none";
  if (!wanted.empty()) {
    throw openvdb::LookupError("no grid named '" + wanted + "' (grids: " + listing + ")");
  }
  throw openvdb::LookupError("no float grid (grids: " + listing + ")");
}

GridHeader FloatGrid::header() const {
  const auto &grid = *impl_->grid;
  GridHeader h;
  h.name = grid.getName();
  h.grid_class = to_class(grid.getGridClass());
  h.background = grid.background();
  const auto &xf = grid.transform();
  h.uniform_linear = is_uniform_linear(xf);
  h.matrix.fill(0.0);
  if (xf.isLinear()) {
    const openvdb::Mat4d m = xf.baseMap()->getAffineMap()->getMat4();
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) h.matrix[r * 4 + c] = m(r, c);
  }
  h.leaf_count = grid.tree().leafCount();
  return h;
}

uint64_t FloatGrid::active_voxel_count() const { return impl_->grid->activeVoxelCount(); }

void FloatGrid::copy_leaves(rust::Slice<int32_t> origins, rust::Slice<float> values,
                            rust::Slice<uint64_t> masks) const {
  const auto &tree = impl_->grid->tree();
  const size_t n = tree.leafCount();
  if (origins.size() != 3 * n || values.size() != kLeafVoxels * n ||
      masks.size() != kMaskWords * n) {
    throw openvdb::ValueError("copy_leaves: buffer sizes do not match the leaf count");
  }
  // LeafManager's order is the tree's leaf iteration order, and its position is the index.
  openvdb::tree::LeafManager<const FloatTree> leaves(tree);
  tbb::parallel_for(leaves.leafRange(), [&](const auto &range) {
    for (auto leaf = range.begin(); leaf; ++leaf) {
      const size_t i = leaf.pos();
      const Coord o = leaf->origin();
      origins[3 * i + 0] = o.x();
      origins[3 * i + 1] = o.y();
      origins[3 * i + 2] = o.z();
      std::memcpy(values.data() + kLeafVoxels * i, leaf->buffer().data(),
                  kLeafVoxels * sizeof(float));
      const auto &mask = leaf->getValueMask();
      for (size_t w = 0; w < kMaskWords; ++w)
        masks[kMaskWords * i + w] = mask.template getWord<uint64_t>(w);
    }
  });
}

rust::Vec<Tile> FloatGrid::tiles() const {
  const auto &tree = impl_->grid->tree();
  const float background = tree.background();
  rust::Vec<Tile> out;
  // Inactive background tiles are what an empty slot means anyway: leave them out.
  auto push = [&](const Coord &c, uint32_t dim, float value, bool active) {
    if (!active && same_bits(value, background)) return;
    out.push_back(Tile{{c.x(), c.y(), c.z()}, dim, value, active});
  };
  const auto &root = tree.root();
  using Int2 = FloatTree::RootNodeType::ChildNodeType;
  using Int1 = Int2::ChildNodeType;
  for (auto t = root.cbeginValueAll(); t; ++t) push(t.getCoord(), Int2::DIM, *t, t.isValueOn());
  for (auto n2 = root.cbeginChildOn(); n2; ++n2) {
    for (auto t = n2->cbeginValueAll(); t; ++t) push(t.getCoord(), Int1::DIM, *t, t.isValueOn());
    for (auto n1 = n2->cbeginChildOn(); n1; ++n1) {
      for (auto t = n1->cbeginValueAll(); t; ++t)
        push(t.getCoord(), LeafT::DIM, *t, t.isValueOn());
    }
  }
  return out;
}

void FloatGrid::prune_level_set() { openvdb::tools::pruneLevelSet(impl_->grid->tree()); }

std::unique_ptr<FloatGrid> new_float_grid(const GridHeader &header,
                                          rust::Slice<const int32_t> origins,
                                          rust::Slice<const float> values,
                                          rust::Slice<const uint64_t> masks,
                                          rust::Slice<const Tile> tiles) {
  ensure_initialized();
  const size_t n = origins.size() / 3;
  if (origins.size() % 3 != 0 || values.size() != kLeafVoxels * n ||
      masks.size() != kMaskWords * n) {
    throw openvdb::ValueError("leaf arrays disagree: " + std::to_string(origins.size()) +
                              " origin coordinates, " + std::to_string(values.size()) +
                              " values, " + std::to_string(masks.size()) + " mask words");
  }
  const auto &m = header.matrix;
  if (m[3] != 0.0 || m[7] != 0.0 || m[11] != 0.0 || m[15] != 1.0) {
    throw openvdb::ValueError("transform matrix is not affine");
  }
  openvdb::Mat4d mat;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) mat(r, c) = m[r * 4 + c];

  auto grid = openvdb::FloatGrid::create(header.background);
  grid->setName(std::string(header.name));
  grid->setGridClass(from_class(header.grid_class));
  grid->setTransform(make_transform(mat));

  auto &tree = grid->tree();
  for (const Tile &t : tiles) {
    openvdb::Index level;
    switch (t.dim) {
      case LeafT::DIM: level = 1; break;
      case FloatTree::RootNodeType::ChildNodeType::ChildNodeType::DIM: level = 2; break;
      case FloatTree::RootNodeType::ChildNodeType::DIM: level = 3; break;
      default: throw openvdb::ValueError("tile of unsupported size " + std::to_string(t.dim));
    }
    const Coord c(t.origin[0], t.origin[1], t.origin[2]);
    if ((c.x() | c.y() | c.z()) & int32_t(t.dim - 1)) {
      throw openvdb::ValueError("tile origin not aligned to its size");
    }
    tree.addTile(level, c, t.value, t.active);
  }
  for (size_t i = 0; i < n; ++i) {
    const Coord c(origins[3 * i], origins[3 * i + 1], origins[3 * i + 2]);
    if ((c.x() | c.y() | c.z()) & int32_t(LeafT::DIM - 1)) {
      throw openvdb::ValueError("leaf origin not aligned to 8");
    }
    auto leaf = std::make_unique<LeafT>(c, header.background, false);
    std::memcpy(leaf->buffer().data(), values.data() + kLeafVoxels * i,
                kLeafVoxels * sizeof(float));
    auto &mask = leaf->getValueMask();
    for (size_t w = 0; w < kMaskWords; ++w)
      mask.template getWord<uint64_t>(w) = masks[kMaskWords * i + w];
    tree.addLeaf(leaf.release());
  }
  return wrap(grid);
}

std::unique_ptr<FloatGrid> make_level_set_sphere(float radius, std::array<float, 3> center,
                                                 float voxel_size, float half_width) {
  ensure_initialized();
  auto grid = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(
      radius, openvdb::Vec3f(center[0], center[1], center[2]), voxel_size, half_width);
  grid->setName("surface");
  return wrap(grid);
}

// ---- writing ----

GridWriter::GridWriter() : impl_(std::make_unique<Impl>()) {}
GridWriter::~GridWriter() = default;

std::unique_ptr<GridWriter> new_grid_writer() {
  ensure_initialized();
  return std::make_unique<GridWriter>();
}

void GridWriter::add(const FloatGrid &grid, bool half_float) {
  // Shallow copy: shares the tree, but carries its own half-float flag. The transform is
  // shared too: copying one goes through Transform's lossy constructor.
  const auto &source = grid.impl().grid;
  openvdb::FloatGrid::Ptr copy = source->copy();
  copy->setTransform(openvdb::ConstPtrCast<openvdb::math::Transform>(source->constTransformPtr()));
  copy->setSaveFloatAsHalf(half_float);
  impl_->grids.push_back(copy);
}

void GridWriter::write(rust::Str path, const FileMetadata &metadata) const {
  openvdb::MetaMap meta;
  meta.insertMeta("creator", openvdb::StringMetadata(std::string(metadata.creator)));
  if (metadata.has_frame) {
    meta.insertMeta("frame", openvdb::Int64Metadata(metadata.frame));
  }
  openvdb::io::File file{std::string(path)};
  // Blosc where this OpenVDB has it (as Houdini writes), else zip; inactive values that
  // equal the background are dropped either way.
  file.setCompression(openvdb::io::COMPRESS_ACTIVE_MASK |
                      (openvdb::io::Archive::hasBloscCompression() ? openvdb::io::COMPRESS_BLOSC
                                                                   : openvdb::io::COMPRESS_ZIP));
  file.write(impl_->grids, meta);
  file.close();
}

void write_vector_grid_file(rust::Str path) {
  ensure_initialized();
  auto grid = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.0f));
  grid->setName("v");
  grid->tree().setValue(Coord(1, 2, 3), openvdb::Vec3s(1.0f, 2.0f, 3.0f));
  openvdb::io::File file{std::string(path)};
  file.write({grid});
  file.close();
}

}  // namespace bridge
}  // namespace activeskin
