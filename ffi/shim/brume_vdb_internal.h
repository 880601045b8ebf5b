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

// Fills a grid-info struct (defined in brume_vdb.cpp).
void fill_info(const openvdb::GridBase &grid, BrumeVdbGridInfo *out);

// The file's grid called name, or a BRUME_VDB_NOT_FOUND failure.
openvdb::GridBase::Ptr find_grid(const BrumeVdbFile &file, const char *name);

} // namespace brume_vdb

#endif
