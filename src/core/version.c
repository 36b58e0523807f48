/* version.c: hd_version(), the library's own version from the header it was built with. */
#include "core/core.h"

#define HD_STR_(x) #x
#define HD_STR(x) HD_STR_(x)

const char *hd_version(void)
{
    return HD_STR(HDNET_VERSION_MAJOR) "." HD_STR(HDNET_VERSION_MINOR) "." HD_STR(HDNET_VERSION_PATCH);
}
