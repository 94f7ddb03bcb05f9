/* The envelope of fmu_src/state_format.py (HEADER "<10sHQI72s"): magic, format version (uint16), length of the
 * payload (uint64), CRC-32 of the payload (uint32), tag (72 bytes, NUL-padded) "<model>/<build fingerprint>"
 * (STATE_TAG, given by fmu_src/status_shim.py when it compiles the shim for one FMU). */
#include "state_envelope.h"

#include <stdint.h>
#include <stdio.h>
#include <string.h>

#ifndef STATE_TAG
#error "compile with -DSTATE_TAG='\"<model>/<build fingerprint>\"' (fmu_src/status_shim.py does)"
#endif

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

const char *envelope_error(const unsigned char *bytes, size_t size, char *text, size_t room) {
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

