/* A Python interpreter for pythonfmu's library in a host that is not a Python program (fmu_src/c/host_python.c). */
#ifndef HOST_PYTHON_H
#define HOST_PYTHON_H
#include <stddef.h>

#define PYTHON_OVERRIDE_VARIABLE "ROTARY_VANE_PYTHON"

/* Make libpython's symbols available to libraries loaded afterwards and tell it which interpreter it is, unless the
 * process already has a Python: 1 when pythonfmu's library may be loaded, else 0 with what was looked for and how to
 * point the FMU at an interpreter in `why`. Thread-safe; the work is done once per process. */
int host_python_ready(char *why, size_t room);

/* The python executable host_python_ready gave libpython as its program name; NULL if the process had a Python. */
const char *host_python_chosen(void);

#endif
