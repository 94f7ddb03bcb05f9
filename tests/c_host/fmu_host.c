/* A minimal FMI 2.0 co-simulation host in C (no FMI headers needed: the types below are those of the standard's
 * fmi2TypesPlatform.h / fmi2FunctionTypes.h). It stands for the non-Python importers (OMSimulator, Simulink,
 * Dymola, ...): it loads the FMU binary with dlopen and runs it through the plain FMI 2 C API.
 *
 * usage: fmu_host UNZIPPED_FMU_DIR MODEL_IDENTIFIER GUID VR_SPEED VR_TORQUE_MEAN VR_INPUT_POWER SPEED_RPM
 *                 STEPS STEP_SIZE [--quick-exit] [--null-guid] [--resources=LOCATION]
 *
 * The resource location is file://UNZIPPED_FMU_DIR/resources unless --resources gives it; --null-guid passes a
 * null pointer as the GUID. The host prints the time from its start to the end of the first fmi2DoStep
 * ("FIRST_STEP_SECONDS").
 *
 * Prints every log message (the message is a printf format, formatted with vprintf), a line for every call that
 * did not return fmi2OK, the outputs after every 50th step and at the end ("RESULT ..."), and "WORST_STATUS n".
 * Exit status: 0 if every call returned fmi2OK, 3 if one did not (or fmi2Instantiate returned NULL), 2 on a
 * usage/loading error.
 *
 * After fmi2FreeInstance and dlclose the host returns from main (a normal exit, which runs the libraries'
 * destructors) or, with --quick-exit, ends with _exit() (no destructors). pythonfmu 0.7.0's binary corrupts the
 * heap in its destructors at exit, which aborts a normal exit when scipy's libgfortran is loaded (numba loads it).
 */
#define _POSIX_C_SOURCE 200809L
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Boolean;
typedef const char *fmi2String;
typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef enum { fmi2ModelExchange, fmi2CoSimulation } fmi2Type;

typedef void (*fmi2CallbackLogger)(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String, fmi2String, ...);
typedef void *(*fmi2CallbackAllocateMemory)(size_t, size_t);
typedef void (*fmi2CallbackFreeMemory)(void *);
typedef void (*fmi2StepFinished)(fmi2ComponentEnvironment, fmi2Status);
typedef struct {
    fmi2CallbackLogger logger;
    fmi2CallbackAllocateMemory allocateMemory;
    fmi2CallbackFreeMemory freeMemory;
    fmi2StepFinished stepFinished;
    fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

typedef fmi2Component (*fmi2InstantiateTYPE)(fmi2String, fmi2Type, fmi2String, fmi2String,
                                             const fmi2CallbackFunctions *, fmi2Boolean, fmi2Boolean);
typedef fmi2Status (*fmi2SetupExperimentTYPE)(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real, fmi2Boolean,
                                              fmi2Real);
typedef fmi2Status (*fmi2ComponentTYPE)(fmi2Component);   /* Enter/ExitInitializationMode, Terminate */
typedef fmi2Status (*fmi2DoStepTYPE)(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean);
typedef fmi2Status (*fmi2SetRealTYPE)(fmi2Component, const fmi2ValueReference[], size_t, const fmi2Real[]);
typedef fmi2Status (*fmi2GetRealTYPE)(fmi2Component, const fmi2ValueReference[], size_t, fmi2Real[]);
typedef void (*fmi2FreeInstanceTYPE)(fmi2Component);

static const char *STATUS_NAME[] = {"OK", "WARNING", "DISCARD", "ERROR", "FATAL", "PENDING"};
static int worst = fmi2OK;

static const char *status_name(int status) {
    return status >= 0 && status <= fmi2Pending ? STATUS_NAME[status] : "ILLEGAL";
}

static void note(int status) {
    if (status < 0 || status > fmi2Pending) status = fmi2Fatal;   /* an illegal code counts as the worst */
    if (status > worst) worst = status;
}

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    va_list args;
    (void)env;
    printf("LOG [%s] %s %s: ", status_name(status), instance ? instance : "?", category ? category : "");
    va_start(args, message);
    vprintf(message, args);
    va_end(args);
    printf("\n");
    fflush(stdout);
}

static int check(const char *function, fmi2Status status) {
    note(status);
    if (status != fmi2OK) {
        printf("CALL %s -> %s\n", function, status_name(status));
        fflush(stdout);
    }
    return status;
}

static void *symbol(void *library, const char *name) {
    void *address = dlsym(library, name);
    if (address == NULL) {
        fprintf(stderr, "missing symbol %s: %s\n", name, dlerror());
        exit(2);
    }
    return address;
}

int main(int argc, char **argv) {
    char path[4096], resources[4096];
    struct timespec started;
    clock_gettime(CLOCK_MONOTONIC, &started);
    int quick_exit = 0, usage_error = argc < 10;
    const char *location = NULL, *guid = argc < 10 ? NULL : argv[3];
    for (int i = 10; i < argc; i++) {
        if (strcmp(argv[i], "--quick-exit") == 0) quick_exit = 1;
        else if (strcmp(argv[i], "--null-guid") == 0) guid = NULL;
        else if (strncmp(argv[i], "--resources=", 12) == 0) location = argv[i] + 12;
        else usage_error = 1;
    }
    if (usage_error) {
        fprintf(stderr, "usage: %s DIR MODEL_IDENTIFIER GUID VR_SPEED VR_TORQUE_MEAN VR_INPUT_POWER SPEED_RPM "
                        "STEPS STEP_SIZE [--quick-exit] [--null-guid] [--resources=LOCATION]\n", argv[0]);
        return 2;
    }
    const char *directory = argv[1], *identifier = argv[2];
    fmi2ValueReference speed_vr = (fmi2ValueReference)strtoul(argv[4], NULL, 10);
    fmi2ValueReference output_vr[2] = {(fmi2ValueReference)strtoul(argv[5], NULL, 10),
                                       (fmi2ValueReference)strtoul(argv[6], NULL, 10)};
    fmi2Real speed = strtod(argv[7], NULL);
    long steps = strtol(argv[8], NULL, 10);
    fmi2Real step_size = strtod(argv[9], NULL);

    snprintf(path, sizeof path, "%s/binaries/linux64/%s.so", directory, identifier);
    if (location) snprintf(resources, sizeof resources, "%s", location);
    else snprintf(resources, sizeof resources, "file://%s/resources", directory);
    void *library = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (library == NULL) {
        fprintf(stderr, "dlopen failed: %s\n", dlerror());
        return 2;
    }
    fmi2InstantiateTYPE instantiate = (fmi2InstantiateTYPE)symbol(library, "fmi2Instantiate");
    fmi2SetupExperimentTYPE setup = (fmi2SetupExperimentTYPE)symbol(library, "fmi2SetupExperiment");
    fmi2ComponentTYPE enter = (fmi2ComponentTYPE)symbol(library, "fmi2EnterInitializationMode");
    fmi2ComponentTYPE leave = (fmi2ComponentTYPE)symbol(library, "fmi2ExitInitializationMode");
    fmi2DoStepTYPE do_step = (fmi2DoStepTYPE)symbol(library, "fmi2DoStep");
    fmi2SetRealTYPE set_real = (fmi2SetRealTYPE)symbol(library, "fmi2SetReal");
    fmi2GetRealTYPE get_real = (fmi2GetRealTYPE)symbol(library, "fmi2GetReal");
    fmi2ComponentTYPE terminate = (fmi2ComponentTYPE)symbol(library, "fmi2Terminate");
    fmi2FreeInstanceTYPE free_instance = (fmi2FreeInstanceTYPE)symbol(library, "fmi2FreeInstance");

    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    fmi2Component c = instantiate("c_host", fmi2CoSimulation, guid, resources, &callbacks, 0, 1);
    if (c == NULL) {
        printf("CALL fmi2Instantiate -> NULL\nWORST_STATUS 4\n");
        return 3;
    }
    check("fmi2SetupExperiment", setup(c, 0, 0.0, 0.0, 1, steps * step_size));
    check("fmi2SetReal(shaft_speed)", set_real(c, &speed_vr, 1, &speed));
    check("fmi2EnterInitializationMode", enter(c));
    check("fmi2ExitInitializationMode", leave(c));

    fmi2Real time = 0.0, outputs[2] = {0.0, 0.0};
    long step;
    for (step = 0; step < steps; step++) {
        if (check("fmi2SetReal(shaft_speed)", set_real(c, &speed_vr, 1, &speed)) > fmi2Warning) break;
        if (check("fmi2DoStep", do_step(c, time, step_size, 1)) > fmi2Warning) break;
        if (step == 0) {
            struct timespec now;
            clock_gettime(CLOCK_MONOTONIC, &now);
            printf("FIRST_STEP_SECONDS %.3f\n", (double)(now.tv_sec - started.tv_sec)
                                                  + 1e-9 * (double)(now.tv_nsec - started.tv_nsec));
        }
        time = (step + 1) * step_size;          /* no accumulated rounding */
        if (check("fmi2GetReal", get_real(c, output_vr, 2, outputs)) > fmi2Warning) break;
        if ((step + 1) % 50 == 0)
            printf("STEP %ld time=%.6g shaft_torque_mean=%.17g input_power=%.17g\n", step + 1, time, outputs[0],
                   outputs[1]);
    }
    printf("RESULT steps=%ld time=%.17g shaft_torque_mean=%.17g input_power=%.17g\n", step, time, outputs[0],
           outputs[1]);
    check("fmi2Terminate", terminate(c));
    free_instance(c);
    dlclose(library);
    printf("WORST_STATUS %d\n", worst);
    fflush(stdout);
    if (quick_exit) _exit(worst == fmi2OK ? 0 : 3);
    return worst == fmi2OK ? 0 : 3;
}
