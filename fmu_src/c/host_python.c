/* A Python interpreter for pythonfmu's library in any host.
 *
 * pythonfmu 0.7.0's library calls the Python C API without linking libpython (it expects a Python process) and
 * starts the interpreter with a plain Py_Initialize(). A C/C++ host (Ecos, OMSimulator, the FMI compliance checker)
 * therefore cannot load it ("undefined symbol: _Py_NoneStruct"), and an interpreter started there would take its
 * home from the first python3 on PATH. Before that library is loaded, this file
 *  1. does nothing if the process has a started Python (a Python host such as fmpy): the host's interpreter is used
 *     as it is;
 *  2. otherwise chooses an interpreter: the one $ROTARY_VANE_PYTHON names (then only that one), else the one that
 *     built the FMU (recorded in shim_config), else the first python3 on PATH. One that is not recorded is asked for
 *     its version, sys.executable and shared libpython (run once, isolated: python -I -S -c ...). It must be of the
 *     build's Python version (major.minor: the bundled code and shipped kernels are for it) and have a shared
 *     libpython;
 *  3. loads that libpython with RTLD_GLOBAL (unless the process has one already, e.g. from LD_PRELOAD, which must be
 *     of the build's version) and gives it the interpreter's executable as program name (Py_SetProgramName), so that
 *     pythonfmu's Py_Initialize finds that interpreter's home and, for a virtual environment (its pyvenv.cfg), its
 *     site-packages, as that python would. PYTHONHOME and PYTHONPATH, if the host sets them, apply as in any Python.
 *     In the C locale it selects Python's UTF-8 mode, as the python program does (PEP 540).
 * pythonfmu's library still starts and finalizes the interpreter itself (on its own thread).
 */
#define _GNU_SOURCE
#include "host_python.h"

#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>
#include <wchar.h>

#include "shim_config.h"

extern char **environ;

#define ASK_TIMEOUT_MS 20000

typedef struct {
    char version[16];               /* major.minor */
    char executable[PATH_MAX];      /* sys.executable */
    char library[PATH_MAX];         /* shared libpython, "" if none */
} Interpreter;

typedef int (*IsInitializedFunction)(void);
typedef const char *(*GetVersionFunction)(void);
typedef void (*SetProgramNameFunction)(const wchar_t *);

/* What an interpreter prints when asked: version, sys.executable, shared libpython (or an empty line). */
static const char ASK_SCRIPT[] =
    "import os, sys, sysconfig\n"
    "v = sysconfig.get_config_var\n"
    "names = [n for n in (v('INSTSONAME'), v('LDLIBRARY')) if n and '.so' in n] if v('Py_ENABLE_SHARED') else []\n"
    "found = [p for p in (os.path.join(v('LIBDIR') or '', n) for n in names) if os.path.isfile(p)]\n"
    "print('%d.%d' % sys.version_info[:2]); print(sys.executable); print(found[0] if found else '')\n";

static long milliseconds_since(const struct timespec *start) {
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (now.tv_sec - start->tv_sec) * 1000L + (now.tv_nsec - start->tv_nsec) / 1000000L;
}

/* The next line of `*text` (up to '\n') into `out`; 0 if there is none or it does not fit. */
static int next_line(char **text, char *out, size_t room) {
    char *end = strchr(*text, '\n');
    if (!end || (size_t)(end - *text) >= room) return 0;
    memcpy(out, *text, (size_t)(end - *text));
    out[end - *text] = '\0';
    *text = end + 1;
    return 1;
}

/* Run `program` with ASK_SCRIPT and read its answer into `found`: 1, or 0 with the reason in `why`. */
static int ask(const char *program, Interpreter *found, char *why, size_t room) {
    int fds[2];
    if (pipe2(fds, O_CLOEXEC) != 0) {
        snprintf(why, room, "cannot be asked (pipe: %s)", strerror(errno));
        return 0;
    }
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_adddup2(&actions, fds[1], 1);
    posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
    char *argv[] = {(char *)program, "-I", "-S", "-c", (char *)ASK_SCRIPT, NULL};
    pid_t child;
    int failed = posix_spawn(&child, program, &actions, NULL, argv, environ);
    posix_spawn_file_actions_destroy(&actions);
    close(fds[1]);
    if (failed) {
        close(fds[0]);
        snprintf(why, room, "cannot be run: %s", strerror(failed));
        return 0;
    }
    char output[3 * PATH_MAX + 64];
    size_t used = 0;
    int timed_out = 0;
    struct timespec start;
    clock_gettime(CLOCK_MONOTONIC, &start);
    while (used + 1 < sizeof output) {
        long left = ASK_TIMEOUT_MS - milliseconds_since(&start);
        struct pollfd readable = {fds[0], POLLIN, 0};
        int ready = left > 0 ? poll(&readable, 1, (int)left) : 0;
        if (ready < 0 && errno == EINTR) continue;
        if (ready == 0) timed_out = 1;
        if (ready <= 0) break;
        ssize_t got = read(fds[0], output + used, sizeof output - 1 - used);
        if (got < 0 && errno == EINTR) continue;
        if (got <= 0) break;
        used += (size_t)got;
    }
    output[used] = '\0';
    close(fds[0]);
    if (timed_out) kill(child, SIGKILL);
    int status = 0;
    pid_t waited;
    do waited = waitpid(child, &status, 0); while (waited < 0 && errno == EINTR);
    if (timed_out) {
        snprintf(why, room, "did not answer within %d s", ASK_TIMEOUT_MS / 1000);
        return 0;
    }
    if (waited == child && !(WIFEXITED(status) && WEXITSTATUS(status) == 0)) {
        snprintf(why, room, "failed when asked for its version and libpython (%s %d)",
                 WIFEXITED(status) ? "exit status" : "signal", WIFEXITED(status) ? WEXITSTATUS(status)
                                                                                  : WTERMSIG(status));
        return 0;
    }
    char *text = output;
    if (!next_line(&text, found->version, sizeof found->version)
        || !next_line(&text, found->executable, sizeof found->executable)
        || !next_line(&text, found->library, sizeof found->library)) {
        snprintf(why, room, "gave an answer that is not a Python's version and libpython");
        return 0;
    }
    return 1;
}

/* The executable file `name` in a folder of $PATH (empty entries skipped) into `out`; 0 if there is none. */
static int on_path(const char *name, char *out, size_t room) {
    const char *path = getenv("PATH");
    while (path && *path) {
        size_t length = strcspn(path, ":");
        struct stat info;
        if (length > 0 && snprintf(out, room, "%.*s/%s", (int)length, path, name) < (int)room
            && access(out, X_OK) == 0 && stat(out, &info) == 0 && S_ISREG(info.st_mode))
            return 1;
        path += length + (path[length] == ':');
    }
    return 0;
}

/* Why `candidate` cannot serve this FMU, or NULL. */
static const char *unusable(const Interpreter *candidate, char *why, size_t room) {
    if (strcmp(candidate->version, SHIM_PYTHON_VERSION) != 0)
        snprintf(why, room, "is Python %s, the FMU needs %s", candidate->version, SHIM_PYTHON_VERSION);
    else if (!candidate->library[0])
        snprintf(why, room, "has no shared libpython (a Python built without --enable-shared)");
    else if (access(candidate->library, R_OK) != 0)
        snprintf(why, room, "its libpython %s cannot be read: %s", candidate->library, strerror(errno));
    else if (access(candidate->executable, X_OK) != 0)
        snprintf(why, room, "its executable %s cannot be run: %s", candidate->executable, strerror(errno));
    else
        return NULL;
    return why;
}

/* The interpreter for this process into `chosen`: 1, or 0 with what was tried in `why`. */
static int choose(Interpreter *chosen, char *why, size_t room) {
    char reason[PATH_MAX + 200], program[PATH_MAX];
    static const char HOW[] = "set " PYTHON_OVERRIDE_VARIABLE " to the python executable of an environment with "
                               "the packages of the FMU's resources/requirements.txt (e.g. " PYTHON_OVERRIDE_VARIABLE
                               "=/path/to/venv/bin/python)";
    const char *named = getenv(PYTHON_OVERRIDE_VARIABLE);
    if (named && named[0]) {
        int found = strchr(named, '/') ? snprintf(program, sizeof program, "%s", named) < (int)sizeof program
                                       : on_path(named, program, sizeof program);
        if (!found) snprintf(reason, sizeof reason, "is not an executable file (nor one on PATH)");
        if (found && ask(program, chosen, reason, sizeof reason) && !unusable(chosen, reason, sizeof reason))
            return 1;
        snprintf(why, room, "no Python for the FMU: %s=%s %s; %s", PYTHON_OVERRIDE_VARIABLE, named, reason, HOW);
        return 0;
    }
    Interpreter recorded;
    snprintf(recorded.version, sizeof recorded.version, "%s", SHIM_PYTHON_VERSION);
    snprintf(recorded.executable, sizeof recorded.executable, "%s", SHIM_PYTHON_EXECUTABLE);
    snprintf(recorded.library, sizeof recorded.library, "%s", SHIM_PYTHON_LIBRARY);
    char tried[2 * sizeof reason + 100];
    if (!unusable(&recorded, reason, sizeof reason)) {
        *chosen = recorded;
        return 1;
    }
    int n = snprintf(tried, sizeof tried, "the interpreter that built the FMU, %s, %s", recorded.executable, reason);
    if (!on_path("python3", program, sizeof program))
        snprintf(tried + n, sizeof tried - (size_t)n, "; no python3 on PATH");
    else if (ask(program, chosen, reason, sizeof reason) && !unusable(chosen, reason, sizeof reason))
        return 1;
    else
        snprintf(tried + n, sizeof tried - (size_t)n, "; python3 on PATH, %s, %s", program, reason);
    snprintf(why, room, "no Python %s for the FMU: %s (and %s is not set); %s", SHIM_PYTHON_VERSION, tried,
             PYTHON_OVERRIDE_VARIABLE, HOW);
    return 0;
}

/* `text` (UTF-8; other bytes as U+DC80 + byte, Python's surrogateescape) as a wide string; NULL without memory. */
static wchar_t *wide(const char *text) {
    size_t length = strlen(text);
    wchar_t *out = malloc((length + 1) * sizeof(wchar_t)), *w = out;
    if (!out) return NULL;
    for (const unsigned char *p = (const unsigned char *)text; *p;) {
        int extra = *p < 0x80 ? 0 : (*p & 0xE0) == 0xC0 ? 1 : (*p & 0xF0) == 0xE0 ? 2 : (*p & 0xF8) == 0xF0 ? 3 : -1;
        unsigned long code = extra <= 0 ? *p : *p & (0x3Fu >> extra);
        int i = 1;
        for (; extra > 0 && i <= extra && (p[i] & 0xC0) == 0x80; i++) code = code << 6 | (p[i] & 0x3Fu);
        if (extra < 0 || i <= extra) {
            *w++ = (wchar_t)(0xDC00 + *p++);
            continue;
        }
        *w++ = (wchar_t)code;
        p += extra + 1;
    }
    *w = L'\0';
    return out;
}

/* 1 if the libpython whose Py_GetVersion is `get_version` is of the build's version, else 0 with why. */
static int right_version(GetVersionFunction get_version, const char *which, char *why, size_t room) {
    const char *version = get_version ? get_version() : "";
    size_t n = strlen(SHIM_PYTHON_VERSION);
    if (strncmp(version, SHIM_PYTHON_VERSION, n) == 0 && version[n] == '.') return 1;
    snprintf(why, room, "%s is Python %.12s, the FMU needs Python %s", which, version, SHIM_PYTHON_VERSION);
    return 0;
}

/* Whether the environment selects the C (or POSIX) locale for LC_CTYPE, in which the python program starts in
 * UTF-8 mode (PEP 540) but an embedded Py_Initialize() would read file names as ASCII: an FMU unpacked into a
 * folder with a non-ASCII name could then not be imported. */
static int c_locale(void) {
    const char *names[] = {"LC_ALL", "LC_CTYPE", "LANG"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        const char *value = getenv(names[i]);
        if (value && value[0]) return strcmp(value, "C") == 0 || strcmp(value, "POSIX") == 0;
    }
    return 1;
}

static char named_program[PATH_MAX];         /* the interpreter this file gave libpython, "" if none */

const char *host_python_chosen(void) {
    return named_program[0] ? named_program : NULL;
}

/* Give the not yet started libpython of `functions` the interpreter's executable as its program name. */
static int name_program(void *functions, const Interpreter *chosen, char *why, size_t room) {
    SetProgramNameFunction set_name = (SetProgramNameFunction)dlsym(functions, "Py_SetProgramName");
    wchar_t *name = wide(chosen->executable);
    if (!set_name || !name) {
        free(name);
        snprintf(why, room, "%s", set_name ? "out of memory" : "libpython has no Py_SetProgramName");
        return 0;
    }
    set_name(name);                       /* Python copies it */
    free(name);
    int *utf8_mode = (int *)dlsym(functions, "Py_UTF8Mode");
    if (utf8_mode && c_locale()) *utf8_mode = 1;
    snprintf(named_program, sizeof named_program, "%s", chosen->executable);
    return 1;
}

static int prepare(char *why, size_t room) {
    IsInitializedFunction started = (IsInitializedFunction)dlsym(RTLD_DEFAULT, "Py_IsInitialized");
    if (started && started()) return 1;                         /* a Python host: its interpreter as it is */
    Interpreter chosen;
    if (started) {                                              /* a libpython loaded but not started (LD_PRELOAD) */
        if (!right_version((GetVersionFunction)dlsym(RTLD_DEFAULT, "Py_GetVersion"), "the libpython loaded in this "
                           "process", why, room))
            return 0;
        char ignored[PATH_MAX + 400];
        return !choose(&chosen, ignored, sizeof ignored) || name_program(RTLD_DEFAULT, &chosen, why, room);
    }
    if (!choose(&chosen, why, room)) return 0;
    void *library = dlopen(chosen.library, RTLD_NOW | RTLD_GLOBAL);
    if (!library) {
        snprintf(why, room, "cannot load the libpython of %s: %s", chosen.executable, dlerror());
        return 0;
    }
    char which[PATH_MAX + 20];
    snprintf(which, sizeof which, "libpython %s", chosen.library);
    if (!right_version((GetVersionFunction)dlsym(library, "Py_GetVersion"), which, why, room)) return 0;
    started = (IsInitializedFunction)dlsym(library, "Py_IsInitialized");
    if (started && started()) return 1;                         /* started by a host that loaded it privately */
    return name_program(library, &chosen, why, room);
}

int host_python_ready(char *why, size_t room) {
    static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
    static int ready;
    pthread_mutex_lock(&lock);
    if (!ready) ready = prepare(why, room);
    int result = ready;
    pthread_mutex_unlock(&lock);
    return result;
}
