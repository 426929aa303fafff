/* consumer_c -- a C program with its own config.h ... host_device.h (own_headers.h) that uses the
 * plugin's C API: prints the plugin's version and a constant of LSNIF's host_device.h. */
#include <stdio.h>

#include <lsnif/lsnif.h>

#include "own_headers.h"

int main(void) {
  const uint32_t v = lsnifGetVersion();
  printf("plugin %u.%u.%u\nmax_points %u\n", LSNIF_VERSION_GET_MAJOR(v), LSNIF_VERSION_GET_MINOR(v),
         LSNIF_VERSION_GET_PATCH(v), (unsigned)LSNIF_MAX_POINTS);
  return 0;
}
