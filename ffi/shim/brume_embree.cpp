// Brume's C ABI over Embree 3 (see brume_embree.h). Embree's API functions catch their own
// exceptions and report them through the device's error callback; this layer records the
// first such error of a call and returns it as a status and message, and catches whatever
// else C++ might throw so that nothing unwinds into Rust.
#include "brume_embree.h"

#include <embree3/rtcore.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <mutex>
#include <new>
#include <string>
#include <vector>

struct BrumeEmbreeDevice {
    RTCDevice device = nullptr;
    std::mutex mutex;           // guards the error fields (callbacks may come from any thread)
    RTCError error = RTC_ERROR_NONE;
    std::string message;
    std::atomic<int64_t> bytes{0};  // running sum of the memory-monitor callback
    std::atomic<int32_t> refs{1};   // the caller's handle and one per scene (the callbacks'
                                    // user pointer must outlive every scene)
};

struct BrumeEmbreeScene {
    BrumeEmbreeDevice *owner = nullptr;
    RTCScene scene = nullptr;
    std::vector<RTCScene> meshes;  // an instanced scene's per-mesh scenes, released after it
};

namespace {

char *copy_string(const std::string &s) {
    char *out = static_cast<char *>(std::malloc(s.size() + 1));
    if (out) {
        std::memcpy(out, s.c_str(), s.size() + 1);
    }
    return out;
}

int32_t fail(char **error, int32_t status, const std::string &message) {
    if (error) {
        *error = copy_string(message);
    }
    return status;
}

// The message a failed check stored in *error, taken back (and freed) to be prefixed.
std::string take_string(char **error) {
    std::string out;
    if (error && *error) {
        out = *error;
        std::free(*error);
        *error = nullptr;
    }
    return out;
}

const char *error_name(RTCError code) {
    switch (code) {
    case RTC_ERROR_NONE: return "RTC_ERROR_NONE";
    case RTC_ERROR_UNKNOWN: return "RTC_ERROR_UNKNOWN";
    case RTC_ERROR_INVALID_ARGUMENT: return "RTC_ERROR_INVALID_ARGUMENT";
    case RTC_ERROR_INVALID_OPERATION: return "RTC_ERROR_INVALID_OPERATION";
    case RTC_ERROR_OUT_OF_MEMORY: return "RTC_ERROR_OUT_OF_MEMORY";
    case RTC_ERROR_UNSUPPORTED_CPU: return "RTC_ERROR_UNSUPPORTED_CPU";
    case RTC_ERROR_CANCELLED: return "RTC_ERROR_CANCELLED";
    }
    return "unknown RTCError";
}

void on_error(void *user, RTCError code, const char *str) {
    auto *d = static_cast<BrumeEmbreeDevice *>(user);
    std::lock_guard<std::mutex> lock(d->mutex);
    if (d->error == RTC_ERROR_NONE) {  // keep the first error of a call: the cause
        d->error = code;
        d->message = str ? str : "";
    }
}

bool on_memory(void *user, ssize_t bytes, bool /*post*/) {
    static_cast<BrumeEmbreeDevice *>(user)->bytes.fetch_add(bytes, std::memory_order_relaxed);
    return true;
}

// The error Embree reported since the last call (and clears it), as a status and message
// naming `what`; BRUME_EMBREE_OK when there was none.
int32_t take_device_error(BrumeEmbreeDevice *d, const char *what, char **error) {
    std::lock_guard<std::mutex> lock(d->mutex);
    if (d->error == RTC_ERROR_NONE) {
        return BRUME_EMBREE_OK;
    }
    std::string message = std::string(what) + ": " + error_name(d->error);
    if (!d->message.empty()) {
        message += ": " + d->message;
    }
    d->error = RTC_ERROR_NONE;
    d->message.clear();
    return fail(error, BRUME_EMBREE_DEVICE_ERROR, message);
}

void release_device(BrumeEmbreeDevice *d) {
    if (d && d->refs.fetch_sub(1, std::memory_order_acq_rel) == 1) {
        rtcReleaseDevice(d->device);
        delete d;
    }
}

void clear_device_error(BrumeEmbreeDevice *d) {
    std::lock_guard<std::mutex> lock(d->mutex);
    d->error = RTC_ERROR_NONE;
    d->message.clear();
}

// Runs `body` (returning a status), turning any exception into a status and message.
template <typename F> int32_t guarded(char **error, F body) {
    if (error) {
        *error = nullptr;
    }
    try {
        return body();
    } catch (const std::bad_alloc &) {
        return fail(error, BRUME_EMBREE_OUT_OF_MEMORY, "out of memory");
    } catch (const std::exception &e) {
        return fail(error, BRUME_EMBREE_INTERNAL, e.what());
    } catch (...) {
        return fail(error, BRUME_EMBREE_INTERNAL, "unknown C++ exception");
    }
}

// Checks the mesh before Embree sees it: Embree reads indices unchecked.
int32_t check_mesh(const float *vertices, size_t vertex_count, const uint32_t *indices,
                   size_t triangle_count, char **error) {
    if ((vertex_count && !vertices) || (triangle_count && !indices)) {
        return fail(error, BRUME_EMBREE_INVALID_ARGUMENT, "NULL vertex or index array");
    }
    if (triangle_count > UINT32_MAX / 3 || vertex_count > UINT32_MAX) {
        return fail(error, BRUME_EMBREE_INVALID_ARGUMENT,
                    "more triangles or vertices than 32-bit indices address");
    }
    for (size_t k = 0; k < 3 * vertex_count; ++k) {
        if (!std::isfinite(vertices[k])) {
            return fail(error, BRUME_EMBREE_INVALID_ARGUMENT,
                        "vertex " + std::to_string(k / 3) + " is not finite");
        }
    }
    for (size_t k = 0; k < 3 * triangle_count; ++k) {
        if (indices[k] >= vertex_count) {
            return fail(error, BRUME_EMBREE_INVALID_ARGUMENT,
                        "triangle " + std::to_string(k / 3) + " indexes vertex " +
                            std::to_string(indices[k]) + " of " +
                            std::to_string(vertex_count));
        }
    }
    return BRUME_EMBREE_OK;
}

// The mesh as one committed Embree scene; `scene` is released by the caller on failure.
int32_t fill_scene(BrumeEmbreeDevice *d, RTCScene scene, const float *vertices,
                   size_t vertex_count, const uint32_t *indices, size_t triangle_count,
                   char **error) {
    rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
    if (triangle_count > 0) {
        RTCGeometry geom = rtcNewGeometry(d->device, RTC_GEOMETRY_TYPE_TRIANGLE);
        if (!geom) {
            return take_device_error(d, "rtcNewGeometry", error);
        }
        rtcSetGeometryBuildQuality(geom, RTC_BUILD_QUALITY_HIGH);
        auto *v = static_cast<float *>(rtcSetNewGeometryBuffer(
            geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), vertex_count));
        auto *i = static_cast<uint32_t *>(rtcSetNewGeometryBuffer(
            geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t),
            triangle_count));
        if (v && i) {
            // Embree's buffers are padded for 16-byte loads past the last element.
            std::memcpy(v, vertices, 3 * sizeof(float) * vertex_count);
            std::memcpy(i, indices, 3 * sizeof(uint32_t) * triangle_count);
            rtcCommitGeometry(geom);
            rtcAttachGeometry(scene, geom);
        }
        rtcReleaseGeometry(geom);  // the scene holds it now
        if (int32_t s = take_device_error(d, "rtcSetNewGeometryBuffer", error)) {
            return s;
        }
    }
    rtcCommitScene(scene);
    return take_device_error(d, "rtcCommitScene", error);
}

void release_scenes(RTCScene top, std::vector<RTCScene> &meshes) {
    if (top) {
        rtcReleaseScene(top);
    }
    for (RTCScene m : meshes) {
        rtcReleaseScene(m);
    }
    meshes.clear();
}

// One instance of `mesh` under `top`, attached as geometry `id` so that hits name it by its
// position in the caller's array.
int32_t attach_instance(BrumeEmbreeDevice *d, RTCScene top, RTCScene mesh,
                        const float world_from_local[12], unsigned id, char **error) {
    RTCGeometry geom = rtcNewGeometry(d->device, RTC_GEOMETRY_TYPE_INSTANCE);
    if (!geom) {
        return take_device_error(d, "rtcNewGeometry(instance)", error);
    }
    rtcSetGeometryInstancedScene(geom, mesh);
    rtcSetGeometryTransform(geom, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, world_from_local);
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(top, geom, id);
    rtcReleaseGeometry(geom);
    return take_device_error(d, "rtcAttachGeometryByID(instance)", error);
}

// The two-level scene into *top and *children; the caller releases both on failure.
int32_t fill_instanced(BrumeEmbreeDevice *d, const BrumeEmbreeMesh *meshes, size_t mesh_count,
                       const BrumeEmbreeInstance *instances, size_t instance_count,
                       RTCScene *top, std::vector<RTCScene> &children, char **error) {
    for (size_t k = 0; k < mesh_count; ++k) {
        const BrumeEmbreeMesh &m = meshes[k];
        if (int32_t s = check_mesh(m.vertices, m.vertex_count, m.indices, m.triangle_count,
                                   error)) {
            return fail(error, s, "mesh " + std::to_string(k) + ": " + take_string(error));
        }
        RTCScene scene = rtcNewScene(d->device);
        if (!scene) {
            return take_device_error(d, "rtcNewScene", error);
        }
        children.push_back(scene);
        if (int32_t s = fill_scene(d, scene, m.vertices, m.vertex_count, m.indices,
                                   m.triangle_count, error)) {
            return s;
        }
    }
    *top = rtcNewScene(d->device);
    if (!*top) {
        return take_device_error(d, "rtcNewScene", error);
    }
    rtcSetSceneFlags(*top, RTC_SCENE_FLAG_ROBUST);
    for (size_t k = 0; k < instance_count; ++k) {
        const BrumeEmbreeInstance &inst = instances[k];
        if (inst.mesh >= mesh_count) {
            return fail(error, BRUME_EMBREE_INVALID_ARGUMENT,
                        "instance " + std::to_string(k) + " names mesh " +
                            std::to_string(inst.mesh) + " of " + std::to_string(mesh_count));
        }
        for (float x : inst.world_from_local) {
            if (!std::isfinite(x)) {
                return fail(error, BRUME_EMBREE_INVALID_ARGUMENT,
                            "instance " + std::to_string(k) + "'s transform is not finite");
            }
        }
        if (int32_t s = attach_instance(d, *top, children[inst.mesh], inst.world_from_local,
                                        static_cast<unsigned>(k), error)) {
            return s;
        }
    }
    rtcCommitScene(*top);
    return take_device_error(d, "rtcCommitScene", error);
}

void ray_of(RTCRay &r, const float o[3], const float d[3], float t_near, float t_far) {
    r.org_x = o[0];
    r.org_y = o[1];
    r.org_z = o[2];
    r.dir_x = d[0];
    r.dir_y = d[1];
    r.dir_z = d[2];
    r.tnear = t_near;
    r.tfar = t_far;
    r.time = 0.0f;
    r.mask = 0xffffffffu;
    r.id = 0;
    r.flags = 0;
}

}  // namespace

extern "C" {

int32_t brume_embree_device_new(const char *config, BrumeEmbreeDevice **out, char **error) {
    return guarded(error, [&]() -> int32_t {
        if (!out) {
            return fail(error, BRUME_EMBREE_INVALID_ARGUMENT, "NULL output pointer");
        }
        *out = nullptr;
        auto *d = new BrumeEmbreeDevice();
        d->device = rtcNewDevice(config ? config : "");
        if (!d->device) {
            // Without a device there is no callback yet: Embree keeps the error per thread.
            const RTCError code = rtcGetDeviceError(nullptr);
            delete d;
            return fail(error, BRUME_EMBREE_DEVICE_ERROR,
                        std::string("rtcNewDevice(\"") + (config ? config : "") +
                            "\"): " + error_name(code));
        }
        rtcSetDeviceErrorFunction(d->device, on_error, d);
        rtcSetDeviceMemoryMonitorFunction(d->device, on_memory, d);
        *out = d;
        return BRUME_EMBREE_OK;
    });
}

void brume_embree_device_free(BrumeEmbreeDevice *device) {
    try {
        release_device(device);
    } catch (...) {
    }
}

int64_t brume_embree_device_memory(const BrumeEmbreeDevice *device) {
    return device ? device->bytes.load(std::memory_order_relaxed) : 0;
}

int32_t brume_embree_scene_new(BrumeEmbreeDevice *device, const float *vertices,
                               size_t vertex_count, const uint32_t *indices,
                               size_t triangle_count, BrumeEmbreeScene **out, char **error) {
    return guarded(error, [&]() -> int32_t {
        if (!device || !out) {
            return fail(error, BRUME_EMBREE_INVALID_ARGUMENT, "NULL device or output pointer");
        }
        *out = nullptr;
        if (int32_t s = check_mesh(vertices, vertex_count, indices, triangle_count, error)) {
            return s;
        }
        clear_device_error(device);
        RTCScene scene = rtcNewScene(device->device);
        if (!scene) {
            return take_device_error(device, "rtcNewScene", error);
        }
        const int32_t s =
            fill_scene(device, scene, vertices, vertex_count, indices, triangle_count, error);
        if (s != BRUME_EMBREE_OK) {
            rtcReleaseScene(scene);
            return s;
        }
        device->refs.fetch_add(1, std::memory_order_relaxed);
        *out = new BrumeEmbreeScene{device, scene, {}};
        return BRUME_EMBREE_OK;
    });
}

int32_t brume_embree_instanced_scene_new(BrumeEmbreeDevice *device,
                                         const BrumeEmbreeMesh *meshes, size_t mesh_count,
                                         const BrumeEmbreeInstance *instances,
                                         size_t instance_count, BrumeEmbreeScene **out,
                                         char **error) {
    return guarded(error, [&]() -> int32_t {
        if (!device || !out || (mesh_count && !meshes) || (instance_count && !instances)) {
            return fail(error, BRUME_EMBREE_INVALID_ARGUMENT,
                        "NULL device, output, mesh or instance pointer");
        }
        *out = nullptr;
        if (instance_count > UINT32_MAX - 1) {
            return fail(error, BRUME_EMBREE_INVALID_ARGUMENT,
                        "more instances than 32-bit identifiers address");
        }
        clear_device_error(device);
        // Owns the scenes built so far: released on any failure or exception.
        struct Building {
            RTCScene top = nullptr;
            std::vector<RTCScene> children;
            ~Building() { release_scenes(top, children); }
        } b;
        b.children.reserve(mesh_count);
        if (int32_t s = fill_instanced(device, meshes, mesh_count, instances, instance_count,
                                       &b.top, b.children, error)) {
            return s;
        }
        auto *scene = new BrumeEmbreeScene{device, b.top, std::move(b.children)};
        b.top = nullptr;
        b.children.clear();
        device->refs.fetch_add(1, std::memory_order_relaxed);
        *out = scene;
        return BRUME_EMBREE_OK;
    });
}

void brume_embree_scene_free(BrumeEmbreeScene *scene) {
    try {
        if (scene) {
            release_scenes(scene->scene, scene->meshes);
            release_device(scene->owner);
            delete scene;
        }
    } catch (...) {
    }
}

int32_t brume_embree_intersect(const BrumeEmbreeScene *scene, const float origin[3],
                               const float direction[3], float t_near, float t_far,
                               BrumeEmbreeHit *hit) {
    try {
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        RTCRayHit rh;
        ray_of(rh.ray, origin, direction, t_near, t_far);
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(scene->scene, &context, &rh);
        if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
            return 0;
        }
        *hit = BrumeEmbreeHit{rh.hit.instID[0], rh.hit.primID, rh.ray.tfar, rh.hit.u, rh.hit.v};
        return 1;
    } catch (...) {
        return 0;  // not reached: Embree reports its own failures to the error callback
    }
}

int32_t brume_embree_occluded(const BrumeEmbreeScene *scene, const float origin[3],
                              const float direction[3], float t_near, float t_far) {
    try {
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        RTCRay r;
        ray_of(r, origin, direction, t_near, t_far);
        rtcOccluded1(scene->scene, &context, &r);
        // Embree marks an occluded ray by setting tfar to -inf.
        return r.tfar < 0.0f && std::isinf(r.tfar) ? 1 : 0;
    } catch (...) {
        return 0;
    }
}

void brume_embree_string_free(char *s) { std::free(s); }

}  // extern "C"
