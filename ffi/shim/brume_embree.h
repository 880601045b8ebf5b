/* Brume's narrow C ABI over Intel Embree 3: one device, scenes of one triangle mesh or of
 * instances of several (a two-level scene), and single-ray closest-hit and occlusion queries.
 *
 * Functions that can fail return a BrumeEmbreeStatus and, on failure, store a heap-allocated,
 * NUL-terminated message in *error (when error is non-NULL), owned by the caller and released
 * with brume_embree_string_free. No C++ exception crosses this boundary: every entry point
 * catches std::bad_alloc, std::exception and (...). Embree's own errors reach the device's
 * error callback, which records the code and message that the failing call then returns.
 * Handles are opaque and released with their *_free function; freeing NULL is a no-op.
 */
#ifndef BRUME_EMBREE_H
#define BRUME_EMBREE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum BrumeEmbreeStatus {
    BRUME_EMBREE_OK = 0,
    /* Embree reported an error (the message names the call and Embree's error code). */
    BRUME_EMBREE_DEVICE_ERROR = 1,
    /* A caller-supplied argument is invalid (NULL pointer, index out of range, non-finite
     * vertex, too many triangles). */
    BRUME_EMBREE_INVALID_ARGUMENT = 2,
    /* Allocation failed. */
    BRUME_EMBREE_OUT_OF_MEMORY = 3,
    /* Any other exception. */
    BRUME_EMBREE_INTERNAL = 4
} BrumeEmbreeStatus;

typedef struct BrumeEmbreeDevice BrumeEmbreeDevice;
typedef struct BrumeEmbreeScene BrumeEmbreeScene;

/* The closest hit of a ray: the instance hit (BRUME_EMBREE_NO_INSTANCE in a scene of one
 * mesh), Embree's primitive (triangle) index in its mesh, ray parameter and barycentrics of
 * the second and third vertex. */
#define BRUME_EMBREE_NO_INSTANCE 0xffffffffu
typedef struct BrumeEmbreeHit {
    uint32_t inst;
    uint32_t prim;
    float t;
    float u;
    float v;
} BrumeEmbreeHit;

/* A device configured by `config` (Embree's configuration string, e.g. "verbose=0"). */
int32_t brume_embree_device_new(const char *config, BrumeEmbreeDevice **out, char **error);
void brume_embree_device_free(BrumeEmbreeDevice *device);
/* Bytes Embree holds on this device now (its memory-monitor callback's running sum). */
int64_t brume_embree_device_memory(const BrumeEmbreeDevice *device);

/* Builds and commits a scene of one triangle mesh: `vertex_count` vertices (x, y, z floats)
 * and `triangle_count` triangles (three uint32 vertex indices each), with
 * RTC_SCENE_FLAG_ROBUST and RTC_BUILD_QUALITY_HIGH. Indices are checked against
 * `vertex_count` and vertices must be finite. Embree's primitive index is the triangle's
 * position in `indices`. The scene keeps the device (and its error callback) alive. */
int32_t brume_embree_scene_new(BrumeEmbreeDevice *device, const float *vertices,
                               size_t vertex_count, const uint32_t *indices,
                               size_t triangle_count, BrumeEmbreeScene **out, char **error);

/* One triangle mesh of an instanced scene: vertices (x, y, z floats) and triangles (three
 * uint32 vertex indices each). */
typedef struct BrumeEmbreeMesh {
    const float *vertices;
    size_t vertex_count;
    const uint32_t *indices;
    size_t triangle_count;
} BrumeEmbreeMesh;

/* One placement of a mesh: its index in the mesh array and its world-from-local transform as
 * a 3x4 column-major matrix (the three axes, then the translation). */
typedef struct BrumeEmbreeInstance {
    uint32_t mesh;
    float world_from_local[12];
} BrumeEmbreeInstance;

/* Builds and commits a two-level scene: one scene per mesh (checked and built as
 * brume_embree_scene_new builds its mesh) under a scene of `instance_count` instances. A
 * hit's `inst` is the instance's position in `instances` and its `prim` the triangle's
 * position in that mesh's `indices`. Instances naming a mesh out of range or with
 * non-finite transforms are errors. */
int32_t brume_embree_instanced_scene_new(BrumeEmbreeDevice *device,
                                         const BrumeEmbreeMesh *meshes, size_t mesh_count,
                                         const BrumeEmbreeInstance *instances,
                                         size_t instance_count, BrumeEmbreeScene **out,
                                         char **error);
void brume_embree_scene_free(BrumeEmbreeScene *scene);

/* The closest hit with t in [t_near, t_far]: 1 (and *hit filled) on a hit, 0 on a miss.
 * Safe to call from many threads at once on a committed scene. */
int32_t brume_embree_intersect(const BrumeEmbreeScene *scene, const float origin[3],
                               const float direction[3], float t_near, float t_far,
                               BrumeEmbreeHit *hit);
/* Whether any triangle is hit with t in [t_near, t_far]: 1 or 0. Thread-safe likewise. */
int32_t brume_embree_occluded(const BrumeEmbreeScene *scene, const float origin[3],
                              const float direction[3], float t_near, float t_far);

void brume_embree_string_free(char *s);

#ifdef __cplusplus
}
#endif

#endif
