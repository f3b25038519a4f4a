/*
 * The port hand-over record (host/urb/managers/handover.py PortHandover): same directory rules,
 * file name and format, so C and Python processes hand a port over to each other.
 * Bridge.tla HostRestart (its premise: the next process sends nothing before this instant)
 */
#include "urb_port.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

static urb_ns_t wall_ns(void)
{
    struct timespec ts;
    (void)clock_gettime(CLOCK_REALTIME, &ts);
    return (urb_ns_t)ts.tv_sec * URB_NS_PER_S + (urb_ns_t)ts.tv_nsec;
}

static urb_ns_t add_sat(urb_ns_t a, urb_ns_t b)
{
    if ((b > 0) && (a > INT64_MAX - b)) {
        return INT64_MAX;
    }
    if ((b < 0) && (a < INT64_MIN + 1 - b)) {
        return INT64_MIN + 1;
    }
    return a + b;
}

/* handover.state_dir(), written into out; false when it does not fit. */
static bool state_dir(char *out, size_t size)
{
    const char *explicit_dir = getenv("URB_STATE_DIR");
    const char *runtime = getenv("XDG_RUNTIME_DIR");
    int n;
    if ((explicit_dir != NULL) && (explicit_dir[0] != '\0')) {
        n = snprintf(out, size, "%s", explicit_dir);
    } else if ((runtime != NULL) && (runtime[0] != '\0')) {
        n = snprintf(out, size, "%s/urb", runtime);
    } else {
        const char *tmp = NULL;
        const char *const names[] = {"TMPDIR", "TEMP", "TMP"}; /* tempfile.gettempdir()'s order */
        for (size_t i = 0u; (i < 3u) && (tmp == NULL); i++) {
            const char *v = getenv(names[i]);
            tmp = ((v != NULL) && (v[0] != '\0')) ? v : NULL;
        }
        n = snprintf(out, size, "%s/urb-%lu", (tmp == NULL) ? "/tmp" : tmp, (unsigned long)getuid());
    }
    return (n > 0) && ((size_t)n < size);
}

/* handover.record_name(): os.path.abspath(port), '/' stripped at both ends, then '/' as '_'
 * (abspath normalises lexically: "//", "." and ".." go, symbolic links stay). */
static bool record_name(const char *port, char *out, size_t size)
{
    char full[URB_PATH_MAX];
    int n;
    if (port[0] == '/') {
        n = snprintf(full, sizeof full, "%s", port);
    } else {
        char cwd[URB_PATH_MAX];
        if (getcwd(cwd, sizeof cwd) == NULL) {
            return false;
        }
        n = snprintf(full, sizeof full, "%s/%s", cwd, port);
    }
    if ((n < 0) || ((size_t)n >= sizeof full)) {
        return false;
    }
    /* the components, in place: starts[] marks where each kept one begins in `full` */
    size_t starts[URB_PATH_MAX / 2u];
    size_t lens[URB_PATH_MAX / 2u];
    size_t count = 0u;
    size_t i = 0u;
    size_t const len = (size_t)n;
    while (i < len) {
        while ((i < len) && (full[i] == '/')) {
            i++;
        }
        size_t const s = i;
        while ((i < len) && (full[i] != '/')) {
            i++;
        }
        size_t const l = i - s;
        if ((l == 0u) || ((l == 1u) && (full[s] == '.'))) {
            continue;
        }
        if ((l == 2u) && (full[s] == '.') && (full[s + 1u] == '.')) {
            if (count > 0u) {
                count--;
            }
            continue;
        }
        starts[count] = s;
        lens[count] = l;
        count++;
    }
    size_t o = 0u;
    for (size_t k = 0u; k < count; k++) {
        if (o + lens[k] + 2u > size) {
            return false;
        }
        if (k > 0u) {
            out[o++] = '_';
        }
        memcpy(out + o, full + starts[k], lens[k]);
        o += lens[k];
    }
    static const char suffix[] = ".handover";
    if (o + sizeof suffix > size) {
        return false;
    }
    memcpy(out + o, suffix, sizeof suffix);
    return true;
}

int32_t urb_handover_init(urb_handover_t *h, const char *port, const char *directory)
{
    if ((h == NULL) || (port == NULL)) {
        return URB_HOST_EINVAL;
    }
    memset(h, 0, sizeof *h);
    char dir[URB_PATH_MAX];
    char name[URB_PATH_MAX];
    if (directory != NULL) {
        int const n = snprintf(dir, sizeof dir, "%s", directory);
        if ((n < 0) || ((size_t)n >= sizeof dir)) {
            return URB_HOST_ENOSPC;
        }
    } else if (!state_dir(dir, sizeof dir)) {
        return URB_HOST_ENOSPC;
    }
    if (!record_name(port, name, sizeof name)) {
        return URB_HOST_ENOSPC;
    }
    int const n = snprintf(h->path, sizeof h->path, "%s/%s", dir, name);
    return ((n < 0) || ((size_t)n >= sizeof h->path)) ? URB_HOST_ENOSPC : URB_HOST_OK;
}

/* The record's text as a number (Python's int() of the stripped text, without its underscores). */
static bool parse_record(const char *text, urb_ns_t *wall, bool *huge)
{
    while ((*text == ' ') || (*text == '\t') || (*text == '\n') || (*text == '\r') || (*text == '\v') || (*text == '\f')) {
        text++;
    }
    const char *p = text;
    if ((*p == '+') || (*p == '-')) {
        p++;
    }
    if ((*p < '0') || (*p > '9')) {
        return false;
    }
    char *end = NULL;
    errno = 0;
    long long const v = strtoll(text, &end, 10);
    while ((*end == ' ') || (*end == '\t') || (*end == '\n') || (*end == '\r') || (*end == '\v') || (*end == '\f')) {
        end++;
    }
    if (*end != '\0') {
        return false;
    }
    *huge = (errno == ERANGE);
    *wall = (urb_ns_t)v;
    return true;
}

urb_ns_t urb_handover_predecessor_until(const urb_handover_t *h, urb_ns_t now_ns)
{
    if (h == NULL) {
        return URB_NO_TIME;
    }
    char text[64] = {0};
    int const fd = open(h->path, O_RDONLY | O_CLOEXEC);
    if ((fd < 0) && (errno == ENOENT)) {
        return URB_NO_TIME;
    }
    if (fd >= 0) {
        ssize_t const got = read(fd, text, sizeof text - 1u);
        text[(got > 0) ? (size_t)got : 0u] = '\0';
        (void)close(fd);
    }
    urb_ns_t const cap = add_sat(now_ns, URB_HANDOVER_MAX_WAIT_NS);
    urb_ns_t wall;
    bool huge = false;
    if ((fd < 0) || !parse_record(text, &wall, &huge)) {
        urb_ns_t const until = add_sat(now_ns, URB_PLACEHOLDER_NS); /* unreadable: written just now */
        return (until < cap) ? until : cap;
    }
    urb_ns_t const until = huge ? ((wall > 0) ? INT64_MAX : INT64_MIN + 1) : add_sat(now_ns, add_sat(wall, -wall_ns()));
    return (until < cap) ? until : cap;
}

static void warn(urb_handover_t *h, const char *what)
{
    if (!h->warned) {
        h->warned = true;
        (void)snprintf(h->error, sizeof h->error,
                       "urb: cannot write %s (%s); a process opening the port after this one ends without close() may "
                       "take its late responses. Set URB_STATE_DIR to a writable directory.",
                       h->path, what);
    }
}

/* mkdir -p of the record's directory: the last one with mode 0700 (the user's own), as
 * Path.mkdir(mode=0o700, parents=True). */
static bool make_dirs(const char *file)
{
    char dir[URB_PATH_MAX];
    (void)snprintf(dir, sizeof dir, "%s", file);
    char *slash = strrchr(dir, '/');
    if ((slash == NULL) || (slash == dir)) {
        return true;
    }
    *slash = '\0';
    struct stat st;
    if (stat(dir, &st) == 0) {
        return S_ISDIR(st.st_mode);
    }
    for (char *p = dir + 1; *p != '\0'; p++) {
        if (*p == '/') {
            *p = '\0';
            if ((mkdir(dir, 0777) != 0) && (errno != EEXIST)) {
                return false;
            }
            *p = '/';
        }
    }
    return (mkdir(dir, 0700) == 0) || (errno == EEXIST);
}

static int32_t write_record(urb_handover_t *h, urb_ns_t until_ns, urb_ns_t now_ns)
{
    urb_ns_t const wall = add_sat(wall_ns(), until_ns - now_ns);
    char tmp[URB_PATH_MAX + 32u];
    size_t const plen = strlen(h->path);
    size_t const base = (plen > 9u && strcmp(h->path + plen - 9u, ".handover") == 0) ? plen - 9u : plen;
    (void)snprintf(tmp, sizeof tmp, "%.*s.%ld.tmp", (int)base, h->path, (long)getpid());
    char text[32];
    int const n = snprintf(text, sizeof text, "%lld\n", (long long)wall);
    if (!make_dirs(h->path)) {
        warn(h, strerror(errno));
        return URB_HOST_EIO;
    }
    int const fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (fd < 0) {
        warn(h, strerror(errno));
        return URB_HOST_EIO;
    }
    bool const ok = (write(fd, text, (size_t)n) == (ssize_t)n);
    int const saved = errno;
    (void)close(fd);
    if (!ok || (rename(tmp, h->path) != 0)) { /* a reader never sees half a record */
        warn(h, strerror(ok ? errno : saved));
        (void)unlink(tmp);
        return URB_HOST_EIO;
    }
    h->written = true;
    h->written_ns = until_ns;
    return URB_HOST_OK;
}

int32_t urb_handover_cover(urb_handover_t *h, urb_ns_t until_ns, urb_ns_t now_ns)
{
    if (h == NULL) {
        return URB_HOST_EINVAL;
    }
    if (!h->written || (until_ns > h->written_ns)) {
        return write_record(h, add_sat(until_ns, URB_HANDOVER_AHEAD_NS), now_ns);
    }
    return URB_HOST_OK;
}

int32_t urb_handover_settle(urb_handover_t *h, urb_ns_t until_ns, urb_ns_t now_ns)
{
    if (h == NULL) {
        return URB_HOST_EINVAL;
    }
    if ((until_ns == URB_NO_TIME) || (until_ns <= now_ns)) {
        h->written = false;
        if ((unlink(h->path) != 0) && (errno != ENOENT)) {
            warn(h, strerror(errno));
            return URB_HOST_EIO;
        }
        return URB_HOST_OK;
    }
    return write_record(h, until_ns, now_ns);
}
