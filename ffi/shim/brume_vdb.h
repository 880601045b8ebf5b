/* Brume's narrow C ABI over OpenVDB.
 *
 * Every function returns a BrumeVdbStatus. On failure it stores a heap-allocated, NUL-terminated
 * message in *error (when error is non-NULL), owned by the caller and released with
 * brume_vdb_string_free. No C++ exception crosses this boundary: every entry point catches
 * openvdb::IoError, openvdb::Exception, std::exception and (...) and turns them into statuses.
 * Handles are opaque and released with their *_free function; freeing NULL is a no-op.
 */
#ifndef BRUME_VDB_H
#define BRUME_VDB_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum BrumeVdbStatus {
    BRUME_VDB_OK = 0,
    /* The file could not be opened or read (missing, a directory, truncated). */
    BRUME_VDB_IO_ERROR = 1,
    /* The bytes are not a readable VDB file (bad magic, corrupt stream). */
    BRUME_VDB_FORMAT_ERROR = 2,
    /* No grid of that name or index. */
    BRUME_VDB_NOT_FOUND = 3,
    /* The grid has a value type or transform this call cannot handle. */
    BRUME_VDB_TYPE_ERROR = 4,
    /* A caller-supplied argument is invalid (NULL pointer, too small a buffer). */
    BRUME_VDB_INVALID_ARGUMENT = 5,
    /* Allocation failed inside OpenVDB. */
    BRUME_VDB_OUT_OF_MEMORY = 6,
    /* Any other exception. */
    BRUME_VDB_INTERNAL = 7,
    /* OpenVDB's reader crashed (a signal) or ran past its time limit on this file; only the
     * child process that read it died (brume_vdb_open_isolated). */
    BRUME_VDB_READER_CRASHED = 8
} BrumeVdbStatus;

typedef enum BrumeVdbGridClass {
    BRUME_VDB_CLASS_UNKNOWN = 0,
    BRUME_VDB_CLASS_LEVEL_SET = 1,
    BRUME_VDB_CLASS_FOG_VOLUME = 2,
    BRUME_VDB_CLASS_STAGGERED = 3
} BrumeVdbGridClass;

/* Flags for brume_vdb_float_grid_open. */
#define BRUME_VDB_LEVEL_SET_TO_FOG 1u

typedef struct BrumeVdbFile BrumeVdbFile;
typedef struct BrumeVdbFloatGrid BrumeVdbFloatGrid;
typedef struct BrumeVdbVec3Grid BrumeVdbVec3Grid;

/* OpenVDB's samplers for brume_vdb_vec3_grid_sample. The staggered ones read component a of the
 * vector at p + 0.5 e_a (a MAC grid's face-centred components). */
typedef enum BrumeVdbVec3Sampler {
    BRUME_VDB_SAMPLE_POINT = 0,           /* openvdb::tools::PointSampler */
    BRUME_VDB_SAMPLE_BOX = 1,             /* openvdb::tools::BoxSampler */
    BRUME_VDB_SAMPLE_STAGGERED_POINT = 2, /* openvdb::tools::StaggeredPointSampler */
    BRUME_VDB_SAMPLE_STAGGERED_BOX = 3    /* openvdb::tools::StaggeredBoxSampler */
} BrumeVdbVec3Sampler;

/* Facts about one grid. Strings are owned by the struct: release with brume_vdb_grid_info_free. */
typedef struct BrumeVdbGridInfo {
    char *name;
    char *value_type;
    int32_t grid_class; /* a BrumeVdbGridClass */
    int32_t is_affine;
    double voxel_size[3];
    /* Row-major 4x4, column-vector convention: world = M * (i, j, k, 1). */
    double world_from_index[16];
    int32_t has_active_bbox;
    int32_t active_bbox_min[3];
    int32_t active_bbox_max[3]; /* inclusive */
    uint64_t active_voxel_count;
    uint64_t leaf_count;
    uint64_t tile_count;
    int32_t has_background;
    double background;
    /* metadata_count triples (name, type, value) flattened into 3 * metadata_count strings. */
    size_t metadata_count;
    char **metadata;
} BrumeVdbGridInfo;

/* One grid for brume_vdb_write_float_grids (test fixtures and example scenes). */
typedef struct BrumeVdbGridSpec {
    const char *name;
    int32_t grid_class;
    /* 0: float, 1: vec3s (value v is written as (v, v, v)), 2: vec3s from vectors,
     * 3: vec3d from vectors. */
    int32_t value_kind;
    /* Row-major 4x4, column-vector convention; must be affine. */
    double world_from_index[16];
    float background;
    /* count voxels: coords holds 3 * count int32, values count floats. Written voxels are active. */
    size_t count;
    const int32_t *coords;
    const float *values;
    /* Nonzero: collapse constant leaves into (active) tiles with openvdb::tools::prune. */
    int32_t prune;
    /* Nonzero: store as half floats. */
    int32_t save_as_half;
    /* value_kind 2 and 3: 3 * count floats, one 3-vector a voxel (values is then unused), and
     * the background vector. */
    const float *vectors;
    float vector_background[3];
} BrumeVdbGridSpec;

void brume_vdb_string_free(char *s);

/* Reads the whole file (all grids, no delayed loading) into a handle, in this process. Only for
 * trusted files: OpenVDB's reader does not check every length it reads and can overflow the heap
 * on a corrupt file. */
int32_t brume_vdb_open(const char *path, BrumeVdbFile **out, char **error);

/* Like brume_vdb_open, but OpenVDB parses the untrusted bytes in a separate process (this
 * executable re-run through /proc/self/exe; the shim's constructor serves it before main), which
 * writes the grids it read back through a pipe in OpenVDB's own (uncompressed) format; this
 * process only parses that. A crash of the reader (a signal) or a read that takes longer than
 * timeout_seconds (0: no limit) kills only the reader and returns BRUME_VDB_READER_CRASHED. */
int32_t brume_vdb_open_isolated(const char *path, double timeout_seconds, BrumeVdbFile **out,
                                char **error);
void brume_vdb_file_free(BrumeVdbFile *file);

int32_t brume_vdb_grid_count(const BrumeVdbFile *file, size_t *count, char **error);
int32_t brume_vdb_grid_info(const BrumeVdbFile *file, size_t index, BrumeVdbGridInfo *out,
                            char **error);
void brume_vdb_grid_info_free(BrumeVdbGridInfo *info);

/* File-level metadata as 3 * count strings (name, type, value); free with brume_vdb_strings_free. */
int32_t brume_vdb_file_metadata(const BrumeVdbFile *file, size_t *count, char ***triples,
                                char **error);
void brume_vdb_strings_free(char **strings, size_t n);

/* Opens the float grid called name (a deep copy; level sets are converted to fog volumes with
 * openvdb::tools::sdfToFogVolume when flags has BRUME_VDB_LEVEL_SET_TO_FOG). */
int32_t brume_vdb_float_grid_open(const BrumeVdbFile *file, const char *name, uint32_t flags,
                                  BrumeVdbFloatGrid **out, char **error);
void brume_vdb_float_grid_free(BrumeVdbFloatGrid *grid);
int32_t brume_vdb_float_grid_info(const BrumeVdbFloatGrid *grid, BrumeVdbGridInfo *out,
                                  char **error);
/* Counts of leaves and of tiles (upper-level values that are active or differ from the
 * background), and the background value. */
int32_t brume_vdb_float_grid_counts(const BrumeVdbFloatGrid *grid, size_t *leaf_count,
                                    size_t *tile_count, float *background, char **error);
/* origins: 3 * capacity int32; values: 512 * capacity floats in OpenVDB leaf order;
 * masks: 8 * capacity words of active bits. capacity must equal the leaf count. */
int32_t brume_vdb_float_grid_copy_leaves(const BrumeVdbFloatGrid *grid, int32_t *origins,
                                         float *values, uint64_t *masks, size_t capacity,
                                         char **error);
/* origins: 3 * capacity; dims, values, active: capacity each. capacity must equal the tile count. */
int32_t brume_vdb_float_grid_copy_tiles(const BrumeVdbFloatGrid *grid, int32_t *origins,
                                        uint32_t *dims, float *values, uint8_t *active,
                                        size_t capacity, char **error);
/* OpenVDB's own samplers at n index-space points (3 * n doubles): order 0 is PointSampler
 * (nearest), order 1 is BoxSampler (trilinear). One accessor serves the whole batch. */
int32_t brume_vdb_float_grid_sample(const BrumeVdbFloatGrid *grid, const double *points, size_t n,
                                    int32_t order, float *out, char **error);

/* Opens the Vec3 grid called name: a deep copy of a vec3s grid, or of a vec3d grid converted to
 * single precision (OpenVDB's value-converting tree copy). Grid info and class are the file's own
 * (value type "vec3d" stays "vec3d"). Other value types give BRUME_VDB_TYPE_ERROR. */
int32_t brume_vdb_vec3_grid_open(const BrumeVdbFile *file, const char *name,
                                 BrumeVdbVec3Grid **out, char **error);
void brume_vdb_vec3_grid_free(BrumeVdbVec3Grid *grid);
int32_t brume_vdb_vec3_grid_info(const BrumeVdbVec3Grid *grid, BrumeVdbGridInfo *out,
                                 char **error);
/* Counts of leaves and of tiles (active, or differing from the background), and the background
 * vector (3 floats). */
int32_t brume_vdb_vec3_grid_counts(const BrumeVdbVec3Grid *grid, size_t *leaf_count,
                                   size_t *tile_count, float *background, char **error);
/* origins: 3 * capacity int32; values: 3 * 512 * capacity floats, 512 (x, y, z) triples a leaf
 * in OpenVDB leaf order; masks: 8 * capacity words. Leaves in the same order as a float grid's.
 * capacity must equal the leaf count. */
int32_t brume_vdb_vec3_grid_copy_leaves(const BrumeVdbVec3Grid *grid, int32_t *origins,
                                        float *values, uint64_t *masks, size_t capacity,
                                        char **error);
/* origins: 3 * capacity; dims, active: capacity each; values: 3 * capacity. */
int32_t brume_vdb_vec3_grid_copy_tiles(const BrumeVdbVec3Grid *grid, int32_t *origins,
                                       uint32_t *dims, float *values, uint8_t *active,
                                       size_t capacity, char **error);
/* OpenVDB's own sampler (a BrumeVdbVec3Sampler) at n index-space points (3 * n doubles) into
 * 3 * n floats. One accessor serves the whole batch. */
int32_t brume_vdb_vec3_grid_sample(const BrumeVdbVec3Grid *grid, const double *points, size_t n,
                                   int32_t sampler, float *out, char **error);

/* Writes grids to path with Blosc compression when the library has it (zip otherwise). */
int32_t brume_vdb_write_float_grids(const char *path, const BrumeVdbGridSpec *grids, size_t n,
                                    char **error);

#ifdef __cplusplus
}
#endif

#endif
