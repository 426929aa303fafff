// render_random.glsl -- the path tracer's counter-based random numbers: a hash of (pixel, sample,
// dimension), and the camera's per-sample sub-pixel offset, which the visibility pass
// (render_visibility.vert) draws with too. Needs nothing else, so that shaders outside the path
// tracer's push-constant block can include it.
#ifndef RENDER_RANDOM_GLSL
#define RENDER_RANDOM_GLSL

// ---- random numbers: a hash of (pixel, sample, dimension) ----
struct RenderRng {
  uint key;
  uint dim;
};
uint render_hash(uint x) {  // a 32-bit integer finalizer (Wellons' lowbias32 constants)
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return x;
}
RenderRng render_rng(uint pixel, uint sample_index) {
  RenderRng r;
  r.key = render_hash(pixel * 0x9e3779b9u ^ render_hash(sample_index + 0x632be5abu));
  r.dim = 0u;
  return r;
}
float render_rand(inout RenderRng r) {
  const uint h = render_hash(r.key ^ render_hash(r.dim++ * 0x85ebca6bu + 0xc2b2ae35u));
  return float(h >> 8) * (1.0 / 16777216.0);
}
// The camera's sub-pixel offset of sample `sample_index`, in [0, 1)^2: the same for every pixel of
// the sample, so that a rasterizer can fold it into its projection (rasterized primary visibility
// sees the point the traced camera ray of the pixel sees).
vec2 render_camera_jitter(uint sample_index) {
  RenderRng r;
  r.key = render_hash(render_hash(sample_index + 0x3c6ef372u) ^ 0xa54ff53au);
  r.dim = 0u;
  return vec2(render_rand(r), render_rand(r));
}

#endif
