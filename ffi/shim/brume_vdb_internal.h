// Helpers shared by the shim's translation units (brume_vdb.cpp, brume_vdb_vec3.cpp); not part
// of the C ABI, never seen by bindgen.
#ifndef BRUME_VDB_INTERNAL_H
#define BRUME_VDB_INTERNAL_H

#include "brume_vdb.h"

#include <openvdb/openvdb.h>

#include <cstdlib>
#include <cstring>
#include <ios>
#include <new>
#include <string>

struct BrumeVdbFile {
    openvdb::GridPtrVecPtr grids;
    openvdb::MetaMap::Ptr metadata;
};

namespace brume_vdb {

struct Failure {
    int32_t status;
    std::string message;
};

inline char *owned_copy(const std::string &s) {
    char *out = static_cast<char *>(std::malloc(s.size() + 1));
    if (out) std::memcpy(out, s.c_str(), s.size() + 1);
    return out;
}

inline void set_error(char **error, const std::string &message) {
    if (error) *error = owned_copy(message);
}

// Runs openvdb::initialize() once per process (defined in brume_vdb.cpp).
void ensure_initialized();

template <typename F> int32_t guarded(char **error, F &&body) {
    if (error) *error = nullptr;
    try {
        ensure_initialized();
        body();
        return BRUME_VDB_OK;
    } catch (const Failure &f) {
        set_error(error, f.message);
        return f.status;
    } catch (const openvdb::IoError &e) {
        set_error(error, e.what());
        return BRUME_VDB_FORMAT_ERROR;
    } catch (const openvdb::TypeError &e) {
        set_error(error, e.what());
        return BRUME_VDB_TYPE_ERROR;
    } catch (const openvdb::Exception &e) {
        set_error(error, e.what());
        return BRUME_VDB_FORMAT_ERROR;
    } catch (const std::ios_base::failure &e) {
        set_error(error, std::string("read failed (truncated or unreadable file): ") + e.what());
        return BRUME_VDB_IO_ERROR;
    } catch (const std::bad_alloc &) {
        set_error(error, "out of memory (a corrupt file can ask for absurd sizes)");
        return BRUME_VDB_OUT_OF_MEMORY;
    } catch (const std::exception &e) {
        set_error(error, e.what());
        return BRUME_VDB_INTERNAL;
    } catch (...) {
        set_error(error, "unknown C++ exception");
        return BRUME_VDB_INTERNAL;
    }
}

inline void require(bool ok, int32_t status, const char *message) {
    if (!ok) throw Failure{status, message};
}

// Upper-level values worth reporting: active tiles, and inactive ones that differ from the
// background (a level set's interior, say), since lookups read them.
template <typename TreeT, typename F> void for_each_tile(const TreeT &tree, F &&visit) {
    const auto background = tree.background();
    for (auto it = tree.cbeginValueAll(); it; ++it) {
        if (it.isVoxelValue()) continue;
        const auto v = *it;
        if (it.isValueOn() || !(v == background)) visit(it);
    }
}

template <typename TreeT> uint64_t count_tiles(const TreeT &tree) {
    uint64_t n = 0;
    for_each_tile(tree, [&](const auto &) { ++n; });
    return n;
}

// Stores value i of a float or Vec3 grid into a flat float buffer (1 or 3 floats a value).
inline void store(float v, float *out, size_t i) { out[i] = v; }
inline void store(const openvdb::Vec3s &v, float *out, size_t i) {
    for (int a = 0; a < 3; ++a) out[3 * i + a] = v[a];
}

// Copies every leaf of tree: origins (3 ints), values in OpenVDB leaf order (store), and the
// active masks (8 words); capacity must be the leaf count.
template <typename TreeT>
void copy_leaves(const TreeT &tree, int32_t *origins, float *values, uint64_t *masks,
                 size_t capacity) {
    require(capacity == tree.leafCount(), BRUME_VDB_INVALID_ARGUMENT,
            "leaf buffer size does not match the leaf count");
    using Leaf = typename TreeT::LeafNodeType;
    size_t n = 0;
    for (auto leaf = tree.cbeginLeaf(); leaf; ++leaf, ++n) {
        const openvdb::Coord o = leaf->origin();
        for (int a = 0; a < 3; ++a) origins[3 * n + a] = o[a];
        for (openvdb::Index i = 0; i < Leaf::SIZE; ++i)
            store(leaf->getValue(i), values, Leaf::SIZE * n + i);
        const auto &mask = leaf->getValueMask();
        for (openvdb::Index w = 0; w < 8; ++w) masks[8 * n + w] = mask.template getWord<uint64_t>(w);
    }
}

// Copies the tiles for_each_tile visits: origin, edge length, value (store), active flag;
// capacity must be their count.
template <typename TreeT>
void copy_tiles(const TreeT &tree, int32_t *origins, uint32_t *dims, float *values,
                uint8_t *active, size_t capacity) {
    require(capacity == count_tiles(tree), BRUME_VDB_INVALID_ARGUMENT,
            "tile buffer size does not match the tile count");
    size_t n = 0;
    for_each_tile(tree, [&](const auto &it) {
        const openvdb::CoordBBox box = it.getBoundingBox();
        for (int a = 0; a < 3; ++a) origins[3 * n + a] = box.min()[a];
        dims[n] = static_cast<uint32_t>(box.dim()[0]);
        store(*it, values, n);
        active[n] = it.isValueOn() ? 1 : 0;
        ++n;
    });
}

// The C entry points that copy a grid handle's leaves or tiles (float and Vec3 alike).
template <typename Handle>
int32_t copy_leaves_of(const Handle *grid, int32_t *origins, float *values, uint64_t *masks,
                       size_t capacity, char **error) {
    return guarded(error, [&] {
        require(grid && origins && values && masks, BRUME_VDB_INVALID_ARGUMENT, "null argument");
        copy_leaves(grid->grid->tree(), origins, values, masks, capacity);
    });
}

template <typename Handle>
int32_t copy_tiles_of(const Handle *grid, int32_t *origins, uint32_t *dims, float *values,
                      uint8_t *active, size_t capacity, char **error) {
    return guarded(error, [&] {
        require(grid && origins && dims && values && active, BRUME_VDB_INVALID_ARGUMENT,
                "null argument");
        copy_tiles(grid->grid->tree(), origins, dims, values, active, capacity);
    });
}

// Fills a grid-info struct (defined in brume_vdb.cpp).
void fill_info(const openvdb::GridBase &grid, BrumeVdbGridInfo *out);

// The file's grid called name, or a BRUME_VDB_NOT_FOUND failure.
openvdb::GridBase::Ptr find_grid(const BrumeVdbFile &file, const char *name);

} // namespace brume_vdb

#endif
