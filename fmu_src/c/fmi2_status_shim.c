/* FMI 2.0 status shim: the FMU's binary, in front of pythonfmu's export library.
 *
 * pythonfmu 0.7.0 turns a Python exception into fmi2Fatal (and destroys the Python instance) and otherwise returns
 * only fmi2OK, or fmi2Discard from doStep. The FMI 2.0 standard asks for fmi2Error (the instance stays usable for
 * fmi2SetFMUstate / fmi2Reset) and fmi2Warning in many situations. This library forwards every FMI call to
 * pythonfmu's library (shipped beside it as <modelIdentifier>_pythonfmu.so) and gives each call the worst status
 * the Python slave logged during it (fmu_src/slave.py logs every refusal with the status it means), so the slave
 * decides the status and the shim carries it. The shim also
 *  - keeps the FMI error state: after a call returned fmi2Error, only the calls FMI 2.0 allows there are
 *    forwarded (getters, the FMU-state functions, fmi2Reset, fmi2FreeInstance, fmi2SetDebugLogging); the others
 *    are refused with fmi2Error naming the state and what put the instance there; a successful fmi2SetFMUstate or
 *    fmi2Reset leaves it;
 *  - forwards warnings and errors to the importer's logger even when debug logging is off (the importer must
 *    learn why a call failed), other messages only when it is on; a forwarded message is passed as the format,
 *    as pythonfmu does (the slave escapes % as %%);
 *  - refuses, before Python sees them, what pythonfmu would turn into fmi2Fatal or a crash: a string value that
 *    is not UTF-8, null pointers, and state bytes whose envelope (fmu_src/state_format.py) is not this build's:
 *    magic, format version, length, CRC-32 and the tag "<model>/<build fingerprint>" (STATE_TAG, given by
 *    fmu_src/status_shim.py when it compiles this file for one FMU).
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#ifndef STATE_TAG
#error "compile with -DSTATE_TAG='\"<model>/<build fingerprint>\"' (fmu_src/status_shim.py does)"
#endif

typedef struct {
    fmi2Component inner;
    fmi2CallbackFunctions host;      /* the importer's callbacks */
    fmi2CallbackFunctions own;       /* given to pythonfmu: logger = shim_logger, environment = this record */
    fmi2Boolean host_logging;
    fmi2Status worst_logged;         /* worst status logged by the slave during the current call */
    char first_error[320];           /* the first error message logged during the current call */
    int in_error;                    /* the FMI error state */
    char error_cause[400];           /* what put the instance into the error state */
    char *instance_name;
} Shim;

static void *library;
/* pythonfmu's functions that the shim forwards to (an X-macro: declared and loaded from one list) */
#define FORWARDED(X) X(fmi2SetDebugLogging) X(fmi2Instantiate) X(fmi2FreeInstance) X(fmi2SetupExperiment) \
    X(fmi2EnterInitializationMode) X(fmi2ExitInitializationMode) X(fmi2Terminate) X(fmi2Reset) X(fmi2GetReal) \
    X(fmi2GetInteger) X(fmi2GetBoolean) X(fmi2GetString) X(fmi2SetReal) X(fmi2SetInteger) X(fmi2SetBoolean) \
    X(fmi2SetString) X(fmi2GetFMUstate) X(fmi2SetFMUstate) X(fmi2FreeFMUstate) X(fmi2SerializedFMUstateSize) \
    X(fmi2SerializeFMUstate) X(fmi2DeSerializeFMUstate) X(fmi2GetDirectionalDerivative) \
    X(fmi2SetRealInputDerivatives) X(fmi2GetRealOutputDerivatives) X(fmi2DoStep) X(fmi2CancelStep) \
    X(fmi2GetRealStatus) X(fmi2GetIntegerStatus) X(fmi2GetBooleanStatus) X(fmi2GetStringStatus)
#define INNER(name) static name##TYPE *inner_##name;
FORWARDED(INNER)

/* Load pythonfmu's library from this library's folder; report on stderr why not (no logger exists yet). */
static int load_inner(void) {
    if (library) return 1;
    Dl_info self;
    if (!dladdr((void *)&load_inner, &self) || !self.dli_fname) {
        fprintf(stderr, "fmi2 status shim: cannot find its own file\n");
        return 0;
    }
    size_t length = strlen(self.dli_fname);
    char *path = malloc(length + 16);
    if (!path) return 0;
    strcpy(path, self.dli_fname);
    char *dot = strrchr(path, '.');
    if (!dot || strchr(dot, '/')) dot = path + length;
    strcpy(dot, "_pythonfmu.so");
    void *opened = dlopen(path, RTLD_LAZY | RTLD_LOCAL);
    if (!opened) {
        fprintf(stderr, "fmi2 status shim: cannot load %s: %s\n", path, dlerror());
        free(path);
        return 0;
    }
    free(path);
#define LOAD(name) if (!(inner_##name = (name##TYPE *)dlsym(opened, #name))) { \
        fprintf(stderr, "fmi2 status shim: pythonfmu's library lacks %s\n", #name); return 0; }
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

static void shim_logger(fmi2ComponentEnvironment environment, fmi2String instance, fmi2Status status,
                        fmi2String category, fmi2String message, ...) {
    Shim *shim = (Shim *)environment;
    if (severity(status) > severity(shim->worst_logged)) shim->worst_logged = status;
    if ((status == fmi2Error || status == fmi2Fatal) && !shim->first_error[0])
        copy_unescaped(shim->first_error, sizeof shim->first_error, message);
    if (shim->host.logger && (shim->host_logging || status == fmi2Warning || status == fmi2Error
                              || status == fmi2Fatal))
        shim->host.logger(shim->host.componentEnvironment, instance, status, category, message);
}

/* Log a message of the shim itself (not a format) to the importer. */
static void say(Shim *shim, fmi2Status status, const char *message) {
    if (shim->host.logger)
        shim->host.logger(shim->host.componentEnvironment, shim->instance_name, status,
                          status == fmi2Error ? "logStatusError" : "logStatusWarning", "%s", message);
}

static void enter_error_state(Shim *shim, const char *function, const char *reason) {
    if (shim->in_error) return;
    shim->in_error = 1;
    snprintf(shim->error_cause, sizeof shim->error_cause, "%s returned fmi2Error: %s", function,
             reason && reason[0] ? reason : "see the messages before");
}

/* A call refused by the shim itself: fmi2Error with `message`. */
static fmi2Status refuse(Shim *shim, const char *function, const char *message) {
    say(shim, fmi2Error, message);
    enter_error_state(shim, function, message);
    return fmi2Error;
}

/* The status of a forwarded call: the worse of what it returned and what the slave logged during it. */
static fmi2Status carried(Shim *shim, const char *function, fmi2Status returned) {
    fmi2Status status = severity(shim->worst_logged) > severity(returned) ? shim->worst_logged : returned;
    if (status == fmi2Error || status == fmi2Fatal) enter_error_state(shim, function, shim->first_error);
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

#define BEGIN(c) Shim *shim = (Shim *)(c); if (!shim) return fmi2Error; \
    shim->worst_logged = fmi2OK; shim->first_error[0] = '\0';
#define NOT_IN_ERROR(name) if (shim->in_error) return refuse_in_error_state(shim, name);
#define FORWARD(name, call) return carried(shim, name, call)
#define NEED(pointer, name, what) if (!(pointer)) return refuse(shim, name, name ": " what " is a null pointer; " \
                                                               "nothing was done");

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String resources,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible, fmi2Boolean logging) {
    if (!functions || !name || !resources || type != fmi2CoSimulation) {
        if (functions && functions->logger)
            functions->logger(functions->componentEnvironment, name ? name : "", fmi2Error, "logStatusError",
                              "fmi2Instantiate: %s", type != fmi2CoSimulation
                              ? "this FMU is for co-simulation only" : "a null instance name or resource location");
        return NULL;
    }
    if (!load_inner()) return NULL;
    Shim *shim = calloc(1, sizeof(Shim));
    if (!shim) return NULL;
    shim->host = *functions;
    shim->own = *functions;
    shim->own.logger = shim_logger;
    shim->own.componentEnvironment = shim;
    shim->host_logging = logging;
    shim->instance_name = strdup(name);
    shim->inner = inner_fmi2Instantiate(name, type, guid, resources, &shim->own, visible, fmi2True);
    if (!shim->inner) {
        free(shim->instance_name);
        free(shim);
        return NULL;
    }
    return shim;
}

void fmi2FreeInstance(fmi2Component c) {
    Shim *shim = (Shim *)c;
    if (!shim) return;
    inner_fmi2FreeInstance(shim->inner);
    free(shim->instance_name);
    free(shim);
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String categories[]) {
    BEGIN(c)
    if (n > 0) NEED(categories, "fmi2SetDebugLogging", "categories")
    for (size_t i = 0; i < n; i++) NEED(categories[i], "fmi2SetDebugLogging", "a category")
    shim->host_logging = on;
    FORWARD("fmi2SetDebugLogging", inner_fmi2SetDebugLogging(shim->inner, fmi2True, 0, NULL));
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean has_tolerance, fmi2Real tolerance, fmi2Real start,
                               fmi2Boolean has_stop, fmi2Real stop) {
    BEGIN(c) NOT_IN_ERROR("fmi2SetupExperiment")
    FORWARD("fmi2SetupExperiment", inner_fmi2SetupExperiment(shim->inner, has_tolerance, tolerance, start, has_stop,
                                                             stop));
}
fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    BEGIN(c) NOT_IN_ERROR("fmi2EnterInitializationMode")
    FORWARD("fmi2EnterInitializationMode", inner_fmi2EnterInitializationMode(shim->inner));
}
fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    BEGIN(c) NOT_IN_ERROR("fmi2ExitInitializationMode")
    FORWARD("fmi2ExitInitializationMode", inner_fmi2ExitInitializationMode(shim->inner));
}
fmi2Status fmi2Terminate(fmi2Component c) {
    BEGIN(c) NOT_IN_ERROR("fmi2Terminate")
    FORWARD("fmi2Terminate", inner_fmi2Terminate(shim->inner));
}
fmi2Status fmi2Reset(fmi2Component c) {
    BEGIN(c)
    int was_in_error = shim->in_error;
    shim->in_error = 0;
    fmi2Status status = carried(shim, "fmi2Reset", inner_fmi2Reset(shim->inner));
    if (status > fmi2Warning && was_in_error) shim->in_error = 1;
    return status;
}

#define GET(name, type) \
    fmi2Status name(fmi2Component c, const fmi2ValueReference vr[], size_t n, type value[]) { \
        BEGIN(c) if (n > 0) { NEED(vr, #name, "the value references") NEED(value, #name, "the values") } \
        FORWARD(#name, inner_##name(shim->inner, vr, n, value)); }
#define SET(name, type) \
    fmi2Status name(fmi2Component c, const fmi2ValueReference vr[], size_t n, const type value[]) { \
        BEGIN(c) NOT_IN_ERROR(#name) \
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
    BEGIN(c) NOT_IN_ERROR("fmi2SetString")
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

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    BEGIN(c) NEED(state, "fmi2GetFMUstate", "the state pointer")
    if (*state) {          /* FMI 2.0: a state given back is overwritten; pythonfmu would leak it */
        fmi2FMUstate old = *state;
        inner_fmi2FreeFMUstate(shim->inner, &old);
        *state = NULL;
    }
    FORWARD("fmi2GetFMUstate", inner_fmi2GetFMUstate(shim->inner, state));
}
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    BEGIN(c) NEED(state, "fmi2SetFMUstate", "the state")
    int was_in_error = shim->in_error;
    shim->in_error = 0;
    fmi2Status status = carried(shim, "fmi2SetFMUstate", inner_fmi2SetFMUstate(shim->inner, state));
    if (status > fmi2Warning && was_in_error) shim->in_error = 1;
    return status;
}
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    BEGIN(c)
    if (!state || !*state) return fmi2OK;              /* FMI 2.0: freeing a null state does nothing */
    fmi2Status status = carried(shim, "fmi2FreeFMUstate", inner_fmi2FreeFMUstate(shim->inner, state));
    *state = NULL;                                     /* FMI 2.0; pythonfmu leaves the pointer dangling */
    return status;
}
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size) {
    BEGIN(c) NEED(state, "fmi2SerializedFMUstateSize", "the state") NEED(size, "fmi2SerializedFMUstateSize", "size")
    FORWARD("fmi2SerializedFMUstateSize", inner_fmi2SerializedFMUstateSize(shim->inner, state, size));
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    BEGIN(c) NEED(state, "fmi2SerializeFMUstate", "the state")
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

/* The envelope of fmu_src/state_format.py (HEADER "<10sHQI72s"): magic, format version (uint16), length of the
 * payload (uint64), CRC-32 of the payload (uint32), tag (72 bytes, NUL-padded). */
#define STATE_MAGIC "RVFMUSTATE"
#define STATE_VERSION 2u
#define MAGIC_SIZE 10
#define TAG_SIZE 72
#define HEADER_SIZE (MAGIC_SIZE + 2 + 8 + 4 + TAG_SIZE)

static uint64_t little_endian(const unsigned char *bytes, int count) {
    uint64_t value = 0;
    for (int i = count - 1; i >= 0; i--) value = value << 8 | bytes[i];
    return value;
}

static uint32_t crc32(const unsigned char *data, size_t size) {   /* zlib's CRC-32 (reflected 0xEDB88320) */
    static uint32_t table[256];
    static int ready;
    if (!ready) {
        for (uint32_t n = 0; n < 256; n++) {
            uint32_t value = n;
            for (int k = 0; k < 8; k++) value = value & 1 ? 0xEDB88320u ^ (value >> 1) : value >> 1;
            table[n] = value;
        }
        ready = 1;
    }
    uint32_t crc = 0xFFFFFFFFu;
    for (size_t i = 0; i < size; i++) crc = table[(crc ^ data[i]) & 0xFF] ^ (crc >> 8);
    return crc ^ 0xFFFFFFFFu;
}

/* Why `bytes` are not a serialized state of this build, or NULL. */
static const char *envelope_error(const unsigned char *bytes, size_t size, char *text, size_t room) {
    if (size < HEADER_SIZE || memcmp(bytes, STATE_MAGIC, MAGIC_SIZE) != 0) {
        snprintf(text, room, "these %zu bytes are not a serialized state of this FMU (no " STATE_MAGIC " header)",
                 size);
        return text;
    }
    unsigned version = (unsigned)little_endian(bytes + MAGIC_SIZE, 2);
    if (version != STATE_VERSION) {
        snprintf(text, room, "state format version %u, this FMU reads version %u", version, STATE_VERSION);
        return text;
    }
    uint64_t length = little_endian(bytes + MAGIC_SIZE + 2, 8);
    if (length != size - HEADER_SIZE) {
        snprintf(text, room, "state of %zu bytes, its header announces %llu (truncated or extended)", size,
                 (unsigned long long)length + HEADER_SIZE);
        return text;
    }
    if (crc32(bytes + HEADER_SIZE, size - HEADER_SIZE) != (uint32_t)little_endian(bytes + MAGIC_SIZE + 10, 4)) {
        snprintf(text, room, "state checksum mismatch (the bytes were changed after serialization)");
        return text;
    }
    char tag[TAG_SIZE + 1] = {0};
    memcpy(tag, bytes + MAGIC_SIZE + 14, TAG_SIZE);
    if (strcmp(tag, STATE_TAG) != 0) {
        snprintf(text, room, "state of another model or build (its tag is not " STATE_TAG ")");
        return text;
    }
    return NULL;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *state) {
    BEGIN(c) NEED(state, "fmi2DeSerializeFMUstate", "the state pointer")
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
        inner_fmi2FreeFMUstate(shim->inner, state);
        *state = NULL;
        return refuse(shim, "fmi2DeSerializeFMUstate", "fmi2DeSerializeFMUstate: the bytes have this FMU's envelope "
                      "but their content is not a state of this build (the reason is on stderr); nothing was read");
    }
    return status;
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference unknown[], size_t n_unknown,
                                        const fmi2ValueReference known[], size_t n_known, const fmi2Real seed[],
                                        fmi2Real sensitivity[]) {
    BEGIN(c) FORWARD("fmi2GetDirectionalDerivative", inner_fmi2GetDirectionalDerivative(
        shim->inner, unknown, n_unknown, known, n_known, seed, sensitivity));
}
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    BEGIN(c) NOT_IN_ERROR("fmi2SetRealInputDerivatives")
    FORWARD("fmi2SetRealInputDerivatives", inner_fmi2SetRealInputDerivatives(shim->inner, vr, n, order, value));
}
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer order[], fmi2Real value[]) {
    BEGIN(c)
    FORWARD("fmi2GetRealOutputDerivatives", inner_fmi2GetRealOutputDerivatives(shim->inner, vr, n, order, value));
}
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real time, fmi2Real step, fmi2Boolean no_earlier_state) {
    BEGIN(c) NOT_IN_ERROR("fmi2DoStep")
    FORWARD("fmi2DoStep", inner_fmi2DoStep(shim->inner, time, step, no_earlier_state));
}
fmi2Status fmi2CancelStep(fmi2Component c) {
    BEGIN(c) NOT_IN_ERROR("fmi2CancelStep")
    FORWARD("fmi2CancelStep", inner_fmi2CancelStep(shim->inner));
}
/* The FMU never returns fmi2Pending, so there is no asynchronous step whose status could be asked for. */
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Status *value) {
    BEGIN(c) (void)kind; (void)value;
    say(shim, fmi2Warning, "fmi2GetStatus: no such status (the FMU completes every step within fmi2DoStep)");
    return fmi2Discard;
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Real *value) {
    BEGIN(c) NEED(value, "fmi2GetRealStatus", "value")
    FORWARD("fmi2GetRealStatus", inner_fmi2GetRealStatus(shim->inner, kind, value));
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Integer *value) {
    BEGIN(c) FORWARD("fmi2GetIntegerStatus", inner_fmi2GetIntegerStatus(shim->inner, kind, value));
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Boolean *value) {
    BEGIN(c) NEED(value, "fmi2GetBooleanStatus", "value")
    FORWARD("fmi2GetBooleanStatus", inner_fmi2GetBooleanStatus(shim->inner, kind, value));
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind kind, fmi2String *value) {
    BEGIN(c) FORWARD("fmi2GetStringStatus", inner_fmi2GetStringStatus(shim->inner, kind, value));
}
