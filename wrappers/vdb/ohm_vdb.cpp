// ohm_vdb.cpp — the C API of ohm_vdb.h over OpenVDB (C++17).
//
// This is the only translation unit of ohm that sees OpenVDB.  Every exported
// function body runs inside OHM_VDB_TRY ... OHM_VDB_CATCH(err), so no C++
// exception ever crosses into C: OpenVDB exceptions keep their own message,
// std::bad_alloc becomes OHM_ERR_NOMEM, anything else OHM_ERR_INTERNAL.
// Messages are one line (ohm_fail replaces newlines) and name the file or grid
// they are about.

#include "ohm_vdb.h"

#include <openvdb/Exceptions.h>
#include <openvdb/Metadata.h>
#include <openvdb/io/Archive.h>
#include <openvdb/io/File.h>
#include <openvdb/io/GridDescriptor.h>
#include <openvdb/io/io.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/Prune.h>
#include <openvdb/tools/SignedFloodFill.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <new>
#include <set>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

struct ohm_vdb_grid {
    openvdb::FloatGrid::Ptr grid;
};

// One catch-all per exported function.  `err` may be NULL (ohm_fail allows it).
#define OHM_VDB_TRY try {
#define OHM_VDB_CATCH(err)                                                          \
    }                                                                               \
    catch (const openvdb::Exception &e_) {                                          \
        return ohm_fail((err), OHM_ERR_INTERNAL, "OpenVDB: %s", e_.what());         \
    }                                                                               \
    catch (const std::bad_alloc &) {                                                \
        return ohm_fail((err), OHM_ERR_NOMEM, "OpenVDB: out of memory");            \
    }                                                                               \
    catch (const std::exception &e_) {                                              \
        return ohm_fail((err), OHM_ERR_INTERNAL, "OpenVDB wrapper: %s", e_.what()); \
    }                                                                               \
    catch (...) {                                                                   \
        return ohm_fail((err), OHM_ERR_INTERNAL, "OpenVDB wrapper: unknown exception"); \
    }

namespace {

// Metadata names OpenVDB itself interprets; setting them through the generic
// setters would rename the grid, change its class or break reading it back.
bool reserved_meta_key(const std::string &key)
{
    using openvdb::GridBase;
    return key == GridBase::META_GRID_NAME || key == GridBase::META_GRID_CLASS ||
           key == GridBase::META_IS_LOCAL_SPACE || key == GridBase::META_VECTOR_TYPE ||
           key == GridBase::META_SAVE_HALF_FLOAT;
}

int check_meta_key(const ohm_vdb_grid *g, const char *key, const char *fn, ohm_error *err)
{
    if (!g) return ohm_fail(err, OHM_ERR_INVALID, "%s: NULL grid", fn);
    if (!key || !*key) return ohm_fail(err, OHM_ERR_INVALID, "%s: empty metadata key", fn);
    if (reserved_meta_key(key))
        return ohm_fail(err, OHM_ERR_INVALID, "%s: metadata key '%s' is reserved by OpenVDB", fn,
                        key);
    return OHM_OK;
}

template <typename MetaT, typename V>
void set_meta(openvdb::FloatGrid &grid, const char *key, const V &value)
{
    // insertMeta throws TypeError when the key exists with another type: a
    // setter replaces, whatever the old type was.
    if (grid[key] && !grid.template getMetadata<MetaT>(key)) grid.removeMeta(key);
    grid.insertMeta(key, MetaT(value));
}

openvdb::math::Transform::Ptr make_transform(double voxel_size, const double origin[3])
{
    openvdb::math::Transform::Ptr xf = openvdb::math::Transform::createLinearTransform(voxel_size);
    if (origin) xf->postTranslate(openvdb::Vec3d(origin[0], origin[1], origin[2]));
    return xf;
}

int check_geometry(double voxel_size, const double origin[3], const char *fn, ohm_error *err)
{
    if (!std::isfinite(voxel_size) || voxel_size <= 0.0)
        return ohm_fail(err, OHM_ERR_INVALID, "%s: voxel size %g is not a positive finite number",
                        fn, voxel_size);
    if (origin && !(std::isfinite(origin[0]) && std::isfinite(origin[1]) && std::isfinite(origin[2])))
        return ohm_fail(err, OHM_ERR_INVALID, "%s: origin (%g, %g, %g) is not finite", fn,
                        origin[0], origin[1], origin[2]);
    return OHM_OK;
}

// ohm assumes origin + ijk * voxel_size: a linear map that is a uniform,
// positive scale plus a translation (no rotation, shear or perspective).
bool uniform_scale_translate(const openvdb::math::Transform &xf, double *voxel_size)
{
    if (!xf.isLinear()) return false;
    const openvdb::Mat4d m = xf.baseMap()->getAffineMap()->getMat4();
    const double s = m(0, 0);
    if (!std::isfinite(s) || s <= 0.0) return false;
    const double tol = 1e-9 * s;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
            const double want = r == c ? s : 0.0;
            if (std::fabs(m(r, c) - want) > tol) return false;
        }
    *voxel_size = s;
    return true;
}

// Remove what a failed write left behind -- only if it is a regular file (the
// path could be a device such as /dev/full, or a FIFO).
void remove_partial(const char *path)
{
    struct stat st;
    if (lstat(path, &st) == 0 && S_ISREG(st.st_mode)) std::remove(path);
}

std::string dir_of(const std::string &path)
{
    const std::string::size_type slash = path.find_last_of('/');
    if (slash == std::string::npos) return ".";
    if (slash == 0) return "/";
    return path.substr(0, slash);
}

// A .vdb file written one grid at a time, so that a caller holds one grid's
// tree at a time, not all of them (a scan's 14 grids at 2.7e7 cells are
// ~1.6 GB of trees).  The format is what Archive::write gives for grids of
// distinct names (seekable, no instancing): the header, the file's (empty)
// metadata, the grid count, then each grid's descriptor and data through
// Archive's own writeGrid, with the stream flags Archive::write sets.
// io::File::write also never checks the stream after writing (a full disk
// would go unnoticed); this writer does.
class StreamingWriter : public openvdb::io::Archive {
public:
    void begin(std::ostream &os, int32_t count)
    {
        meta_.reset(new openvdb::io::StreamMetadata);
        openvdb::io::setStreamMetadataPtr(os, meta_, /*transfer=*/false);
        openvdb::io::setDataCompression(os, compression());
        openvdb::io::setWriteGridStatsMetadata(os, isGridStatsMetadataEnabled());
        writeHeader(os, /*seekable=*/true);
        openvdb::MetaMap().writeMeta(os);
        os.write(reinterpret_cast<const char *>(&count), sizeof count);
    }
    void add(std::ostream &os, const openvdb::GridBase::ConstPtr &grid)
    {
        openvdb::io::GridDescriptor gd(grid->getName(), grid->type(), grid->saveFloatAsHalf());
        writeGrid(gd, grid, os, /*seekable=*/true);
        openvdb::io::setDataCompression(os, compression()); // a grid may change it
    }

private:
    openvdb::io::StreamMetadata::Ptr meta_;
};

} // namespace

extern "C" {

int ohm_vdb_init(ohm_error *err)
{
    OHM_VDB_TRY
    openvdb::initialize();
    return OHM_OK;
    OHM_VDB_CATCH(err)
}

int ohm_vdb_grid_create(ohm_vdb_grid **out, const char *name, int grid_class, float background,
                        double voxel_size, const double origin[3], ohm_error *err)
{
    OHM_VDB_TRY
    if (!out) return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_grid_create: NULL output");
    *out = nullptr;
    openvdb::GridClass cls;
    switch (grid_class) {
    case OHM_VDB_CLASS_UNKNOWN: cls = openvdb::GRID_UNKNOWN; break;
    case OHM_VDB_CLASS_LEVEL_SET: cls = openvdb::GRID_LEVEL_SET; break;
    case OHM_VDB_CLASS_FOG_VOLUME: cls = openvdb::GRID_FOG_VOLUME; break;
    default:
        return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_grid_create: unknown grid class %d",
                        grid_class);
    }
    int rc = check_geometry(voxel_size, origin, "ohm_vdb_grid_create", err);
    if (rc) return rc;
    if (!std::isfinite(background))
        return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_grid_create: background %g is not finite",
                        (double)background);
    if (cls == openvdb::GRID_LEVEL_SET && !(background > 0.0f))
        return ohm_fail(err, OHM_ERR_INVALID,
                        "ohm_vdb_grid_create: level-set background %g must be positive "
                        "(the narrow-band half width in world units)",
                        (double)background);
    openvdb::initialize();

    std::unique_ptr<ohm_vdb_grid> g(new ohm_vdb_grid);
    g->grid = openvdb::FloatGrid::create(background);
    g->grid->setTransform(make_transform(voxel_size, origin));
    g->grid->setGridClass(cls);
    g->grid->setName(name ? name : "");
    *out = g.release();
    return OHM_OK;
    OHM_VDB_CATCH(err)
}

void ohm_vdb_grid_free(ohm_vdb_grid *g)
{
    // Destructors of shared_ptr / trees do not throw; the try is belt and braces.
    try {
        delete g;
    } catch (...) {
    }
}

int ohm_vdb_grid_set_values(ohm_vdb_grid *g, const int32_t *ijk, const float *values, size_t n,
                            ohm_error *err)
{
    OHM_VDB_TRY
    if (!g) return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_grid_set_values: NULL grid");
    if (n == 0) return OHM_OK;
    if (!ijk || !values)
        return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_grid_set_values: NULL coordinates or values");
    for (size_t i = 0; i < n; ++i)
        if (!std::isfinite(values[i]))
            return ohm_fail(err, OHM_ERR_NUMERIC,
                            "grid '%s': value %g at voxel (%d, %d, %d) is not finite",
                            g->grid->getName().c_str(), (double)values[i], (int)ijk[3 * i],
                            (int)ijk[3 * i + 1], (int)ijk[3 * i + 2]);
    openvdb::FloatGrid::Accessor acc = g->grid->getAccessor();
    for (size_t i = 0; i < n; ++i)
        acc.setValue(openvdb::Coord(ijk[3 * i], ijk[3 * i + 1], ijk[3 * i + 2]), values[i]);
    return OHM_OK;
    OHM_VDB_CATCH(err)
}

int ohm_vdb_grid_finish_level_set(ohm_vdb_grid *g, ohm_error *err)
{
    OHM_VDB_TRY
    if (!g) return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_grid_finish_level_set: NULL grid");
    if (g->grid->getGridClass() != openvdb::GRID_LEVEL_SET)
        return ohm_fail(err, OHM_ERR_INVALID, "grid '%s' is not a level set",
                        g->grid->getName().c_str());
    openvdb::tools::signedFloodFill(g->grid->tree());
    openvdb::tools::pruneLevelSet(g->grid->tree());
    return OHM_OK;
    OHM_VDB_CATCH(err)
}

int ohm_vdb_grid_prune(ohm_vdb_grid *g, ohm_error *err)
{
    OHM_VDB_TRY
    if (!g) return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_grid_prune: NULL grid");
    openvdb::tools::prune(g->grid->tree());
    return OHM_OK;
    OHM_VDB_CATCH(err)
}

int ohm_vdb_grid_set_meta_string(ohm_vdb_grid *g, const char *key, const char *value,
                                 ohm_error *err)
{
    OHM_VDB_TRY
    int rc = check_meta_key(g, key, "ohm_vdb_grid_set_meta_string", err);
    if (rc) return rc;
    if (!value)
        return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_grid_set_meta_string: NULL value for '%s'",
                        key);
    set_meta<openvdb::StringMetadata>(*g->grid, key, std::string(value));
    return OHM_OK;
    OHM_VDB_CATCH(err)
}

int ohm_vdb_grid_set_meta_double(ohm_vdb_grid *g, const char *key, double value, ohm_error *err)
{
    OHM_VDB_TRY
    int rc = check_meta_key(g, key, "ohm_vdb_grid_set_meta_double", err);
    if (rc) return rc;
    set_meta<openvdb::DoubleMetadata>(*g->grid, key, value);
    return OHM_OK;
    OHM_VDB_CATCH(err)
}

int ohm_vdb_grid_set_meta_int(ohm_vdb_grid *g, const char *key, int64_t value, ohm_error *err)
{
    OHM_VDB_TRY
    int rc = check_meta_key(g, key, "ohm_vdb_grid_set_meta_int", err);
    if (rc) return rc;
    set_meta<openvdb::Int64Metadata>(*g->grid, key, static_cast<openvdb::Int64>(value));
    return OHM_OK;
    OHM_VDB_CATCH(err)
}

int ohm_vdb_grid_get_meta_string(const ohm_vdb_grid *g, const char *key, char *buf, size_t buflen,
                                 ohm_error *err)
{
    OHM_VDB_TRY
    if (!g) return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_grid_get_meta_string: NULL grid");
    if (!key) return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_grid_get_meta_string: NULL key");
    if (!buf || buflen == 0)
        return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_grid_get_meta_string: no buffer");
    buf[0] = '\0';
    const openvdb::FloatGrid &grid = *g->grid;
    openvdb::Metadata::ConstPtr m = grid[key];
    if (!m)
        return ohm_fail(err, OHM_ERR_INVALID, "grid '%s' has no metadata '%s'",
                        grid.getName().c_str(), key);
    openvdb::StringMetadata::ConstPtr s = grid.getMetadata<openvdb::StringMetadata>(key);
    if (!s)
        return ohm_fail(err, OHM_ERR_INVALID, "grid '%s': metadata '%s' is a %s, not a string",
                        grid.getName().c_str(), key, m->typeName().c_str());
    const std::string &v = s->value();
    const size_t len = v.size() < buflen - 1 ? v.size() : buflen - 1;
    std::memcpy(buf, v.data(), len);
    buf[len] = '\0';
    return OHM_OK;
    OHM_VDB_CATCH(err)
}

int ohm_vdb_grid_get_info(const ohm_vdb_grid *g, ohm_vdb_grid_info *out, ohm_error *err)
{
    OHM_VDB_TRY
    if (!g || !out) return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_grid_get_info: NULL argument");
    std::memset(out, 0, sizeof *out);
    const openvdb::FloatGrid &grid = *g->grid;
    const std::string name = grid.getName();
    const size_t len = name.size() < sizeof out->name - 1 ? name.size() : sizeof out->name - 1;
    std::memcpy(out->name, name.data(), len);
    out->name[len] = '\0';
    switch (grid.getGridClass()) {
    case openvdb::GRID_LEVEL_SET: out->grid_class = OHM_VDB_CLASS_LEVEL_SET; break;
    case openvdb::GRID_FOG_VOLUME: out->grid_class = OHM_VDB_CLASS_FOG_VOLUME; break;
    default: out->grid_class = OHM_VDB_CLASS_UNKNOWN; break;
    }
    out->voxel_size = grid.voxelSize()[0];
    const openvdb::Vec3d o = grid.transform().indexToWorld(openvdb::Vec3d(0.0, 0.0, 0.0));
    for (int a = 0; a < 3; ++a) out->origin[a] = o[a];
    out->active_voxels = static_cast<uint64_t>(grid.activeVoxelCount());
    if (out->active_voxels > 0) {
        const openvdb::CoordBBox bb = grid.evalActiveVoxelBoundingBox();
        for (int a = 0; a < 3; ++a) {
            out->bbox_min[a] = bb.min()[a];
            out->bbox_max[a] = bb.max()[a];
        }
    }
    out->background = grid.background();
    return OHM_OK;
    OHM_VDB_CATCH(err)
}

int ohm_vdb_grid_get_value(const ohm_vdb_grid *g, const int32_t ijk[3], float *value,
                           ohm_error *err)
{
    OHM_VDB_TRY
    if (!g || !ijk || !value)
        return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_grid_get_value: NULL argument");
    *value = g->grid->tree().getValue(openvdb::Coord(ijk[0], ijk[1], ijk[2]));
    return OHM_OK;
    OHM_VDB_CATCH(err)
}

int ohm_vdb_grid_foreach_active(const ohm_vdb_grid *g, ohm_vdb_voxel_fn fn, void *user,
                                ohm_error *err)
{
    OHM_VDB_TRY
    if (!g || !fn)
        return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_grid_foreach_active: NULL argument");
    const openvdb::FloatTree &tree = g->grid->constTree();
    for (openvdb::FloatTree::ValueOnCIter it = tree.cbeginValueOn(); it; ++it) {
        const float v = *it;
        if (it.isVoxelValue()) {
            const openvdb::Coord c = it.getCoord();
            const int32_t p[3] = {c.x(), c.y(), c.z()};
            const int rc = fn(user, p, v);
            if (rc) return rc;
        } else {
            // An active tile stands for many voxels: visit each of them.
            openvdb::CoordBBox bb;
            it.getBoundingBox(bb);
            for (int32_t x = bb.min().x(); x <= bb.max().x(); ++x)
                for (int32_t y = bb.min().y(); y <= bb.max().y(); ++y)
                    for (int32_t z = bb.min().z(); z <= bb.max().z(); ++z) {
                        const int32_t p[3] = {x, y, z};
                        const int rc = fn(user, p, v);
                        if (rc) return rc;
                    }
        }
    }
    return OHM_OK;
    OHM_VDB_CATCH(err)
}

struct ohm_vdb_writer {
    std::string path;
    std::ofstream os;
    StreamingWriter archive;
    size_t expected = 0, written = 0;
    std::set<std::string> names;
};

// The writer's stream failed or threw: close it and remove what it wrote.
static int writer_failed(ohm_vdb_writer *w, int code, const char *why, ohm_error *err)
{
    int rc = ohm_fail(err, code, "cannot write '%s': %s", w->path.c_str(), why);
    w->os.close();
    remove_partial(w->path.c_str());
    return rc;
}

int ohm_vdb_writer_open(ohm_vdb_writer **out, const char *path, size_t ngrids, ohm_error *err)
{
    OHM_VDB_TRY
    if (!out) return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_writer_open: NULL output");
    *out = nullptr;
    if (!path || !*path) return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_write: empty path");
    if (ngrids > INT32_MAX) return ohm_fail(err, OHM_ERR_INVALID, "cannot write '%s': %zu grids", path, ngrids);
    openvdb::initialize();

    // Check the destination first so the message says what is wrong.
    const std::string dir = dir_of(path);
    struct stat st;
    if (stat(dir.c_str(), &st) != 0)
        return ohm_fail(err, OHM_ERR_IO, "cannot write '%s': directory '%s': %s", path, dir.c_str(),
                        std::strerror(errno));
    if (!S_ISDIR(st.st_mode))
        return ohm_fail(err, OHM_ERR_IO, "cannot write '%s': '%s' is not a directory", path,
                        dir.c_str());
    if (access(dir.c_str(), W_OK | X_OK) != 0)
        return ohm_fail(err, OHM_ERR_IO, "cannot write '%s': directory '%s' is not writable (%s)",
                        path, dir.c_str(), std::strerror(errno));
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode))
        return ohm_fail(err, OHM_ERR_IO, "cannot write '%s': it is a directory", path);

    std::unique_ptr<ohm_vdb_writer> w(new ohm_vdb_writer);
    w->path = path;
    w->expected = ngrids;
    errno = 0;
    w->os.open(path, std::ios_base::out | std::ios_base::binary | std::ios_base::trunc);
    if (!w->os.is_open() || w->os.fail())
        return ohm_fail(err, OHM_ERR_IO, "cannot write '%s': %s", path,
                        errno ? std::strerror(errno) : "cannot open for writing");
    try {
        w->archive.begin(w->os, static_cast<int32_t>(ngrids));
    } catch (const std::bad_alloc &) {
        return writer_failed(w.get(), OHM_ERR_NOMEM, "out of memory", err);
    } catch (const std::exception &e) {
        return writer_failed(w.get(), OHM_ERR_IO, e.what(), err);
    }
    if (w->os.fail()) return writer_failed(w.get(), OHM_ERR_IO, std::strerror(errno ? errno : EIO), err);
    *out = w.release();
    return OHM_OK;
    OHM_VDB_CATCH(err)
}

int ohm_vdb_writer_add(ohm_vdb_writer *w, const ohm_vdb_grid *g, ohm_error *err)
{
    OHM_VDB_TRY
    if (!w || !g) return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_writer_add: NULL argument");
    if (w->written == w->expected)
        return ohm_fail(err, OHM_ERR_INTERNAL, "cannot write '%s': more than the %zu grids announced", w->path.c_str(),
                        w->expected);
    if (!w->names.insert(g->grid->getName()).second)
        return ohm_fail(err, OHM_ERR_INTERNAL, "cannot write '%s': two grids named '%s'", w->path.c_str(),
                        g->grid->getName().c_str());
    try {
        w->archive.add(w->os, g->grid);
    } catch (const std::bad_alloc &) {
        return writer_failed(w, OHM_ERR_NOMEM, "out of memory", err);
    } catch (const std::exception &e) {
        return writer_failed(w, OHM_ERR_IO, e.what(), err);
    }
    if (w->os.fail()) return writer_failed(w, OHM_ERR_IO, std::strerror(errno ? errno : EIO), err);
    w->written++;
    return OHM_OK;
    OHM_VDB_CATCH(err)
}

int ohm_vdb_writer_close(ohm_vdb_writer *w, ohm_error *err)
{
    OHM_VDB_TRY
    if (!w) return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_writer_close: NULL writer");
    std::unique_ptr<ohm_vdb_writer> owned(w);
    if (!w->os.is_open()) return ohm_fail(err, OHM_ERR_IO, "cannot write '%s': an earlier write failed", w->path.c_str());
    if (w->written != w->expected) {
        char why[96];
        std::snprintf(why, sizeof why, "%zu grids written of the %zu announced", w->written, w->expected);
        return writer_failed(w, OHM_ERR_INTERNAL, why, err);
    }
    errno = 0;
    w->os.flush();
    const bool flushed = !w->os.fail();
    const int flush_errno = errno;
    w->os.close();
    if (!flushed || w->os.fail()) {
        const int e = flush_errno ? flush_errno : errno;
        remove_partial(w->path.c_str());
        return ohm_fail(err, OHM_ERR_IO, "cannot write '%s': %s", w->path.c_str(), e ? std::strerror(e) : "write failed");
    }
    return OHM_OK;
    OHM_VDB_CATCH(err)
}

void ohm_vdb_writer_abort(ohm_vdb_writer *w)
{
    if (!w) return;
    try {
        if (w->os.is_open()) w->os.close();
        remove_partial(w->path.c_str());
    } catch (...) {
    }
    delete w;
}

int ohm_vdb_write(const char *path, ohm_vdb_grid *const *grids, size_t n, ohm_error *err)
{
    if (!path || !*path) return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_write: empty path");
    if (n > 0 && !grids) return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_write: NULL grid array");
    for (size_t i = 0; i < n; ++i)
        if (!grids[i]) return ohm_fail(err, OHM_ERR_INVALID, "cannot write '%s': grid %zu is NULL", path, i);
    ohm_vdb_writer *w = nullptr;
    int rc = ohm_vdb_writer_open(&w, path, n, err);
    for (size_t i = 0; !rc && i < n; ++i)
        if ((rc = ohm_vdb_writer_add(w, grids[i], err))) ohm_vdb_writer_abort(w);
    return rc ? rc : ohm_vdb_writer_close(w, err);
}

int ohm_vdb_read(ohm_vdb_grid ***out, size_t *n, const char *path, ohm_error *err)
{
    OHM_VDB_TRY
    if (!out || !n || !path || !*path)
        return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_read: NULL argument or empty path");
    *out = nullptr;
    *n = 0;
    openvdb::initialize();

    struct stat st;
    if (stat(path, &st) != 0)
        return ohm_fail(err, OHM_ERR_IO, "cannot read '%s': %s", path, std::strerror(errno));
    if (S_ISDIR(st.st_mode))
        return ohm_fail(err, OHM_ERR_IO, "cannot read '%s': it is a directory", path);
    if (access(path, R_OK) != 0)
        return ohm_fail(err, OHM_ERR_IO, "cannot read '%s': %s", path, std::strerror(errno));

    openvdb::io::File file(path);
    try {
        file.open(/*delayLoad=*/false);
    } catch (const std::bad_alloc &) {
        return ohm_fail(err, OHM_ERR_NOMEM, "cannot read '%s': out of memory", path);
    } catch (const std::exception &e) {
        return ohm_fail(err, OHM_ERR_PARSE, "'%s' is not an OpenVDB file: %s", path, e.what());
    }
    openvdb::GridPtrVecPtr all;
    try {
        all = file.getGrids();
        file.close();
    } catch (const std::bad_alloc &) {
        return ohm_fail(err, OHM_ERR_NOMEM, "cannot read '%s': out of memory", path);
    } catch (const std::exception &e) {
        return ohm_fail(err, OHM_ERR_PARSE, "cannot read the grids of '%s': %s", path, e.what());
    }

    std::vector<std::unique_ptr<ohm_vdb_grid>> grids;
    if (all) {
        grids.reserve(all->size());
        for (const openvdb::GridBase::Ptr &base : *all) {
            if (!base) continue;
            openvdb::FloatGrid::Ptr fg = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
            if (!fg)
                return ohm_fail(err, OHM_ERR_INVALID,
                                "'%s': grid '%s' holds %s values (%s), not a float grid", path,
                                base->getName().c_str(), base->valueType().c_str(),
                                base->type().c_str());
            double vs = 0.0;
            if (!uniform_scale_translate(fg->transform(), &vs))
                return ohm_fail(err, OHM_ERR_INVALID,
                                "'%s': grid '%s' has a transform (%s) that is not a uniform "
                                "scale and translation",
                                path, fg->getName().c_str(), fg->transform().mapType().c_str());
            std::unique_ptr<ohm_vdb_grid> h(new ohm_vdb_grid);
            h->grid = fg;
            grids.push_back(std::move(h));
        }
    }
    if (grids.empty()) return OHM_OK;
    ohm_vdb_grid **arr =
        static_cast<ohm_vdb_grid **>(std::malloc(grids.size() * sizeof(ohm_vdb_grid *)));
    if (!arr) return ohm_fail(err, OHM_ERR_NOMEM, "cannot read '%s': out of memory", path);
    for (size_t i = 0; i < grids.size(); ++i) arr[i] = grids[i].release();
    *out = arr;
    *n = grids.size();
    return OHM_OK;
    OHM_VDB_CATCH(err)
}

int ohm_vdb_mesh_to_level_set(ohm_vdb_grid **out, const double *verts, size_t nverts,
                              const int64_t *tris, size_t ntris, double voxel_size,
                              const double origin[3], float half_width_voxels, ohm_error *err)
{
    OHM_VDB_TRY
    if (!out) return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_mesh_to_level_set: NULL output");
    *out = nullptr;
    if ((nverts && !verts) || (ntris && !tris))
        return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_mesh_to_level_set: NULL vertices or triangles");
    if (ntris == 0)
        return ohm_fail(err, OHM_ERR_INVALID, "ohm_vdb_mesh_to_level_set: the mesh has no triangles");
    if (nverts > 0xffffffffu)
        return ohm_fail(err, OHM_ERR_INVALID,
                        "ohm_vdb_mesh_to_level_set: %zu vertices, more than OpenVDB's 32-bit "
                        "indices allow",
                        nverts);
    int rc = check_geometry(voxel_size, origin, "ohm_vdb_mesh_to_level_set", err);
    if (rc) return rc;
    if (!std::isfinite(half_width_voxels) || half_width_voxels < 1.0f)
        return ohm_fail(err, OHM_ERR_INVALID,
                        "ohm_vdb_mesh_to_level_set: half width %g voxels must be at least 1",
                        (double)half_width_voxels);
    for (size_t i = 0; i < 3 * ntris; ++i)
        if (tris[i] < 0 || (uint64_t)tris[i] >= (uint64_t)nverts)
            return ohm_fail(err, OHM_ERR_INVALID,
                            "ohm_vdb_mesh_to_level_set: triangle %zu has vertex index %lld, "
                            "outside 0..%zu",
                            i / 3, (long long)tris[i], nverts ? nverts - 1 : (size_t)0);
    for (size_t i = 0; i < 3 * nverts; ++i)
        if (!std::isfinite(verts[i]))
            return ohm_fail(err, OHM_ERR_INVALID,
                            "ohm_vdb_mesh_to_level_set: vertex %zu has a non-finite coordinate",
                            i / 3);
    openvdb::initialize();

    std::vector<openvdb::Vec3s> points(nverts);
    for (size_t i = 0; i < nverts; ++i)
        points[i] = openvdb::Vec3s(static_cast<float>(verts[3 * i]),
                                   static_cast<float>(verts[3 * i + 1]),
                                   static_cast<float>(verts[3 * i + 2]));
    std::vector<openvdb::Vec3I> triangles(ntris);
    for (size_t i = 0; i < ntris; ++i)
        triangles[i] = openvdb::Vec3I(static_cast<uint32_t>(tris[3 * i]),
                                      static_cast<uint32_t>(tris[3 * i + 1]),
                                      static_cast<uint32_t>(tris[3 * i + 2]));
    openvdb::math::Transform::Ptr xf = make_transform(voxel_size, origin);
    std::unique_ptr<ohm_vdb_grid> g(new ohm_vdb_grid);
    g->grid = openvdb::tools::meshToLevelSet<openvdb::FloatGrid>(*xf, points, triangles,
                                                                 half_width_voxels);
    g->grid->setGridClass(openvdb::GRID_LEVEL_SET);
    *out = g.release();
    return OHM_OK;
    OHM_VDB_CATCH(err)
}

} // extern "C"
