/* The envelope of a serialized FMU state (fmu_src/state_format.py), checked before Python sees the bytes. */
#ifndef STATE_ENVELOPE_H
#define STATE_ENVELOPE_H
#include <stddef.h>

/* Why `bytes` are not a serialized state of this build (written into `text`), or NULL. */
const char *envelope_error(const unsigned char *bytes, size_t size, char *text, size_t room);

#endif
