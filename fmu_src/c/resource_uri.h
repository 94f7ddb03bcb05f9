/* The local folder named by the resource location an importer gives fmi2Instantiate (fmu_src/c/resource_uri.c). */
#ifndef RESOURCE_URI_H
#define RESOURCE_URI_H
#include <stddef.h>

/* Decode `location`, a file URI of a local folder, into the folder's real path (symbolic links, "." and ".." and
 * repeated slashes resolved) in `folder`: 1 on success, else 0 with the reason in `why`. */
int resource_folder(const char *location, char *folder, size_t room, char *why, size_t why_room);

#endif
