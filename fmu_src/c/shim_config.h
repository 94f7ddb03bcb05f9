/* What fmu_src/status_shim.py compiles into one FMU's shim (it writes these definitions into a generated C file). */
#ifndef SHIM_CONFIG_H
#define SHIM_CONFIG_H

extern const char SHIM_MODEL_GUID[];          /* the guid of the FMU's modelDescription.xml */
extern const char SHIM_PYTHON_VERSION[];      /* major.minor of the building interpreter, e.g. "3.11" */
extern const char SHIM_PYTHON_EXECUTABLE[];   /* its sys.executable (a virtual environment's python, if built in one) */
extern const char SHIM_PYTHON_LIBRARY[];      /* its shared libpython, "" if it has none */

#endif
