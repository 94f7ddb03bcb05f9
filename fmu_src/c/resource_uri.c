/* The resource location of fmi2Instantiate: FMI 2.0 gives it as a URI (RFC 3986) whose scheme the FMU must
 * understand; this FMU reads local folders, named in every form importers use:
 *   file:///abs/resources          the usual form (fmpy, FMI Library)
 *   file:////abs/resources         an empty authority and a path that starts with "//" (Ecos: "file:///" + "/tmp/...")
 *   file:/abs/resources            no authority (RFC 8089)
 *   file://localhost/abs/resources the local host named
 * with percent-encoded bytes (%20 for a space, UTF-8 bytes of non-ASCII names) decoded. A plain path without a
 * scheme is refused (FMI 2.0 asks for a URI; the message shows the form to use), as are other schemes (http:),
 * another host, a relative path, a query or fragment, a malformed escape, an encoded NUL, and a path that is not an
 * existing folder. */
#define _GNU_SOURCE
#include "resource_uri.h"

#include <ctype.h>
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

static int hex_digit(char c) {
    return c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                                                                                       : -1;
}

/* `text` with its %XX escapes decoded into `out`: 1, or 0 with the reason in `why`. */
static int percent_decoded(const char *text, char *out, size_t room, char *why, size_t why_room) {
    size_t n = 0;
    for (const char *p = text; *p; p++) {
        char c = *p;
        if (c == '%') {
            int high = hex_digit(p[1]), low = high < 0 ? -1 : hex_digit(p[2]);
            if (low < 0) {
                snprintf(why, why_room, "it has a malformed percent escape at \"%.3s\" (expected %% and two hex digits)",
                         p);
                return 0;
            }
            c = (char)(high * 16 + low);
            if (c == '\0') {
                snprintf(why, why_room, "it encodes a NUL byte (%%00)");
                return 0;
            }
            p += 2;
        }
        if (n + 1 >= room) {
            snprintf(why, why_room, "its path is longer than %zu bytes", room - 1);
            return 0;
        }
        out[n++] = c;
    }
    out[n] = '\0';
    return 1;
}

/* The length of the URI scheme at the start of `text` ("file" in "file:..."), or 0 if it does not start with one. */
static size_t scheme_length(const char *text) {
    if (!isalpha((unsigned char)text[0])) return 0;
    size_t n = 1;
    while (isalnum((unsigned char)text[n]) || text[n] == '+' || text[n] == '-' || text[n] == '.') n++;
    return text[n] == ':' ? n : 0;
}

int resource_folder(const char *location, char *folder, size_t room, char *why, size_t why_room) {
    static const char EXPECTED[] = "; expected a file URI of the FMU's unpacked resources folder, e.g. "
                                   "file:///path/to/unpacked/resources";
    char reason[400];
    if (!location || !location[0]) {
        snprintf(why, why_room, "the resource location is %s%s", location ? "empty" : "a null pointer", EXPECTED);
        return 0;
    }
    size_t scheme = scheme_length(location);
    if (scheme == 0) {
        snprintf(why, why_room, "the resource location \"%s\" is not a URI (FMI 2.0 asks for one: for a folder "
                 "/x/resources give file:///x/resources)", location);
        return 0;
    }
    if (scheme != 4 || strncasecmp(location, "file", 4) != 0) {
        snprintf(why, why_room, "the resource location \"%s\" has the scheme \"%.*s:\": this FMU reads only a local "
                 "folder (file:)%s", location, (int)scheme, location, EXPECTED);
        return 0;
    }
    const char *path = location + 5;
    if (path[0] == '/' && path[1] == '/') {                  /* an authority: empty or localhost */
        const char *authority = path + 2;
        size_t length = strcspn(authority, "/");
        if (length > 0 && !(length == 9 && strncasecmp(authority, "localhost", 9) == 0)) {
            snprintf(why, why_room, "the resource location \"%s\" names the host \"%.*s\": this FMU reads only a "
                     "local folder (file:///path or file://localhost/path)", location, (int)length, authority);
            return 0;
        }
        path = authority + length;
    }
    if (path[0] != '/') {
        snprintf(why, why_room, "the resource location \"%s\" has no absolute path%s", location, EXPECTED);
        return 0;
    }
    if (strpbrk(path, "?#")) {
        snprintf(why, why_room, "the resource location \"%s\" has a query or fragment (? or #); a folder name "
                 "with these characters is written %%3F and %%23", location);
        return 0;
    }
    char decoded[PATH_MAX];
    if (!percent_decoded(path, decoded, sizeof decoded, reason, sizeof reason)) {
        snprintf(why, why_room, "the resource location \"%s\" cannot be decoded: %s", location, reason);
        return 0;
    }
    char real[PATH_MAX];
    struct stat info;
    if (!realpath(decoded, real) || stat(real, &info) != 0) {
        snprintf(why, why_room, "the resource location \"%s\" names the folder \"%s\", which cannot be opened: %s",
                 location, decoded, strerror(errno));
        return 0;
    }
    if (!S_ISDIR(info.st_mode)) {
        snprintf(why, why_room, "the resource location \"%s\" names \"%s\", which is not a folder", location, real);
        return 0;
    }
    if (strlen(real) + 1 > room) {
        snprintf(why, why_room, "the resources folder's path \"%s\" is longer than %zu bytes", real, room - 1);
        return 0;
    }
    strcpy(folder, real);
    return 1;
}
