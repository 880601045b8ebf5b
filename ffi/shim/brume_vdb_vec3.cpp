// Vec3 grids (fluid velocities) through Brume's C ABI: open by name, copy out leaves and tiles,
// and OpenVDB's own samplers for tests. See brume_vdb.h for the contract.
#include "brume_vdb_internal.h"

#include <openvdb/tools/Interpolation.h>

#include <string>

using namespace brume_vdb;

struct BrumeVdbVec3Grid {
    // The grid as the file holds it (its info, value type and class are reported from here).
    openvdb::GridBase::ConstPtr original;
    // Single-precision values: a deep copy of a vec3s grid, or a vec3d grid converted.
    openvdb::Vec3SGrid::Ptr grid;
};

namespace {

openvdb::Vec3s single(const openvdb::Vec3d &v) {
    return openvdb::Vec3s(float(v[0]), float(v[1]), float(v[2]));
}

// A vec3d grid's values rounded to single precision, with the same tree topology, transform
// and metadata (name and class included). OpenVDB has no implicit Vec3d -> Vec3s conversion, so
// its topology copy is filled value by value: both trees visit the same values in one order.
openvdb::Vec3SGrid::Ptr single_precision(const openvdb::Vec3DGrid &grid) {
    const auto &in = grid.tree();
    auto tree = std::make_shared<openvdb::Vec3STree>(in, single(in.background()),
                                                     openvdb::TopologyCopy());
    auto out_value = tree->beginValueAll();
    for (auto in_value = in.cbeginValueAll(); in_value; ++in_value, ++out_value) {
        require(out_value && out_value.getCoord() == in_value.getCoord(), BRUME_VDB_INTERNAL,
                "vec3d to vec3s: the topology copy visits values in another order");
        out_value.setValue(single(*in_value));
    }
    auto out = openvdb::Vec3SGrid::create(tree);
    out->setTransform(grid.transform().copy());
    for (auto it = grid.beginMeta(); it != grid.endMeta(); ++it)
        if (it->second) out->insertMeta(it->first, *it->second);
    return out;
}

openvdb::Vec3R point_at(const double *points, size_t i) {
    return openvdb::Vec3R(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
}

// One sampler over the whole batch, through one accessor.
template <typename Sampler>
void sample_all(const openvdb::Vec3SGrid &grid, const double *points, size_t n, float *out) {
    auto acc = grid.getConstAccessor();
    for (size_t i = 0; i < n; ++i) store(Sampler::sample(acc, point_at(points, i)), out, i);
}

} // namespace

extern "C" {

int32_t brume_vdb_vec3_grid_open(const BrumeVdbFile *file, const char *name,
                                 BrumeVdbVec3Grid **out, char **error) {
    return guarded(error, [&] {
        require(file && name && out, BRUME_VDB_INVALID_ARGUMENT, "null argument");
        *out = nullptr;
        const openvdb::GridBase::Ptr found = find_grid(*file, name);
        require(found->transform().isLinear(), BRUME_VDB_TYPE_ERROR,
                "grid has a non-affine (frustum) transform, which Brume does not support");
        openvdb::Vec3SGrid::Ptr grid;
        if (auto s = openvdb::gridPtrCast<openvdb::Vec3SGrid>(found)) {
            grid = s->deepCopy();
        } else if (auto d = openvdb::gridPtrCast<openvdb::Vec3DGrid>(found)) {
            grid = single_precision(*d);
        } else {
            throw Failure{BRUME_VDB_TYPE_ERROR, std::string("grid '") + name + "' holds " +
                                                    found->valueType() +
                                                    " values, not vec3s or vec3d"};
        }
        *out = new BrumeVdbVec3Grid{found, grid};
    });
}

void brume_vdb_vec3_grid_free(BrumeVdbVec3Grid *grid) { delete grid; }

int32_t brume_vdb_vec3_grid_info(const BrumeVdbVec3Grid *grid, BrumeVdbGridInfo *out,
                                 char **error) {
    return guarded(error, [&] {
        require(grid && out, BRUME_VDB_INVALID_ARGUMENT, "null argument");
        fill_info(*grid->original, out);
    });
}

int32_t brume_vdb_vec3_grid_counts(const BrumeVdbVec3Grid *grid, size_t *leaf_count,
                                   size_t *tile_count, float *background, char **error) {
    return guarded(error, [&] {
        require(grid && leaf_count && tile_count && background, BRUME_VDB_INVALID_ARGUMENT,
                "null argument");
        const auto &tree = grid->grid->tree();
        *leaf_count = tree.leafCount();
        *tile_count = count_tiles(tree);
        store(tree.background(), background, 0);
    });
}

int32_t brume_vdb_vec3_grid_copy_leaves(const BrumeVdbVec3Grid *grid, int32_t *origins,
                                        float *values, uint64_t *masks, size_t capacity,
                                        char **error) {
    return copy_leaves_of(grid, origins, values, masks, capacity, error);
}

int32_t brume_vdb_vec3_grid_copy_tiles(const BrumeVdbVec3Grid *grid, int32_t *origins,
                                       uint32_t *dims, float *values, uint8_t *active,
                                       size_t capacity, char **error) {
    return copy_tiles_of(grid, origins, dims, values, active, capacity, error);
}

int32_t brume_vdb_vec3_grid_sample(const BrumeVdbVec3Grid *grid, const double *points, size_t n,
                                   int32_t sampler, float *out, char **error) {
    return guarded(error, [&] {
        require(grid && (points || n == 0) && (out || n == 0), BRUME_VDB_INVALID_ARGUMENT,
                "null argument");
        namespace t = openvdb::tools;
        switch (sampler) {
        case BRUME_VDB_SAMPLE_POINT: sample_all<t::PointSampler>(*grid->grid, points, n, out); break;
        case BRUME_VDB_SAMPLE_BOX: sample_all<t::BoxSampler>(*grid->grid, points, n, out); break;
        case BRUME_VDB_SAMPLE_STAGGERED_POINT:
            sample_all<t::StaggeredPointSampler>(*grid->grid, points, n, out);
            break;
        case BRUME_VDB_SAMPLE_STAGGERED_BOX:
            sample_all<t::StaggeredBoxSampler>(*grid->grid, points, n, out);
            break;
        default: throw Failure{BRUME_VDB_INVALID_ARGUMENT, "unknown sampler"};
        }
    });
}

} // extern "C"
