// ivoct export/ — the C entry points, .ply and .obj meshes, and recognising files
// for `ivoct info` (read in a child process).  Includes neither VTK nor OpenVDB.
#include <cerrno>
#include <csignal>
#include <ctime>
#include <dirent.h>
#include <fcntl.h>
#include <poll.h>
#include <sys/prctl.h>
#include <cstring>
#include <strings.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>

#include "internal.hpp"

namespace ivexp {

namespace {

const char *extension(const char *path)
{
    const char *slash = std::strrchr(path, '/');
    const char *dot = std::strrchr(slash ? slash : path, '.');
    return dot ? dot : "";
}

void put_u32le(unsigned char *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (unsigned char)(v >> (8 * i));
}

void write_ply(const Mesh &m, const oct_source_t *src, const char *path)
{
    Output out(path);
    size_t nv = m.points.size() / 3, nt = m.tris.size() / 3;
    std::string header = "ply\nformat binary_little_endian 1.0\ncomment written by ivoct\n";
    if (src && src->name && !std::strpbrk(src->name, "\r\n"))
        header += std::string("comment scene ") + src->name + "\n";
    const char *type = m.doubles ? "double" : "float";
    header += "element vertex " + std::to_string(nv) + "\nproperty " + type + " x\nproperty " +
              type + " y\nproperty " + type + " z\n"
              "element face " + std::to_string(nt) +
              "\nproperty list uchar int vertex_indices\nend_header\n";
    out.write(header.data(), header.size());
    std::vector<unsigned char> buf;
    buf.reserve(4096 * 13);
    auto flush = [&] {
        out.write(buf.data(), buf.size());
        buf.clear();
    };
    for (size_t i = 0; i < 3 * nv; i++) {
        unsigned char b[8];
        if (m.doubles) {
            uint64_t bits;
            std::memcpy(&bits, &m.points[i], 8);
            put_u32le(b, (uint32_t)bits);
            put_u32le(b + 4, (uint32_t)(bits >> 32));
            buf.insert(buf.end(), b, b + 8);
        } else {
            float x = (float)m.points[i];
            uint32_t bits;
            std::memcpy(&bits, &x, 4);
            put_u32le(b, bits);
            buf.insert(buf.end(), b, b + 4);
        }
        if (buf.size() >= 4096 * 12)
            flush();
    }
    for (size_t t = 0; t < nt; t++) {
        unsigned char b[13];
        b[0] = 3;
        for (int k = 0; k < 3; k++)
            put_u32le(b + 1 + 4 * k, m.tris[3 * t + k]);
        buf.insert(buf.end(), b, b + 13);
        if (buf.size() >= 4096 * 12)
            flush();
    }
    flush();
    out.commit();
}

void write_obj(const Mesh &m, const oct_source_t *src, const char *path)
{
    Output out(path);
    FILE *f = out.file();
    std::fprintf(f, "# written by ivoct\n");
    if (src && src->name && !std::strpbrk(src->name, "\r\n"))
        std::fprintf(f, "# scene %s\n", src->name);
    const char *fmt = m.doubles ? "v %.17g %.17g %.17g\n" : "v %.9g %.9g %.9g\n";
    for (size_t i = 0; i + 2 < m.points.size(); i += 3)
        std::fprintf(f, fmt, m.points[i], m.points[i + 1], m.points[i + 2]);
    for (size_t t = 0; t + 2 < m.tris.size(); t += 3)
        std::fprintf(f, "f %lu %lu %lu\n", (unsigned long)m.tris[t] + 1,
                     (unsigned long)m.tris[t + 1] + 1, (unsigned long)m.tris[t + 2] + 1);
    out.commit();
}

enum class Format { none, vtk, vdb };

// VDB files start with the 64-bit magic number 0x56444220 ("VDB " little-endian);
// VTK XML files with an XML declaration or the VTKFile element.
Format sniff(const char *path)
{
    FILE *f = std::fopen(path, "rb");
    if (!f)
        return Format::none;
    unsigned char b[16] = {0};
    size_t n = std::fread(b, 1, sizeof b, f);
    std::fclose(f);
    static const unsigned char vdb[8] = {0x20, 0x42, 0x44, 0x56, 0, 0, 0, 0};
    if (n >= 8 && !std::memcmp(b, vdb, 8))
        return Format::vdb;
    if ((n >= 5 && !std::memcmp(b, "<?xml", 5)) || (n >= 8 && !std::memcmp(b, "<VTKFile", 8)))
        return Format::vtk;
    return Format::none;
}

// VTK 9.1's and OpenVDB 10's readers are not safe on corrupt files: fuzzing found a
// null dereference in VTK's HyperTreeGrid reader (an unknown array type) and a heap
// overflow in OpenVDB's Blosc decoding (tests/fuzz/corpus/vtk, vdb).  So `info` reads
// an export in a child process, which sends back a status byte and the summary (or the
// error) through a pipe; a child that dies is a file the library could not read.
// The child's stderr is /dev/null, and the sanitizer's death callback (libFuzzer's, in
// the fuzz targets) is cleared there: a crash in the child is not the parent's.
extern "C" void __sanitizer_set_death_callback(void (*)(void)) __attribute__((weak));

// The readers also believe the sizes a file states: OpenVDB read a 10 KB file whose
// metadata claims gigabytes into 5 GB of memory.  The child may use 256 MiB plus 64 times
// the file's size beyond what it holds at the fork (RLIMIT_DATA, counted from VmData so
// that the sanitizers' reserved shadow memory does not count); past that an allocation
// fails, which the readers report (bad_alloc) or die of.
// CPU seconds the child may take (the depth-9 exports of the tests, 30-120 MB, read in
// about 1 s), and wall-clock seconds (the parent ends a child that takes longer).
// A .vdb has no pieces elsewhere, so its time is bounded by its size as well: 5 s and
// 1 s per 4 MiB, 25 times slower than the reading of real exports (fuzzing found an
// 11 KB file whose tree OpenVDB reads for 30 s of CPU).  A VTK index names pieces of
// any size: its reader has the whole bound.
constexpr rlim_t CHILD_CPU_SECONDS = 120;
constexpr unsigned CHILD_WALL_SECONDS = 600;

rlim_t child_cpu_seconds(Format fmt, const char *path)
{
    struct stat st;
    if (fmt != Format::vdb || stat(path, &st) || st.st_size < 0)
        return CHILD_CPU_SECONDS;
    rlim_t t = 5 + (rlim_t)st.st_size / ((rlim_t)4 << 20);
    return t < CHILD_CPU_SECONDS ? t : CHILD_CPU_SECONDS;
}

void limit_child_memory(const char *path)
{
    struct stat st;
    FILE *f = std::fopen("/proc/self/status", "r");
    if (!f || stat(path, &st))
        return (void)(f && std::fclose(f));
    unsigned long long kb = 0;
    char line[256];
    while (std::fgets(line, sizeof line, f))
        if (std::sscanf(line, "VmData: %llu kB", &kb) == 1)
            break;
    std::fclose(f);
    if (!kb)
        return;
    rlim_t size = st.st_size > 0 ? (rlim_t)st.st_size : 0;
    rlim_t budget = ((rlim_t)1 << 28) + (size < ((rlim_t)1 << 40) ? 64 * size : ((rlim_t)1 << 46));
    struct rlimit rl;
    if (getrlimit(RLIMIT_DATA, &rl) == 0) {
        rlim_t want = (rlim_t)kb * 1024 + budget;
        if (rl.rlim_max == RLIM_INFINITY || want < rl.rlim_max)
            rl.rlim_cur = want;
        setrlimit(RLIMIT_DATA, &rl);
    }
}

// A child forked from a process with other threads inherits their locks as they were at
// the fork, and one held there is never released in the child.  The threads ivoct has
// besides the caller sleep once started (the CLI's signal thread in sigwait, the pool
// that OpenVDB's log4cplus starts at load time in a condition wait); while one is still
// starting it may hold the allocator's lock (ASan's does, in clang 14: the child hung in
// malloc, about one `ivoct info` in thirty on a loaded machine).  So the fork waits, up
// to a second, until every other thread of the process is asleep.
// The fields of a /proc/.../stat file after the process's or thread's name (which
// may hold spaces and parentheses: the last ')' ends it), into buf; NULL when the
// file cannot be read (the process or thread has ended)
const char *proc_stat_fields(const char *path, char *buf, size_t size)
{
    FILE *f = std::fopen(path, "r");
    if (!f)
        return nullptr;
    size_t n = std::fread(buf, 1, size - 1, f);
    std::fclose(f);
    buf[n] = 0;
    const char *end = std::strrchr(buf, ')');
    return end ? end + 1 : nullptr;
}

bool other_threads_asleep()
{
    DIR *dir = opendir("/proc/self/task");
    if (!dir)
        return true;  // no /proc: nothing to wait for that can be seen
    bool asleep = true;
    char self[32];
    std::snprintf(self, sizeof self, "%ld", (long)gettid());
    while (struct dirent *d = readdir(dir)) {
        if (d->d_name[0] == '.' || !std::strcmp(d->d_name, self))
            continue;
        char stat[512];
        std::string name = std::string("/proc/self/task/") + d->d_name + "/stat";
        const char *state = proc_stat_fields(name.c_str(), stat, sizeof stat);
        if (state && state[0] == ' ' && state[1] != 'S') {  // (a thread that ended: skipped)
            asleep = false;
            break;
        }
    }
    closedir(dir);
    return asleep;
}

void wait_for_other_threads_asleep()
{
    for (int i = 0; i < 200 && !other_threads_asleep(); i++) {
        struct timespec ts = {0, 5000000};
        nanosleep(&ts, nullptr);
    }
}

// The CPU time (user + system, in clock ticks, all its threads) and the state of
// process pid from /proc; false when it cannot be read (the process has ended)
bool process_cpu(pid_t pid, unsigned long long *ticks, char *state)
{
    char name[64], stat[1024];
    std::snprintf(name, sizeof name, "/proc/%ld/stat", (long)pid);
    const char *p = proc_stat_fields(name, stat, sizeof stat);
    unsigned long long utime = 0, stime = 0;
    if (!p || std::sscanf(p, " %c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %llu %llu", state,
                          &utime, &stime) != 3)
        return false;
    *ticks = utime + stime;
    return true;
}

// How one reading child ended: it answered (status byte and text in `got`), died
// (`status` from waitpid), or was ended by the parent: stuck (asleep without using any
// CPU for STUCK_SECONDS) or past CHILD_WALL_SECONDS; or it could not be started
// (failed: the error is in err)
enum class ChildEnd { answered, died, stuck, too_long, failed };

// A lock held by another thread at the fork (above) can still be inherited, since that
// thread may wake between the check and the fork: the child then sleeps on it forever.
// A reader that works uses CPU or waits on the disk (state D), so a child asleep (state
// S) that has not used a clock tick in two seconds is stuck; it is ended and the file
// read again by a new child, up to CHILD_TRIES times.  The parent ends the children
// itself (and each child dies with the parent, PR_SET_PDEATHSIG): none outlives the call.
constexpr int STUCK_SECONDS = 2;
constexpr int CHILD_TRIES = 3;

ChildEnd read_in_child(Format fmt, const char *path, std::string &got, int &status,
                       ivoct_error_t *err)
{
    int fd[2];
    if (pipe(fd)) {
        ivoct_error_set(err, "cannot read %s: %s", path, std::strerror(errno));
        return ChildEnd::failed;
    }
    wait_for_other_threads_asleep();
    pid_t parent = getpid();
    pid_t pid = fork();
    if (pid < 0) {
        ivoct_error_set(err, "cannot read %s: %s", path, std::strerror(errno));
        close(fd[0]);
        close(fd[1]);
        return ChildEnd::failed;
    }
    if (pid == 0) {
        close(fd[0]);
        prctl(PR_SET_PDEATHSIG, SIGKILL);
        if (getppid() != parent)  // the parent ended before the line above
            _exit(2);
        if (__sanitizer_set_death_callback)
            __sanitizer_set_death_callback(nullptr);
        for (int sig : {SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL})
            std::signal(sig, SIG_DFL);
        // the CLI blocks SIGINT, SIGTERM and SIGHUP for its signal thread, which the
        // child does not have: there they take their action (a Ctrl-C ends both)
        sigset_t stop;
        sigemptyset(&stop);
        for (int sig : {SIGINT, SIGTERM, SIGHUP})
            sigaddset(&stop, sig);
        sigprocmask(SIG_UNBLOCK, &stop, nullptr);
        limit_child_memory(path);
        // and time: a reader caught in a loop by a crafted file is ended by SIGXCPU;
        // real exports read in seconds
        const rlim_t cpu_seconds = child_cpu_seconds(fmt, path);
        struct rlimit cpu = {cpu_seconds, cpu_seconds + 1};
        setrlimit(RLIMIT_CPU, &cpu);
        // what a dying library prints (glibc's "free(): invalid pointer", a sanitizer's
        // report) is not ivoct's message: the parent reports the file
        int null_fd = open("/dev/null", O_WRONLY);
        if (null_fd >= 0) {
            dup2(null_fd, STDERR_FILENO);
            close(null_fd);
        }
        char *text = nullptr;
        size_t len = 0;
        FILE *mem = open_memstream(&text, &len);
        ivoct_error_t e;
        ivoct_error_clear(&e);
        int rc = !mem ? -1 : guard(&e, [&] {
            if (fmt == Format::vdb)
                vdb_info(path, mem);
            else
                vtk_info(path, mem);
        });
        if (mem)
            std::fclose(mem);
        std::string msg(1, rc ? '1' : '0');
        msg += rc ? (mem ? e.msg : "out of memory") : std::string(text ? text : "", len);
        for (size_t at = 0; at < msg.size();) {
            ssize_t w = write(fd[1], msg.data() + at, msg.size() - at);
            if (w <= 0 && errno != EINTR)
                _exit(2);
            at += w > 0 ? (size_t)w : 0;
        }
        _exit(0);  // not exit: the parent's stdio buffers and atexit handlers are its own
    }
    close(fd[1]);
    got.clear();
    ChildEnd end = ChildEnd::answered;
    struct timespec t0, idle_since;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    idle_since = t0;
    unsigned long long last_ticks = 0;
    auto seconds = [](const struct timespec &a, const struct timespec &b) {
        return (double)(b.tv_sec - a.tv_sec) + 1e-9 * (double)(b.tv_nsec - a.tv_nsec);
    };
    char buf[4096];
    for (;;) {
        struct pollfd p = {fd[0], POLLIN, 0};
        int ready = poll(&p, 1, 250);
        if (ready < 0 && errno != EINTR)
            break;
        if (ready > 0) {
            ssize_t r = read(fd[0], buf, sizeof buf);
            if (r > 0) {
                got.append(buf, (size_t)r);
                continue;
            }
            if (r == 0 || errno != EINTR)
                break;  // the child's end is closed: it has answered or died
        }
        struct timespec now;
        clock_gettime(CLOCK_MONOTONIC, &now);
        unsigned long long ticks = 0;
        char state = '?';
        if (!process_cpu(pid, &ticks, &state))
            continue;  // ended: the pipe says so next
        if (ticks != last_ticks || state != 'S') {
            last_ticks = ticks;
            idle_since = now;
        }
        if (seconds(idle_since, now) >= STUCK_SECONDS || seconds(t0, now) >= CHILD_WALL_SECONDS) {
            end = seconds(t0, now) >= CHILD_WALL_SECONDS ? ChildEnd::too_long : ChildEnd::stuck;
            kill(pid, SIGKILL);
            break;
        }
    }
    close(fd[0]);
    status = 0;
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    if (end != ChildEnd::answered)
        return end;
    return WIFEXITED(status) && WEXITSTATUS(status) == 0 && !got.empty() ? ChildEnd::answered
                                                                         : ChildEnd::died;
}

int info_in_child(Format fmt, const char *path, FILE *out, ivoct_error_t *err)
{
    const char *lib = fmt == Format::vdb ? "OpenVDB" : "VTK";
    std::fflush(out);
    std::string got;
    int status = 0;
    ChildEnd end = ChildEnd::stuck;
    for (int tries = 0; end == ChildEnd::stuck && tries < CHILD_TRIES; tries++)
        end = read_in_child(fmt, path, got, status, err);
    switch (end) {
    case ChildEnd::answered: break;
    case ChildEnd::failed: return -1;
    case ChildEnd::stuck:
        ivoct_error_set(err, "cannot read %s: %s's reader stopped (asleep without progress "
                             "%d times)", path, lib, CHILD_TRIES);
        return -1;
    case ChildEnd::too_long:
        ivoct_error_set(err, "cannot read %s: %s's reader did not finish in %u s", path, lib,
                        CHILD_WALL_SECONDS);
        return -1;
    case ChildEnd::died:
        if (WIFSIGNALED(status) && WTERMSIG(status) == SIGXCPU)
            ivoct_error_set(err, "cannot read %s: %s's reader did not finish in %u s of CPU",
                            path, lib, (unsigned)child_cpu_seconds(fmt, path));
        else if (WIFSIGNALED(status))
            ivoct_error_set(err, "cannot read %s: corrupt file (%s's reader died of signal %d)",
                            path, lib, WTERMSIG(status));
        else
            ivoct_error_set(err, "cannot read %s: corrupt file (%s's reader failed)", path, lib);
        return -1;
    }
    if (got[0] != '0') {
        ivoct_error_set(err, "%s", got.c_str() + 1);
        return -1;
    }
    std::fwrite(got.data() + 1, 1, got.size() - 1, out);
    return 0;
}

}  // namespace
}  // namespace ivexp

using namespace ivexp;

extern "C" {

int exp_cells(const oct_tree_t *tree, const char *path, int threads, ivoct_error_t *err)
{
    return guard(err, [&] { write_cells(tree, path, threads); });
}

size_t exp_cells_memory(const oct_tree_t *tree, int threads)
{
    return cells_memory(tree, threads);
}

int exp_vtu(const oct_tree_t *tree, const oct_source_t *src, const char *path,
            ivoct_error_t *err)
{
    return guard(err, [&] { vtk_write_vtu(tree, src, path); });
}

int exp_htg(const oct_tree_t *tree, const tape_t *tape, const oct_source_t *src,
            const char *path, ivoct_error_t *err)
{
    return guard(err, [&] { vtk_write_htg(tree, tape, src, path); });
}

int exp_htg_piece(const oct_tree_t *part, const tape_t *tape, const oct_source_t *src, int depth,
                  const uint64_t *frontier, size_t n, int top, const char *path,
                  ivoct_error_t *err)
{
    return guard(err, [&] { vtk_write_htg_piece(part, tape, src, depth, frontier, n, top, path); });
}

int exp_vdb(const oct_tree_t *tree, const tape_t *tape, const oct_source_t *src,
            const char *path, ivoct_error_t *err)
{
    return guard(err, [&] { vdb_write(tree, tape, src, path); });
}

int exp_mesh_supported(const char *path)
{
    const char *e = extension(path);
    return !strcasecmp(e, ".vtp") || !strcasecmp(e, ".ply") || !strcasecmp(e, ".obj");
}

// Write m in the format of path's extension.
void write_mesh(const Mesh &m, const oct_source_t *src, const char *path)
{
    const char *e = extension(path);
    if (!exp_mesh_supported(path))
        throw Error(std::string("cannot write ") + path +
                    ": unknown mesh format (the name must end in .vtp, .ply or .obj)");
    if (!strcasecmp(e, ".vtp"))
        vtk_write_vtp(m, src, path);
    else if (!strcasecmp(e, ".ply"))
        write_ply(m, src, path);
    else
        write_obj(m, src, path);
}

int exp_mesh(const oct_tree_t *tree, const tape_t *tape, const oct_source_t *src,
             const char *path, ivoct_error_t *err)
{
    return guard(err, [&] { write_mesh(vdb_mesh(tree, tape), src, path); });
}

int exp_mesh_write(const double *points, size_t n_points, const uint32_t *tris,
                   const int *tri_depth, size_t n_tris, const oct_source_t *src, const char *path,
                   ivoct_error_t *err)
{
    return guard(err, [&] {
        Mesh m;
        m.doubles = true;
        m.points.assign(points, points + 3 * n_points);
        m.tris.assign(tris, tris + 3 * n_tris);
        if (tri_depth)
            m.tri_depth.assign(tri_depth, tri_depth + n_tris);
        write_mesh(m, src, path);
    });
}

int exp_info(const char *path, FILE *out, ivoct_error_t *err)
{
    Format fmt = sniff(path);
    if (fmt == Format::none)
        return 1;
    // the reader's module is opened here, not in the child: dlopen after a fork
    // of a process with threads is not safe
    if (guard(err, [&] { fmt == Format::vdb ? vdb_load(path) : vtk_load(path); }))
        return -1;
    return info_in_child(fmt, path, out, err);
}

}  // extern "C"
