/* consumer_c -- a C program with its own config.h ... host_device.h (own_headers.h) that uses the
 * plugin's C API: prints the plugin's version, a constant of LSNIF's host_device.h and the surface
 * channels lsnifUnpackSurface reads from a packed word (as of LsnifQueryHit::surface). */
#include <stdio.h>

#include <lsnif/lsnif.h>

#include "own_headers.h"

int main(void) {
  const uint32_t v = lsnifGetVersion();
  printf("plugin %u.%u.%u\nmax_points %u\n", LSNIF_VERSION_GET_MAJOR(v), LSNIF_VERSION_GET_MINOR(v),
         LSNIF_VERSION_GET_PATCH(v), (unsigned)LSNIF_MAX_POINTS);
  /* metallic 255, roughness 51, ambient occlusion 0, learned */
  const LsnifSurfaceChannels c = lsnifUnpackSurface(255U | 51U << 8 | LSNIF_SURFACE_LEARNED << 24);
  printf("surface %u %.2f %.2f %.2f\n", (unsigned)c.learned, (double)c.metallic, (double)c.roughness,
         (double)c.ambientOcclusion);
  return 0;
}
