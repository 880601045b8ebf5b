// Brume's C ABI over OpenVDB. See brume_vdb.h for the contract.
//
// Every entry point runs its body through `guarded`, which turns any exception into a status
// and an owned copy of its message: OpenVDB throws freely (IoError on bad magic, ValueError,
// std::bad_alloc on corrupt sizes, std::ios_base::failure on truncation) and an exception that
// unwound into Rust would abort the process.
#include "brume_vdb_internal.h"

#include <openvdb/openvdb.h>
#include <openvdb/io/Stream.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/LevelSetUtil.h>
#include <openvdb/tools/Prune.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <new>
#include <sstream>
#include <string>
#include <vector>

#include <ext/stdio_filebuf.h>
#include <unistd.h>
#include <fcntl.h>
#include <poll.h>
#include <spawn.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

struct BrumeVdbFloatGrid {
    openvdb::FloatGrid::Ptr grid;
};

namespace brume_vdb {

void ensure_initialized() {
    static std::once_flag once;
    std::call_once(once, [] { openvdb::initialize(); });
}

} // namespace brume_vdb

using namespace brume_vdb;

namespace {

int32_t grid_class_of(openvdb::GridClass c) {
    switch (c) {
    case openvdb::GRID_LEVEL_SET: return BRUME_VDB_CLASS_LEVEL_SET;
    case openvdb::GRID_FOG_VOLUME: return BRUME_VDB_CLASS_FOG_VOLUME;
    case openvdb::GRID_STAGGERED: return BRUME_VDB_CLASS_STAGGERED;
    default: return BRUME_VDB_CLASS_UNKNOWN;
    }
}

// OpenVDB multiplies row vectors (p' = p * M); Brume's matrices act on column vectors.
void world_from_index_of(const openvdb::math::Transform &xform, double out[16]) {
    const openvdb::Mat4d m = xform.baseMap()->getAffineMap()->getMat4();
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) out[r * 4 + c] = m(c, r);
}

std::vector<std::string> metadata_triples(const openvdb::MetaMap &meta) {
    std::vector<std::string> out;
    for (auto it = meta.beginMeta(); it != meta.endMeta(); ++it) {
        out.push_back(it->first);
        out.push_back(it->second ? it->second->typeName() : std::string("null"));
        out.push_back(it->second ? it->second->str() : std::string());
    }
    return out;
}

char **owned_strings(const std::vector<std::string> &v) {
    char **out = static_cast<char **>(std::calloc(v.size() ? v.size() : 1, sizeof(char *)));
    if (!out) throw std::bad_alloc();
    for (size_t i = 0; i < v.size(); ++i) out[i] = owned_copy(v[i]);
    return out;
}

} // namespace

void brume_vdb::fill_info(const openvdb::GridBase &grid, BrumeVdbGridInfo *out) {
    std::memset(out, 0, sizeof(*out));
    const auto &xform = grid.transform();
    out->is_affine = xform.isLinear() ? 1 : 0;
    const openvdb::Vec3d vs = xform.voxelSize();
    for (int i = 0; i < 3; ++i) out->voxel_size[i] = vs[i];
    if (out->is_affine) world_from_index_of(xform, out->world_from_index);
    const openvdb::CoordBBox bbox = grid.evalActiveVoxelBoundingBox();
    if (!bbox.empty()) {
        out->has_active_bbox = 1;
        for (int i = 0; i < 3; ++i) {
            out->active_bbox_min[i] = bbox.min()[i];
            out->active_bbox_max[i] = bbox.max()[i];
        }
    }
    out->active_voxel_count = grid.activeVoxelCount();
    out->leaf_count = grid.baseTree().leafCount();
    out->grid_class = grid_class_of(grid.getGridClass());
    if (const auto *fg = dynamic_cast<const openvdb::FloatGrid *>(&grid)) {
        out->tile_count = count_tiles(fg->tree());
        out->has_background = 1;
        out->background = fg->background();
    } else if (const auto *dg = dynamic_cast<const openvdb::DoubleGrid *>(&grid)) {
        out->tile_count = dg->tree().activeTileCount();
        out->has_background = 1;
        out->background = dg->background();
    } else if (const auto *vs = dynamic_cast<const openvdb::Vec3SGrid *>(&grid)) {
        out->tile_count = count_tiles(vs->tree());
    } else if (const auto *vd = dynamic_cast<const openvdb::Vec3DGrid *>(&grid)) {
        out->tile_count = count_tiles(vd->tree());
    } else {
        out->tile_count = grid.baseTree().activeTileCount();
    }
    const auto meta = metadata_triples(grid);
    out->metadata_count = meta.size() / 3;
    out->metadata = owned_strings(meta);
    // Strings last: everything that can throw has run, so nothing leaks on failure.
    out->name = owned_copy(grid.getName());
    out->value_type = owned_copy(grid.valueType());
}

openvdb::GridBase::Ptr brume_vdb::find_grid(const BrumeVdbFile &file, const char *name) {
    for (const auto &g : *file.grids)
        if (g && g->getName() == name) return g;
    throw Failure{BRUME_VDB_NOT_FOUND, std::string("no grid named '") + name + "'"};
}

namespace {

openvdb::math::Transform::Ptr transform_from(const double m[16]) {
    openvdb::Mat4d vdb;
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) vdb(c, r) = m[r * 4 + c];
    return openvdb::math::Transform::createLinearTransform(vdb);
}

template <typename GridT, typename ValueOf>
typename GridT::Ptr build_grid(const BrumeVdbGridSpec &spec, ValueOf value_of) {
    auto grid = GridT::create(value_of(spec.background));
    auto acc = grid->getAccessor();
    for (size_t i = 0; i < spec.count; ++i) {
        const openvdb::Coord ijk(spec.coords[3 * i], spec.coords[3 * i + 1], spec.coords[3 * i + 2]);
        acc.setValue(ijk, value_of(spec.values[i]));
    }
    if (spec.prune) openvdb::tools::prune(grid->tree());
    return grid;
}

// A vector grid from one 3-vector a voxel (spec.vectors), in GridT's precision.
template <typename GridT> typename GridT::Ptr build_vector_grid(const BrumeVdbGridSpec &spec) {
    using V = typename GridT::ValueType;
    const float *b = spec.vector_background;
    auto grid = GridT::create(V(b[0], b[1], b[2]));
    auto acc = grid->getAccessor();
    for (size_t i = 0; i < spec.count; ++i) {
        const openvdb::Coord ijk(spec.coords[3 * i], spec.coords[3 * i + 1], spec.coords[3 * i + 2]);
        const float *v = spec.vectors + 3 * i;
        acc.setValue(ijk, V(v[0], v[1], v[2]));
    }
    if (spec.prune) openvdb::tools::prune(grid->tree());
    return grid;
}


std::ifstream open_checked(const char *path) {
    std::error_code ec;
    const std::filesystem::path p(path);
    require(std::filesystem::exists(p, ec), BRUME_VDB_IO_ERROR, "no such file");
    require(!std::filesystem::is_directory(p, ec), BRUME_VDB_IO_ERROR,
            "is a directory, not a .vdb file");
    require(std::filesystem::is_regular_file(p, ec), BRUME_VDB_IO_ERROR, "not a regular file");
    require(std::filesystem::file_size(p, ec) > 0, BRUME_VDB_FORMAT_ERROR, "empty file");
    std::ifstream is(p, std::ios::in | std::ios::binary);
    require(is.good(), BRUME_VDB_IO_ERROR, "cannot open for reading");
    // With exceptions on, a truncated file fails at the short read instead of handing
    // OpenVDB zero-filled sizes.
    is.exceptions(std::ios::badbit | std::ios::failbit);
    return is;
}

std::unique_ptr<BrumeVdbFile> read_file(std::istream &is) {
    // Stream, not io::File: no delayed loading or memory mapping, so everything is read
    // (and every error raised) here, inside the guard.
    openvdb::io::Stream stream(is, /*delayLoad=*/false);
    auto file = std::make_unique<BrumeVdbFile>();
    file->metadata = stream.getMetadata();
    file->grids = stream.getGrids();
    require(file->grids != nullptr, BRUME_VDB_FORMAT_ERROR, "no grids could be read");
    return file;
}

// What the child sends before anything else.
constexpr char CHILD_OK = 'O';
constexpr char CHILD_FAILED = 'E';

// The reader process's whole life: parse the untrusted file, then write what it read back in
// OpenVDB's own format (no compression: the pipe is local; no statistics: not needed). Never
// returns.
[[noreturn]] void child_reads(const char *path, int fd) {
    // glibc's "malloc(): invalid size" as the reader dies would read like Brume's own output;
    // the parent reports the crash in its place. Nor may the reader hold the parent's stdout
    // open (a test harness reading it would wait for the reader too).
    const int devnull = ::open("/dev/null", O_WRONLY | O_CLOEXEC);
    if (devnull >= 0) {
        ::dup2(devnull, STDOUT_FILENO);
        ::dup2(devnull, STDERR_FILENO);
    }
    // The same exception-to-status mapping as every entry point.
    char *error = nullptr;
    const int32_t status = guarded(&error, [&] {
        std::ifstream is = open_checked(path);
        auto file = read_file(is);
        __gnu_cxx::stdio_filebuf<char> buf(fd, std::ios::out | std::ios::binary);
        std::ostream os(&buf);
        os.put(CHILD_OK);
        openvdb::io::Stream stream(os);
        stream.setGridStatsMetadataEnabled(false);
        stream.setCompression(openvdb::io::COMPRESS_NONE);
        openvdb::GridCPtrVec grids(file->grids->begin(), file->grids->end());
        stream.write(grids, file->metadata ? *file->metadata : openvdb::MetaMap());
        os.flush();
        _exit(os.good() ? 0 : 3);
    });
    std::string out(1, CHILD_FAILED);
    out.append(reinterpret_cast<const char *>(&status), sizeof(status));
    out += error ? error : "unknown failure";
    for (size_t done = 0; done < out.size();) {
        const ssize_t n = ::write(fd, out.data() + done, out.size() - done);
        if (n <= 0 && errno != EINTR) break;
        if (n > 0) done += size_t(n);
    }
    _exit(0);
}

std::string signal_name(int sig) {
    const char *name = strsignal(sig);
    return std::string(name ? name : "unknown signal") + " (signal " + std::to_string(sig) + ")";
}

// Where the reader process finds its file and its pipe.
constexpr const char *READER_ENV = "BRUME_VDB_READER_CHILD";
constexpr const char *READER_PARENT_ENV = "BRUME_VDB_READER_PARENT";
constexpr int READER_FD = 3;

// Starts a reader process for `path` (this same executable, re-run: see
// brume_vdb_reader_entry), collects what it sends into `bytes` (OpenVDB's own encoding of the
// grids) and waits for it. Throws Failure for a crashed, hung or failed reader.
//
// A fresh exec, not a bare fork: OpenVDB's writer runs TBB parallel loops, and in a forked copy
// of a process whose TBB pool is already running they wait forever for worker threads that the
// copy does not have (seen: LeafManager::initLeafArray under Archive::writeGrid).
void read_in_child(const char *path, double timeout_seconds, std::string &bytes) {
    int fds[2];
    require(::pipe2(fds, O_CLOEXEC) == 0, BRUME_VDB_INTERNAL, "cannot create a pipe");
    std::vector<std::string> env_strings;
    // The reader's own variables are set below, never inherited.
    const char *own = "BRUME_VDB_READER_";
    for (char **e = environ; e && *e; ++e) {
        if (std::strncmp(*e, own, std::strlen(own)) == 0) continue;
        env_strings.emplace_back(*e);
    }
    env_strings.push_back(std::string(READER_ENV) + "=" + path);
    env_strings.push_back(std::string(READER_PARENT_ENV) + "=" + std::to_string(::getpid()));
    std::vector<char *> envp;
    for (auto &e : env_strings) envp.push_back(e.data());
    envp.push_back(nullptr);
    char arg0[] = "brume-vdb-reader";
    char *argv[] = {arg0, nullptr};
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    // dup2 onto READER_FD clears close-on-exec there; every other descriptor of ours closes.
    posix_spawn_file_actions_adddup2(&actions, fds[1], READER_FD);
    pid_t pid = -1;
    const int spawned =
        ::posix_spawn(&pid, "/proc/self/exe", &actions, nullptr, argv, envp.data());
    posix_spawn_file_actions_destroy(&actions);
    ::close(fds[1]);
    if (spawned != 0) {
        ::close(fds[0]);
        throw Failure{BRUME_VDB_INTERNAL, std::string("cannot start a process to read the file: ") +
                                              std::strerror(spawned)};
    }
    const auto start = std::chrono::steady_clock::now();
    bool timed_out = false;
    char chunk[1 << 16];
    for (;;) {
        int wait_ms = -1;
        if (timeout_seconds > 0) {
            const double left = timeout_seconds - std::chrono::duration<double>(
                                                      std::chrono::steady_clock::now() - start)
                                                      .count();
            if (left <= 0) {
                timed_out = true;
                break;
            }
            wait_ms = int(std::min(left * 1000.0 + 1.0, 60000.0));
        }
        pollfd p{fds[0], POLLIN, 0};
        const int r = ::poll(&p, 1, wait_ms);
        if (r < 0 && errno == EINTR) continue;
        if (r == 0) continue;
        const ssize_t n = ::read(fds[0], chunk, sizeof(chunk));
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) break;
        bytes.append(chunk, size_t(n));
    }
    ::close(fds[0]);
    if (timed_out) ::kill(pid, SIGKILL);
    int wstatus = 0;
    while (::waitpid(pid, &wstatus, 0) < 0 && errno == EINTR) {
    }
    if (timed_out) {
        std::ostringstream m;
        m << "OpenVDB's reader did not finish within " << timeout_seconds
          << " s (the file is corrupt, or too large for the limit)";
        throw Failure{BRUME_VDB_READER_CRASHED, m.str()};
    }
    if (WIFSIGNALED(wstatus)) {
        const int sig = WTERMSIG(wstatus);
        throw Failure{BRUME_VDB_READER_CRASHED,
                      "OpenVDB's reader crashed on this file with " + signal_name(sig) +
                          (sig == SIGKILL ? " (out of memory?)" : "") +
                          ": the file is corrupt (it was read in a separate process, so only "
                          "that process died)"};
    }
    require(WIFEXITED(wstatus) && WEXITSTATUS(wstatus) == 0, BRUME_VDB_INTERNAL,
            WIFEXITED(wstatus) && WEXITSTATUS(wstatus) == 127
                ? "cannot run the process to read the file (/proc/self/exe)"
                : "the process reading the file failed");
    require(!bytes.empty(), BRUME_VDB_INTERNAL, "the process reading the file sent nothing");
    if (bytes[0] == CHILD_FAILED) {
        int32_t status = BRUME_VDB_INTERNAL;
        require(bytes.size() >= 1 + sizeof(status), BRUME_VDB_INTERNAL,
                "the process reading the file sent a short error");
        std::memcpy(&status, bytes.data() + 1, sizeof(status));
        throw Failure{status, bytes.substr(1 + sizeof(status))};
    }
    require(bytes[0] == CHILD_OK, BRUME_VDB_INTERNAL,
            "the process reading the file sent an unknown reply");
}

} // namespace

// The reader process: this executable re-run by read_in_child with READER_ENV naming the file.
// It runs before main (the Rust runtime never starts), reads, writes to READER_FD and exits.
// Every program that links the shim can thus serve as its own reader, tests included.
__attribute__((constructor)) static void brume_vdb_reader_entry() {
    const char *path = std::getenv(READER_ENV);
    if (!path) return;
    // Die with the process that asked (killed by a watchdog, say) instead of lingering.
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    const char *parent = std::getenv(READER_PARENT_ENV);
    if (!parent || std::to_string(::getppid()) != parent) _exit(4);
    child_reads(path, READER_FD);
}

extern "C" {

void brume_vdb_string_free(char *s) { std::free(s); }

void brume_vdb_strings_free(char **strings, size_t n) {
    if (!strings) return;
    for (size_t i = 0; i < n; ++i) std::free(strings[i]);
    std::free(strings);
}

int32_t brume_vdb_open(const char *path, BrumeVdbFile **out, char **error) {
    return guarded(error, [&] {
        require(path && out, BRUME_VDB_INVALID_ARGUMENT, "null argument");
        *out = nullptr;
        std::ifstream is = open_checked(path);
        *out = read_file(is).release();
    });
}

int32_t brume_vdb_open_isolated(const char *path, double timeout_seconds, BrumeVdbFile **out,
                                char **error) {
    return guarded(error, [&] {
        require(path && out, BRUME_VDB_INVALID_ARGUMENT, "null argument");
        *out = nullptr;
        std::string bytes;
        // The checks that need no OpenVDB run here, so their errors read as usual.
        open_checked(path);
        read_in_child(path, timeout_seconds, bytes);
        std::istringstream is(bytes, std::ios::in | std::ios::binary);
        std::string().swap(bytes); // the stream holds its own copy
        is.exceptions(std::ios::badbit | std::ios::failbit);
        is.get(); // CHILD_OK
        *out = read_file(is).release();
    });
}

void brume_vdb_file_free(BrumeVdbFile *file) { delete file; }

int32_t brume_vdb_grid_count(const BrumeVdbFile *file, size_t *count, char **error) {
    return guarded(error, [&] {
        require(file && count, BRUME_VDB_INVALID_ARGUMENT, "null argument");
        *count = file->grids->size();
    });
}

int32_t brume_vdb_grid_info(const BrumeVdbFile *file, size_t index, BrumeVdbGridInfo *out,
                            char **error) {
    return guarded(error, [&] {
        require(file && out, BRUME_VDB_INVALID_ARGUMENT, "null argument");
        require(index < file->grids->size(), BRUME_VDB_NOT_FOUND, "grid index out of range");
        const auto &grid = (*file->grids)[index];
        require(grid != nullptr, BRUME_VDB_FORMAT_ERROR, "null grid in file");
        fill_info(*grid, out);
    });
}

void brume_vdb_grid_info_free(BrumeVdbGridInfo *info) {
    if (!info) return;
    std::free(info->name);
    std::free(info->value_type);
    brume_vdb_strings_free(info->metadata, 3 * info->metadata_count);
    std::memset(info, 0, sizeof(*info));
}

int32_t brume_vdb_file_metadata(const BrumeVdbFile *file, size_t *count, char ***triples,
                                char **error) {
    return guarded(error, [&] {
        require(file && count && triples, BRUME_VDB_INVALID_ARGUMENT, "null argument");
        std::vector<std::string> meta;
        if (file->metadata) meta = metadata_triples(*file->metadata);
        *triples = owned_strings(meta);
        *count = meta.size() / 3;
    });
}

int32_t brume_vdb_float_grid_open(const BrumeVdbFile *file, const char *name, uint32_t flags,
                                  BrumeVdbFloatGrid **out, char **error) {
    return guarded(error, [&] {
        require(file && name && out, BRUME_VDB_INVALID_ARGUMENT, "null argument");
        *out = nullptr;
        openvdb::GridBase::Ptr found;
        for (const auto &g : *file->grids)
            if (g && g->getName() == name) {
                found = g;
                break;
            }
        if (!found) throw Failure{BRUME_VDB_NOT_FOUND, std::string("no grid named '") + name + "'"};
        auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(found);
        if (!grid)
            throw Failure{BRUME_VDB_TYPE_ERROR, std::string("grid '") + name + "' holds " +
                                                    found->valueType() + " values, not float"};
        require(grid->transform().isLinear(), BRUME_VDB_TYPE_ERROR,
                "grid has a non-affine (frustum) transform, which Brume does not support");
        auto copy = grid->deepCopy();
        if ((flags & BRUME_VDB_LEVEL_SET_TO_FOG) && copy->getGridClass() == openvdb::GRID_LEVEL_SET)
            openvdb::tools::sdfToFogVolume(*copy);
        *out = new BrumeVdbFloatGrid{copy};
    });
}

void brume_vdb_float_grid_free(BrumeVdbFloatGrid *grid) { delete grid; }

int32_t brume_vdb_float_grid_info(const BrumeVdbFloatGrid *grid, BrumeVdbGridInfo *out,
                                  char **error) {
    return guarded(error, [&] {
        require(grid && out, BRUME_VDB_INVALID_ARGUMENT, "null argument");
        fill_info(*grid->grid, out);
    });
}

int32_t brume_vdb_float_grid_counts(const BrumeVdbFloatGrid *grid, size_t *leaf_count,
                                    size_t *tile_count, float *background, char **error) {
    return guarded(error, [&] {
        require(grid && leaf_count && tile_count && background, BRUME_VDB_INVALID_ARGUMENT,
                "null argument");
        const auto &tree = grid->grid->tree();
        *leaf_count = tree.leafCount();
        *tile_count = count_tiles(tree);
        *background = tree.background();
    });
}

int32_t brume_vdb_float_grid_copy_leaves(const BrumeVdbFloatGrid *grid, int32_t *origins,
                                         float *values, uint64_t *masks, size_t capacity,
                                         char **error) {
    return copy_leaves_of(grid, origins, values, masks, capacity, error);
}

int32_t brume_vdb_float_grid_copy_tiles(const BrumeVdbFloatGrid *grid, int32_t *origins,
                                        uint32_t *dims, float *values, uint8_t *active,
                                        size_t capacity, char **error) {
    return copy_tiles_of(grid, origins, dims, values, active, capacity, error);
}

int32_t brume_vdb_float_grid_sample(const BrumeVdbFloatGrid *grid, const double *points, size_t n,
                                    int32_t order, float *out, char **error) {
    return guarded(error, [&] {
        require(grid && (points || n == 0) && (out || n == 0), BRUME_VDB_INVALID_ARGUMENT,
                "null argument");
        require(order == 0 || order == 1, BRUME_VDB_INVALID_ARGUMENT, "order must be 0 or 1");
        auto acc = grid->grid->getConstAccessor();
        if (order == 0) {
            for (size_t i = 0; i < n; ++i)
                out[i] = openvdb::tools::PointSampler::sample(
                    acc, openvdb::Vec3R(points[3 * i], points[3 * i + 1], points[3 * i + 2]));
        } else {
            for (size_t i = 0; i < n; ++i)
                out[i] = openvdb::tools::BoxSampler::sample(
                    acc, openvdb::Vec3R(points[3 * i], points[3 * i + 1], points[3 * i + 2]));
        }
    });
}

int32_t brume_vdb_write_float_grids(const char *path, const BrumeVdbGridSpec *grids, size_t n,
                                    char **error) {
    return guarded(error, [&] {
        require(path && (grids || n == 0), BRUME_VDB_INVALID_ARGUMENT, "null argument");
        openvdb::GridPtrVec out;
        for (size_t g = 0; g < n; ++g) {
            const BrumeVdbGridSpec &spec = grids[g];
            const bool vectors = spec.value_kind == 2 || spec.value_kind == 3;
            require(spec.name &&
                        (spec.count == 0 ||
                         (spec.coords && (vectors ? spec.vectors != nullptr : spec.values != nullptr))),
                    BRUME_VDB_INVALID_ARGUMENT, "grid spec has null pointers");
            openvdb::GridBase::Ptr grid;
            if (spec.value_kind == 0) {
                grid = build_grid<openvdb::FloatGrid>(spec, [](float v) { return v; });
            } else if (spec.value_kind == 1) {
                grid = build_grid<openvdb::Vec3SGrid>(
                    spec, [](float v) { return openvdb::Vec3s(v, v, v); });
            } else if (spec.value_kind == 2) {
                grid = build_vector_grid<openvdb::Vec3SGrid>(spec);
            } else if (spec.value_kind == 3) {
                grid = build_vector_grid<openvdb::Vec3DGrid>(spec);
            } else {
                throw Failure{BRUME_VDB_INVALID_ARGUMENT, "value_kind must be 0, 1, 2 or 3"};
            }
            grid->setName(spec.name);
            switch (spec.grid_class) {
            case BRUME_VDB_CLASS_LEVEL_SET: grid->setGridClass(openvdb::GRID_LEVEL_SET); break;
            case BRUME_VDB_CLASS_FOG_VOLUME: grid->setGridClass(openvdb::GRID_FOG_VOLUME); break;
            case BRUME_VDB_CLASS_STAGGERED: grid->setGridClass(openvdb::GRID_STAGGERED); break;
            default: grid->setGridClass(openvdb::GRID_UNKNOWN); break;
            }
            grid->setTransform(transform_from(spec.world_from_index));
            grid->setSaveFloatAsHalf(spec.save_as_half != 0);
            grid->insertMeta("creator", openvdb::StringMetadata("brume"));
            out.push_back(grid);
        }
        // Write next to the target and rename, so a failed write never leaves half a file. The
        // temporary name carries the process and a per-process count, so two writers of the
        // same path (threads or processes) never share one: each renames a whole file.
        static std::atomic<unsigned long> writes{0};
        const std::string tmp = std::string(path) + ".tmp-" + std::to_string(getpid()) + "-" +
                                std::to_string(writes.fetch_add(1));
        {
            openvdb::io::File file(tmp);
            file.setCompression(openvdb::io::Archive::hasBloscCompression()
                                    ? openvdb::io::COMPRESS_BLOSC | openvdb::io::COMPRESS_ACTIVE_MASK
                                    : openvdb::io::COMPRESS_ZIP | openvdb::io::COMPRESS_ACTIVE_MASK);
            openvdb::MetaMap meta;
            meta.insertMeta("creator", openvdb::StringMetadata("brume"));
            file.write(out, meta);
            file.close();
        }
        std::error_code ec;
        std::filesystem::rename(tmp, path, ec);
        if (ec) {
            std::filesystem::remove(tmp, ec);
            throw Failure{BRUME_VDB_IO_ERROR, "cannot rename the written file into place"};
        }
    });
}

} // extern "C"
