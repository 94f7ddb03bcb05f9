/* A stand-in for pythonfmu's library behind the FMU's shim (binaries/linux64/<model>_pythonfmu.so), for the tests of
 * what the shim does after fmi2Fatal (tests/fmu_shim_cases.py): pythonfmu answers fmi2Fatal when a Python exception
 * escapes and then has destroyed its Python instance, so any later call would use freed objects. This stub needs no
 * Python. Its first fmi2DoStep logs a message with pythonfmu's category "cppfmu" and returns fmi2Discard, the second
 * logs one with no category and returns fmi2Fatal; every call after that, fmi2FreeInstance included, prints
 * "STUB CALLED AFTER FATAL: <function>" on stderr and aborts the process. Every other call returns fmi2OK.
 */
#include <stdio.h>
#include <stdlib.h>

#include "fmi2Functions.h"

static const fmi2CallbackFunctions *host;
static int fatal, steps;
static int component;                       /* the address is the instance */

static fmi2Status called(const char *function) {
    if (fatal) {
        fprintf(stderr, "STUB CALLED AFTER FATAL: %s\n", function);
        fflush(stderr);
        abort();
    }
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String resources,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible, fmi2Boolean logging) {
    (void)name; (void)type; (void)guid; (void)resources; (void)visible; (void)logging;
    host = functions;
    return &component;
}
void fmi2FreeInstance(fmi2Component c) { (void)c; called("fmi2FreeInstance"); }
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real time, fmi2Real step, fmi2Boolean no_earlier_state) {
    (void)c; (void)time; (void)step; (void)no_earlier_state;
    called("fmi2DoStep");
    if (steps++ == 0) {
        host->logger(host->componentEnvironment, "stub", fmi2Discard, "cppfmu", "stub: a discarded step");
        return fmi2Discard;
    }
    host->logger(host->componentEnvironment, "stub", fmi2Fatal, NULL, "stub: a Python exception");
    fatal = 1;
    return fmi2Fatal;
}

#define ANSWER(name, parameters) fmi2Status name parameters { return called(#name); }
ANSWER(fmi2SetDebugLogging, (fmi2Component c, fmi2Boolean on, size_t n, const fmi2String categories[]))
ANSWER(fmi2SetupExperiment, (fmi2Component c, fmi2Boolean a, fmi2Real b, fmi2Real d, fmi2Boolean e, fmi2Real f))
ANSWER(fmi2EnterInitializationMode, (fmi2Component c))
ANSWER(fmi2ExitInitializationMode, (fmi2Component c))
ANSWER(fmi2Terminate, (fmi2Component c))
ANSWER(fmi2Reset, (fmi2Component c))
ANSWER(fmi2GetReal, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]))
ANSWER(fmi2GetInteger, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer value[]))
ANSWER(fmi2GetBoolean, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean value[]))
ANSWER(fmi2GetString, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String value[]))
ANSWER(fmi2SetReal, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]))
ANSWER(fmi2SetInteger, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer value[]))
ANSWER(fmi2SetBoolean, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean value[]))
ANSWER(fmi2SetString, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String value[]))
ANSWER(fmi2GetFMUstate, (fmi2Component c, fmi2FMUstate *state))
ANSWER(fmi2SetFMUstate, (fmi2Component c, fmi2FMUstate state))
ANSWER(fmi2FreeFMUstate, (fmi2Component c, fmi2FMUstate *state))
ANSWER(fmi2SerializedFMUstateSize, (fmi2Component c, fmi2FMUstate state, size_t *size))
ANSWER(fmi2SerializeFMUstate, (fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size))
ANSWER(fmi2DeSerializeFMUstate, (fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *state))
ANSWER(fmi2GetRealStatus, (fmi2Component c, const fmi2StatusKind kind, fmi2Real *value))
ANSWER(fmi2GetIntegerStatus, (fmi2Component c, const fmi2StatusKind kind, fmi2Integer *value))
ANSWER(fmi2GetBooleanStatus, (fmi2Component c, const fmi2StatusKind kind, fmi2Boolean *value))
ANSWER(fmi2GetStringStatus, (fmi2Component c, const fmi2StatusKind kind, fmi2String *value))
