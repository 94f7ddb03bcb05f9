/* FMI 2.0 shim: the FMU's binary, in front of pythonfmu's export library.
 *
 * pythonfmu 0.7.0 turns a Python exception into fmi2Fatal (and destroys the Python instance) and otherwise returns
 * only fmi2OK, or fmi2Discard from doStep; its library needs a Python in the process. The FMI 2.0 standard asks for
 * fmi2Error (the instance stays usable for fmi2SetFMUstate / fmi2Reset) and fmi2Warning in many situations. This
 * library loads pythonfmu's library (shipped beside it as <modelIdentifier>_pythonfmu.so), forwards the FMI calls to
 * it and gives each call the worst status the Python slave logged during it (fmu_src/slave.py logs every refusal
 * with the status it means), so the slave decides the status and the shim carries it. The shim also
 *  - provides a Python interpreter in a host that is not a Python program (fmu_src/c/host_python.c);
 *  - refuses to instantiate (NULL, with a message) for another model's GUID, another FMU type, or a resource
 *    location that is not a local folder with this FMU's resources (fmu_src/c/resource_uri.c reads every file-URI
 *    form importers use); pythonfmu is given "file://" + the folder's real path;
 *  - follows the FMI 2.0 co-simulation state machine (§4.2.4, the table of the functions allowed per state) for
 *    what it answers itself: the state inquiries fmi2Get*Status are allowed in stepComplete/stepFailed (here:
 *    initialized) and terminated, and answered with fmi2Error elsewhere; the functions whose capability flags are
 *    false (directional derivatives, input/output derivatives, fmi2CancelStep) are fmi2Error. Neither changes the
 *    instance, so neither enters the error state;
 *  - keeps the FMI error state: after a call returned fmi2Error, only the calls FMI 2.0 allows there are
 *    forwarded (getters, the FMU-state functions, fmi2Reset, fmi2FreeInstance, fmi2SetDebugLogging); the others
 *    are refused with fmi2Error naming the state and what put the instance there; a successful fmi2SetFMUstate or
 *    fmi2Reset leaves it;
 *  - keeps the fatal state: after fmi2Fatal (pythonfmu has then destroyed its Python instance) no call reaches
 *    pythonfmu again; each is answered with fmi2Fatal and its cause, and fmi2FreeInstance frees only the shim (the
 *    destroyed instance would release its Python objects a second time);
 *  - gives every message a category of the modelDescription's LogCategories (pythonfmu's own come with none or
 *    "cppfmu"): the one of its status. Warnings, discards and errors reach the importer's logger even when debug
 *    logging is off (the importer must learn why a call failed), other messages when it is on for their category;
 *    a forwarded message is passed as the format, as pythonfmu does (the slave escapes % as %%);
 *  - refuses, before Python sees them, what pythonfmu would turn into fmi2Fatal or a crash: a string value that
 *    is not UTF-8, null pointers, and state bytes whose envelope is not this build's (fmu_src/c/state_envelope.c).
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <limits.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fmi2Functions.h"
#include "host_python.h"
#include "resource_uri.h"
#include "shim_config.h"
#include "state_envelope.h"

/* The FMI state of an instance that is neither in the error nor in the fatal state. */
typedef enum { INSTANTIATED, INITIALIZATION_MODE, INITIALIZED, TERMINATED } Mode;
static const char *const MODE_NAME[] = {"instantiated", "initialization mode", "initialized", "terminated"};

typedef struct {
    fmi2FMUstate state;
    Mode mode;                       /* the instance's mode when the state was taken */
} SavedState;

typedef struct {
    fmi2Component inner;
    fmi2CallbackFunctions host;      /* the importer's callbacks */
    fmi2CallbackFunctions own;       /* given to pythonfmu: logger = shim_logger, environment = this record */
    fmi2Boolean host_logging;
    unsigned logged_categories;      /* with host_logging: the categories asked for (bit i: CATEGORY[i]) */
    fmi2Status worst_logged;         /* worst status logged by the slave during the current call */
    char first_error[320];           /* the first error message logged during the current call */
    Mode mode;
    int in_error;                    /* the FMI error state */
    char error_cause[400];           /* what put the instance into the error state */
    int fatal;                       /* pythonfmu answered fmi2Fatal: its instance is gone */
    char fatal_cause[400];
    SavedState *saved;               /* the FMU states this instance handed out, with their modes */
    size_t saved_count, saved_room;
    char *instance_name;
} Shim;

/* The LogCategories pythonfmu declares in every modelDescription.xml (fmu_src/status_shim.py checks), by status. */
static const char *const CATEGORY[] = {"logAll", "logStatusWarning", "logStatusDiscard", "logStatusError",
                                       "logStatusFatal"};
#define CATEGORY_COUNT (sizeof CATEGORY / sizeof CATEGORY[0])

static const char *category_of(fmi2Status status) {
    return status >= fmi2OK && status <= fmi2Fatal ? CATEGORY[status] : CATEGORY[0];
}

static int category_index(const char *name) {
    for (size_t i = 0; name && i < CATEGORY_COUNT; i++)
        if (strcmp(name, CATEGORY[i]) == 0) return (int)i;
    return -1;
}

static void *library;
/* pythonfmu's functions that the shim forwards to (an X-macro: declared and loaded from one list) */
#define FORWARDED(X) X(fmi2SetDebugLogging) X(fmi2Instantiate) X(fmi2FreeInstance) X(fmi2SetupExperiment) \
    X(fmi2EnterInitializationMode) X(fmi2ExitInitializationMode) X(fmi2Terminate) X(fmi2Reset) X(fmi2GetReal) \
    X(fmi2GetInteger) X(fmi2GetBoolean) X(fmi2GetString) X(fmi2SetReal) X(fmi2SetInteger) X(fmi2SetBoolean) \
    X(fmi2SetString) X(fmi2GetFMUstate) X(fmi2SetFMUstate) X(fmi2FreeFMUstate) X(fmi2SerializedFMUstateSize) \
    X(fmi2SerializeFMUstate) X(fmi2DeSerializeFMUstate) X(fmi2DoStep) X(fmi2GetRealStatus) X(fmi2GetIntegerStatus) \
    X(fmi2GetBooleanStatus) X(fmi2GetStringStatus)
#define INNER(name) static name##TYPE *inner_##name;
FORWARDED(INNER)

/* Load pythonfmu's library from this library's folder: 1, or 0 with why not. */
static int load_inner(char *why, size_t room) {
    if (library) return 1;
    Dl_info self;
    if (!dladdr((void *)&load_inner, &self) || !self.dli_fname) {
        snprintf(why, room, "the FMU's binary cannot find its own file");
        return 0;
    }
    char path[PATH_MAX];
    snprintf(path, sizeof path - 16, "%s", self.dli_fname);
    char *dot = strrchr(path, '.');
    if (!dot || strchr(dot, '/')) dot = path + strlen(path);
    strcpy(dot, "_pythonfmu.so");
    void *opened = dlopen(path, RTLD_LAZY | RTLD_LOCAL);
    if (!opened) {
        snprintf(why, room, "cannot load %s: %s", path, dlerror());
        return 0;
    }
#define LOAD(name) if (!(inner_##name = (name##TYPE *)dlsym(opened, #name))) { \
        snprintf(why, room, "pythonfmu's library %s lacks %s", path, #name); return 0; }
    FORWARDED(LOAD)
    library = opened;
    return 1;
}

static int severity(fmi2Status status) {           /* fmi2Pending (5) is not a severity */
    return status == fmi2Pending ? 0 : (int)status;
}

/* `text` without the %-escaping of a log format ("%%" -> "%"), cut to fit `size`. */
static void copy_unescaped(char *target, size_t size, const char *text) {
    size_t n = 0;
    for (; text && *text && n + 1 < size; text++) {
        if (text[0] == '%' && text[1] == '%') text++;
        target[n++] = *text;
    }
    target[n] = '\0';
}

/* Whether the importer gets a message of `status` in `category`. */
static int reaches_host(const Shim *shim, fmi2Status status, const char *category) {
    if (!shim->host.logger) return 0;
    if (status == fmi2Warning || status == fmi2Discard || status == fmi2Error || status == fmi2Fatal) return 1;
    return shim->host_logging && (shim->logged_categories >> category_index(category) & 1u);
}

static void shim_logger(fmi2ComponentEnvironment environment, fmi2String instance, fmi2Status status,
                        fmi2String category, fmi2String message, ...) {
    Shim *shim = (Shim *)environment;
    if (severity(status) > severity(shim->worst_logged)) shim->worst_logged = status;
    if ((status == fmi2Error || status == fmi2Fatal) && !shim->first_error[0])
        copy_unescaped(shim->first_error, sizeof shim->first_error, message);
    if (category_index(category) < 0) category = category_of(status);
    if (reaches_host(shim, status, category))
        shim->host.logger(shim->host.componentEnvironment, instance, status, category, message ? message : "");
}

/* Log a message of the shim itself (not a format) to the importer. */
static void say(Shim *shim, fmi2Status status, const char *message) {
    if (reaches_host(shim, status, category_of(status)))
        shim->host.logger(shim->host.componentEnvironment, shim->instance_name, status, category_of(status), "%s",
                          message);
}

static void enter_error_state(Shim *shim, const char *function, const char *reason) {
    if (shim->in_error) return;
    shim->in_error = 1;
    snprintf(shim->error_cause, sizeof shim->error_cause, "%s returned fmi2Error: %s", function,
             reason && reason[0] ? reason : "see the messages before");
}

/* A call refused by the shim itself: fmi2Error with `message`, and the error state. */
static fmi2Status refuse(Shim *shim, const char *function, const char *message) {
    say(shim, fmi2Error, message);
    enter_error_state(shim, function, message);
    return fmi2Error;
}

/* A call that does nothing and changes nothing: fmi2Error with `message`, the instance's state kept. */
static fmi2Status decline(Shim *shim, const char *message) {
    say(shim, fmi2Error, message);
    return fmi2Error;
}

/* The status of a forwarded call: the worse of what it returned and what the slave logged during it. */
static fmi2Status carried(Shim *shim, const char *function, fmi2Status returned) {
    fmi2Status status = severity(shim->worst_logged) > severity(returned) ? shim->worst_logged : returned;
    if (status == fmi2Fatal && !shim->fatal) {
        shim->fatal = 1;
        snprintf(shim->fatal_cause, sizeof shim->fatal_cause, "%s returned fmi2Fatal: %s", function,
                 shim->first_error[0] ? shim->first_error : "see the messages before");
    } else if (status == fmi2Error) {
        enter_error_state(shim, function, shim->first_error);
    }
    return status;
}

/* The status of a forwarded call that moves the instance to `mode` when it succeeds. */
static fmi2Status carried_to(Shim *shim, const char *function, fmi2Status returned, Mode mode) {
    fmi2Status status = carried(shim, function, returned);
    if (status == fmi2OK || status == fmi2Warning) shim->mode = mode;
    return status;
}

/* In the error state only the calls FMI 2.0 allows there are forwarded. */
static fmi2Status refuse_in_error_state(Shim *shim, const char *function) {
    char message[600];
    snprintf(message, sizeof message, "%s is not allowed in the error state (%s); allowed: fmi2SetFMUstate of a "
             "state saved before, fmi2Reset, fmi2FreeInstance, the getters and the other FMU-state functions",
             function, shim->error_cause);
    say(shim, fmi2Error, message);
    return fmi2Error;
}

/* After fmi2Fatal nothing is forwarded: pythonfmu's instance is gone. */
static fmi2Status refuse_after_fatal(Shim *shim, const char *function) {
    char message[600];
    snprintf(message, sizeof message, "%s: the instance was lost (%s); only fmi2FreeInstance is possible, then "
             "instantiate anew", function, shim->fatal_cause);
    say(shim, fmi2Fatal, message);
    return fmi2Fatal;
}

#define BEGIN(c, name) Shim *shim = (Shim *)(c); if (!shim) return fmi2Error; \
    if (shim->fatal) return refuse_after_fatal(shim, name); \
    shim->worst_logged = fmi2OK; shim->first_error[0] = '\0';
#define NOT_IN_ERROR(name) if (shim->in_error) return refuse_in_error_state(shim, name);
#define FORWARD(name, call) return carried(shim, name, call)
#define NEED(pointer, name, what) if (!(pointer)) return refuse(shim, name, name ": " what " is a null pointer; " \
                                                               "nothing was done");

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

/* fmi2Instantiate's refusal: NULL, with `message` to the importer's logger (and stderr, where a host drops it). */
static fmi2Component not_instantiated(const fmi2CallbackFunctions *functions, fmi2String name, const char *message) {
    fprintf(stderr, "fmi2Instantiate(%s): %s\n", name ? name : "null instance name", message);
    if (functions && functions->logger)
        functions->logger(functions->componentEnvironment, name ? name : "", fmi2Error, "logStatusError",
                          "fmi2Instantiate: %s", message);
    return NULL;
}

/* The resource location for pythonfmu: "file://" + the real path of this FMU's resources folder, 1; else 0, why. */
static int pythonfmu_resources(const char *location, char *uri, size_t room, char *why, size_t why_room) {
    char folder[PATH_MAX], module[PATH_MAX + 20];
    if (!resource_folder(location, folder, sizeof folder, why, why_room)) return 0;
    snprintf(module, sizeof module, "%s/slavemodule.txt", folder);
    if (access(module, R_OK) != 0)
        snprintf(why, why_room, "the resource location \"%s\" is not this FMU's resources folder (%s has no "
                 "slavemodule.txt)", location, folder);
    else if (strstr(folder, "%20"))       /* pythonfmu 0.7.0 turns every "%20" of its location into a space */
        snprintf(why, why_room, "the resources folder's path \"%s\" contains \"%%20\", which pythonfmu reads as a "
                 "space: unpack the FMU into another folder", folder);
    else if (snprintf(uri, room, "file://%s", folder) >= (int)room)
        snprintf(why, why_room, "the resources folder's path \"%s\" is too long", folder);
    else
        return 1;
    return 0;
}

/* pythonfmu's library, loaded with a Python for it: 1, or 0 with why not. */
static int pythonfmu_loaded(char *why, size_t room) {
    static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
    pthread_mutex_lock(&lock);
    int loaded = host_python_ready(why, room) && load_inner(why, room);
    pthread_mutex_unlock(&lock);
    return loaded;
}

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String resources,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible, fmi2Boolean logging) {
    char why[PATH_MAX + 1200], uri[PATH_MAX + 8];
    if (!functions) return not_instantiated(functions, name, "the callback functions are a null pointer");
    if (!name) return not_instantiated(functions, name, "the instance name is a null pointer");
    if (type != fmi2CoSimulation)
        return not_instantiated(functions, name, "this FMU is for co-simulation only (fmuType fmi2CoSimulation)");
    if (!guid || strcmp(guid, SHIM_MODEL_GUID) != 0) {
        snprintf(why, sizeof why, "the GUID %s%s%s is not this FMU's (%s, in its modelDescription.xml): the "
                 "modelDescription.xml read is not this binary's", guid ? "\"" : "", guid ? guid : "(null pointer)",
                 guid ? "\"" : "", SHIM_MODEL_GUID);
        return not_instantiated(functions, name, why);
    }
    if (!pythonfmu_resources(resources, uri, sizeof uri, why, sizeof why)) return not_instantiated(functions, name, why);
    if (!pythonfmu_loaded(why, sizeof why)) return not_instantiated(functions, name, why);
    Shim *shim = calloc(1, sizeof(Shim));
    if (!shim || !(shim->instance_name = strdup(name))) {
        free(shim);
        return not_instantiated(functions, name, "out of memory");
    }
    shim->host = *functions;
    shim->own = *functions;
    shim->own.logger = shim_logger;
    shim->own.componentEnvironment = shim;
    shim->host_logging = logging;
    shim->logged_categories = ~0u;
    shim->mode = INSTANTIATED;
    shim->inner = inner_fmi2Instantiate(name, type, guid, uri, &shim->own, visible, fmi2True);
    if (!shim->inner) {                /* pythonfmu has logged why (through shim_logger: the importer's logger) */
        free(shim->instance_name);
        free(shim);
        if (!host_python_chosen()) return NULL;
        snprintf(why, sizeof why, "pythonfmu could not make the instance in the Python of %s (see the message "
                 "before); if that environment lacks the packages of the FMU's resources/requirements.txt, set "
                 PYTHON_OVERRIDE_VARIABLE " to the python executable of one that has them", host_python_chosen());
        return not_instantiated(functions, name, why);
    }
    return shim;
}

void fmi2FreeInstance(fmi2Component c) {
    Shim *shim = (Shim *)c;
    if (!shim) return;
    if (!shim->fatal) inner_fmi2FreeInstance(shim->inner);
    free(shim->saved);
    free(shim->instance_name);
    free(shim);
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String categories[]) {
    BEGIN(c, "fmi2SetDebugLogging")
    if (n > 0) NEED(categories, "fmi2SetDebugLogging", "categories")
    unsigned chosen = n == 0 ? ~0u : 0u;
    for (size_t i = 0; i < n; i++) {
        NEED(categories[i], "fmi2SetDebugLogging", "a category")
        int index = category_index(categories[i]);
        if (index < 0) {
            char message[400];
            snprintf(message, sizeof message, "fmi2SetDebugLogging: \"%.80s\" is not a log category of this FMU "
                     "(logAll, logStatusWarning, logStatusDiscard, logStatusError, logStatusFatal); nothing was "
                     "changed", categories[i]);
            return decline(shim, message);
        }
        chosen |= 1u << index;
    }
    shim->host_logging = on;
    shim->logged_categories = chosen;
    FORWARD("fmi2SetDebugLogging", inner_fmi2SetDebugLogging(shim->inner, fmi2True, 0, NULL));
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean has_tolerance, fmi2Real tolerance, fmi2Real start,
                               fmi2Boolean has_stop, fmi2Real stop) {
    BEGIN(c, "fmi2SetupExperiment") NOT_IN_ERROR("fmi2SetupExperiment")
    FORWARD("fmi2SetupExperiment", inner_fmi2SetupExperiment(shim->inner, has_tolerance, tolerance, start, has_stop,
                                                             stop));
}
fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    BEGIN(c, "fmi2EnterInitializationMode") NOT_IN_ERROR("fmi2EnterInitializationMode")
    return carried_to(shim, "fmi2EnterInitializationMode", inner_fmi2EnterInitializationMode(shim->inner),
                      INITIALIZATION_MODE);
}
fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    BEGIN(c, "fmi2ExitInitializationMode") NOT_IN_ERROR("fmi2ExitInitializationMode")
    return carried_to(shim, "fmi2ExitInitializationMode", inner_fmi2ExitInitializationMode(shim->inner),
                      INITIALIZED);
}
fmi2Status fmi2Terminate(fmi2Component c) {
    BEGIN(c, "fmi2Terminate") NOT_IN_ERROR("fmi2Terminate")
    return carried_to(shim, "fmi2Terminate", inner_fmi2Terminate(shim->inner), TERMINATED);
}
fmi2Status fmi2Reset(fmi2Component c) {
    BEGIN(c, "fmi2Reset")
    int was_in_error = shim->in_error;
    shim->in_error = 0;
    fmi2Status status = carried_to(shim, "fmi2Reset", inner_fmi2Reset(shim->inner), INSTANTIATED);
    if (status > fmi2Warning && was_in_error) shim->in_error = 1;
    return status;
}

#define GET(name, type) \
    fmi2Status name(fmi2Component c, const fmi2ValueReference vr[], size_t n, type value[]) { \
        BEGIN(c, #name) if (n > 0) { NEED(vr, #name, "the value references") NEED(value, #name, "the values") } \
        FORWARD(#name, inner_##name(shim->inner, vr, n, value)); }
#define SET(name, type) \
    fmi2Status name(fmi2Component c, const fmi2ValueReference vr[], size_t n, const type value[]) { \
        BEGIN(c, #name) NOT_IN_ERROR(#name) \
        if (n > 0) { NEED(vr, #name, "the value references") NEED(value, #name, "the values") } \
        FORWARD(#name, inner_##name(shim->inner, vr, n, value)); }
GET(fmi2GetReal, fmi2Real) GET(fmi2GetInteger, fmi2Integer) GET(fmi2GetBoolean, fmi2Boolean)
GET(fmi2GetString, fmi2String) SET(fmi2SetReal, fmi2Real) SET(fmi2SetInteger, fmi2Integer)
SET(fmi2SetBoolean, fmi2Boolean)

/* 1 if `text` is well-formed UTF-8 (no overlong forms, surrogates or code points above U+10FFFF). */
static int is_utf8(const unsigned char *text) {
    while (*text) {
        unsigned char lead = *text;
        int extra = lead < 0x80 ? 0 : (lead & 0xE0) == 0xC0 ? 1 : (lead & 0xF0) == 0xE0 ? 2
                  : (lead & 0xF8) == 0xF0 ? 3 : -1;
        if (extra < 0 || lead == 0xC0 || lead == 0xC1 || lead > 0xF4) return 0;
        unsigned long code = extra == 0 ? lead : lead & (0x3F >> extra);
        for (int i = 1; i <= extra; i++) {
            if ((text[i] & 0xC0) != 0x80) return 0;
            code = (code << 6) | (text[i] & 0x3F);
        }
        if ((extra == 2 && (code < 0x800 || (code >= 0xD800 && code <= 0xDFFF))) || (extra == 3 && code < 0x10000)
            || code > 0x10FFFF)
            return 0;
        text += extra + 1;
    }
    return 1;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String value[]) {
    BEGIN(c, "fmi2SetString") NOT_IN_ERROR("fmi2SetString")
    if (n > 0) { NEED(vr, "fmi2SetString", "the value references") NEED(value, "fmi2SetString", "the values") }
    for (size_t i = 0; i < n; i++) {
        if (!value[i] || !is_utf8((const unsigned char *)value[i])) {
            char message[200];
            snprintf(message, sizeof message, "fmi2SetString: the value for value reference %u is %s; nothing "
                     "was set", vr[i], value[i] ? "not valid UTF-8" : "a null pointer");
            return refuse(shim, "fmi2SetString", message);
        }
    }
    FORWARD("fmi2SetString", inner_fmi2SetString(shim->inner, vr, n, value));
}

/* The FMU states handed out, with the mode each was taken in (fmi2SetFMUstate returns the instance to it). */
static int remember(Shim *shim, fmi2FMUstate state, Mode mode) {
    if (shim->saved_count == shim->saved_room) {
        size_t room = shim->saved_room ? 2 * shim->saved_room : 8;
        SavedState *grown = realloc(shim->saved, room * sizeof *grown);
        if (!grown) return 0;
        shim->saved = grown;
        shim->saved_room = room;
    }
    shim->saved[shim->saved_count++] = (SavedState){state, mode};
    return 1;
}
static SavedState *saved_entry(Shim *shim, fmi2FMUstate state) {
    for (size_t i = 0; i < shim->saved_count; i++)
        if (shim->saved[i].state == state) return &shim->saved[i];
    return NULL;
}
static void forget(Shim *shim, fmi2FMUstate state) {
    SavedState *entry = saved_entry(shim, state);
    if (entry) *entry = shim->saved[--shim->saved_count];
}
/* A state pythonfmu made: remembered with `mode`, or freed again with fmi2Error when it cannot be remembered. */
static fmi2Status handed_out(Shim *shim, const char *function, fmi2Status status, fmi2FMUstate *state, Mode mode) {
    if (status > fmi2Warning || !*state || remember(shim, *state, mode)) return status;
    inner_fmi2FreeFMUstate(shim->inner, state);
    *state = NULL;
    char message[200];
    snprintf(message, sizeof message, "%s: out of memory; no state was made", function);
    return refuse(shim, function, message);
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    BEGIN(c, "fmi2GetFMUstate") NEED(state, "fmi2GetFMUstate", "the state pointer")
    if (*state) {          /* FMI 2.0: a state given back is overwritten; pythonfmu would leak it */
        fmi2FMUstate old = *state;
        forget(shim, old);
        inner_fmi2FreeFMUstate(shim->inner, &old);
        *state = NULL;
    }
    fmi2Status status = carried(shim, "fmi2GetFMUstate", inner_fmi2GetFMUstate(shim->inner, state));
    return handed_out(shim, "fmi2GetFMUstate", status, state, shim->mode);
}
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    BEGIN(c, "fmi2SetFMUstate") NEED(state, "fmi2SetFMUstate", "the state")
    int was_in_error = shim->in_error;
    shim->in_error = 0;
    SavedState *entry = saved_entry(shim, state);
    fmi2Status status = carried_to(shim, "fmi2SetFMUstate", inner_fmi2SetFMUstate(shim->inner, state),
                                   entry ? entry->mode : shim->mode);
    if (status > fmi2Warning && was_in_error) shim->in_error = 1;
    return status;
}
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    BEGIN(c, "fmi2FreeFMUstate")
    if (!state || !*state) return fmi2OK;              /* FMI 2.0: freeing a null state does nothing */
    forget(shim, *state);
    fmi2Status status = carried(shim, "fmi2FreeFMUstate", inner_fmi2FreeFMUstate(shim->inner, state));
    *state = NULL;                                     /* FMI 2.0; pythonfmu leaves the pointer dangling */
    return status;
}
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size) {
    BEGIN(c, "fmi2SerializedFMUstateSize")
    NEED(state, "fmi2SerializedFMUstateSize", "the state") NEED(size, "fmi2SerializedFMUstateSize", "size")
    FORWARD("fmi2SerializedFMUstateSize", inner_fmi2SerializedFMUstateSize(shim->inner, state, size));
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    BEGIN(c, "fmi2SerializeFMUstate") NEED(state, "fmi2SerializeFMUstate", "the state")
    if (size > 0) NEED(bytes, "fmi2SerializeFMUstate", "the byte buffer")
    size_t needed = 0;       /* pythonfmu copies the whole state whatever `size` says */
    fmi2Status status = carried(shim, "fmi2SerializeFMUstate",
                                inner_fmi2SerializedFMUstateSize(shim->inner, state, &needed));
    if (status > fmi2Warning) return status;
    if (size < needed) {
        char message[200];
        snprintf(message, sizeof message, "fmi2SerializeFMUstate: the buffer of %zu bytes is too small: the state "
                 "needs %zu (fmi2SerializedFMUstateSize); nothing was written", size, needed);
        return refuse(shim, "fmi2SerializeFMUstate", message);
    }
    FORWARD("fmi2SerializeFMUstate", inner_fmi2SerializeFMUstate(shim->inner, state, bytes, size));
}

/* A deserialized state is remembered with the instance's current mode: the mode it was taken in is not in the
 * bytes the shim can read (the slave restores its own phase from them). */
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *state) {
    BEGIN(c, "fmi2DeSerializeFMUstate") NEED(state, "fmi2DeSerializeFMUstate", "the state pointer")
    *state = NULL;
    if (size > 0) NEED(bytes, "fmi2DeSerializeFMUstate", "the bytes")
    char reason[200], message[300];
    if (envelope_error((const unsigned char *)bytes, size, reason, sizeof reason)) {
        snprintf(message, sizeof message, "fmi2DeSerializeFMUstate: %s; nothing was read", reason);
        return refuse(shim, "fmi2DeSerializeFMUstate", message);
    }
    fmi2Status status = carried(shim, "fmi2DeSerializeFMUstate",
                                inner_fmi2DeSerializeFMUstate(shim->inner, bytes, size, state));
    if (status > fmi2Warning) return status;
    /* the slave gives a state whose content it refused the serialized size 0 (fmu_src/slave.py) */
    size_t probe = 0;
    if (inner_fmi2SerializedFMUstateSize(shim->inner, *state, &probe) == fmi2OK && probe == 0) {
        /* pythonfmu decodes on the class, where no logger is reachable: handing the refused state to the instance
         * makes the slave log the reason (with fmi2Error, changing nothing), which this call then carries */
        shim->worst_logged = fmi2OK;
        shim->first_error[0] = '\0';
        inner_fmi2SetFMUstate(shim->inner, *state);
        inner_fmi2FreeFMUstate(shim->inner, state);
        *state = NULL;
        char refusal[sizeof shim->first_error + 160];
        snprintf(refusal, sizeof refusal, "fmi2DeSerializeFMUstate: the bytes have this FMU's envelope but their "
                 "content is not a state of this build (%s); nothing was read",
                 shim->first_error[0] ? shim->first_error : "the model gave no reason");
        return refuse(shim, "fmi2DeSerializeFMUstate", refusal);
    }
    return handed_out(shim, "fmi2DeSerializeFMUstate", status, state, shim->mode);
}

/* The functions whose capability flags are false in the modelDescription (providesDirectionalDerivative,
 * canInterpolateInputs, maxOutputDerivativeOrder = 0, canRunAsynchronuously): fmi2Error, nothing done. */
static fmi2Status unsupported(fmi2Component c, const char *function, const char *flag) {
    BEGIN(c, function)
    char message[300];
    snprintf(message, sizeof message, "%s is not supported by this FMU (its modelDescription.xml declares %s); "
             "nothing was done, the instance is unchanged", function, flag);
    return decline(shim, message);
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference unknown[], size_t n_unknown,
                                        const fmi2ValueReference known[], size_t n_known, const fmi2Real seed[],
                                        fmi2Real sensitivity[]) {
    (void)unknown; (void)n_unknown; (void)known; (void)n_known; (void)seed; (void)sensitivity;
    return unsupported(c, "fmi2GetDirectionalDerivative", "no providesDirectionalDerivative");
}
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr; (void)n; (void)order; (void)value;
    return unsupported(c, "fmi2SetRealInputDerivatives", "canInterpolateInputs=\"false\"");
}
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr; (void)n; (void)order; (void)value;
    return unsupported(c, "fmi2GetRealOutputDerivatives", "no maxOutputDerivativeOrder");
}
fmi2Status fmi2CancelStep(fmi2Component c) {
    return unsupported(c, "fmi2CancelStep", "no canRunAsynchronuously: fmi2DoStep never returns fmi2Pending");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real time, fmi2Real step, fmi2Boolean no_earlier_state) {
    BEGIN(c, "fmi2DoStep") NOT_IN_ERROR("fmi2DoStep")
    FORWARD("fmi2DoStep", inner_fmi2DoStep(shim->inner, time, step, no_earlier_state));
}

/* FMI 2.0 §4.2.4: the status inquiries are allowed in stepComplete, stepInProgress, stepFailed and terminated
 * (the instance is initialized or terminated, and not in the error state); elsewhere fmi2Error, nothing done. */
static int inquiry_refused(Shim *shim, const char *function, fmi2Status *status) {
    if (!shim->in_error && (shim->mode == INITIALIZED || shim->mode == TERMINATED)) return 0;
    char message[600];
    snprintf(message, sizeof message, "%s is not allowed in the %s state%s%s (FMI 2.0 allows the status inquiries "
             "after initialization: after fmi2DoStep and after fmi2Terminate)", function,
             shim->in_error ? "error" : MODE_NAME[shim->mode], shim->in_error ? ": " : "",
             shim->in_error ? shim->error_cause : "");
    *status = decline(shim, message);
    return 1;
}
#define INQUIRY(name) fmi2Status refused; if (inquiry_refused(shim, name, &refused)) return refused;

/* The FMU never returns fmi2Pending, so there is no asynchronous step whose status could be asked for. */
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Status *value) {
    BEGIN(c, "fmi2GetStatus") INQUIRY("fmi2GetStatus") (void)kind; (void)value;
    say(shim, fmi2Discard, "fmi2GetStatus: no such status (the FMU completes every step within fmi2DoStep)");
    return fmi2Discard;
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Real *value) {
    BEGIN(c, "fmi2GetRealStatus") INQUIRY("fmi2GetRealStatus") NEED(value, "fmi2GetRealStatus", "value")
    FORWARD("fmi2GetRealStatus", inner_fmi2GetRealStatus(shim->inner, kind, value));
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Integer *value) {
    BEGIN(c, "fmi2GetIntegerStatus") INQUIRY("fmi2GetIntegerStatus")
    FORWARD("fmi2GetIntegerStatus", inner_fmi2GetIntegerStatus(shim->inner, kind, value));
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Boolean *value) {
    BEGIN(c, "fmi2GetBooleanStatus") INQUIRY("fmi2GetBooleanStatus") NEED(value, "fmi2GetBooleanStatus", "value")
    FORWARD("fmi2GetBooleanStatus", inner_fmi2GetBooleanStatus(shim->inner, kind, value));
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind kind, fmi2String *value) {
    BEGIN(c, "fmi2GetStringStatus") INQUIRY("fmi2GetStringStatus")
    FORWARD("fmi2GetStringStatus", inner_fmi2GetStringStatus(shim->inner, kind, value));
}
