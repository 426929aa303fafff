// render_visibility.glsl -- the first path vertex from the visibility buffer (rasterized primary
// visibility, RenderFrame::primary_raster), for both pipelines (render.rgen, render_wave.comp):
// the surface at the rasterized triangle's barycentrics (render_triangle_hit), at the rasterized
// distance along the pixel's camera ray. An LSNIF record's texel is a triangle of the node's kept
// mesh: it is shaded from the mesh (the paper's section 4) and is a triangle hit in every respect,
// so the rays leaving it start 1e-4 (relative) off the mesh along its normal, without the LSNIF
// leaving rule's tmin and culling (docs/self-intersection.md: measured closer to the reference).
#ifndef RENDER_VISIBILITY_GLSL
#define RENDER_VISIBILITY_GLSL

#include "lsnif/renderer/shaders/render_surface.glsl"
#include "lsnif/renderer/shaders/render_path.glsl"

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer RenderVisibilityRef { RenderVisibility v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer RenderVisibilityMat3Ref { mat3 v[]; };

// The camera ray `ray` of sample `sample_index` at `pixel`: false when the pixel saw nothing, else
// the surface (hit) and the point p on the ray.
bool render_visibility_hit(RenderFrame f, uint pixel, uint sample_index, RenderRay ray, out RenderHit hit, out vec3 p) {
  const uint texel = (sample_index - f.visibility_first_sample) * f.width * f.height + pixel;
  const RenderVisibility v = RenderVisibilityRef(f.visibility).v[texel];
  p = ray.origin;
  if (v.instance == RENDER_VISIBILITY_NONE) return false;
  const uint custom_index = v.instance & ((1u << RENDER_VISIBILITY_GEOMETRY_SHIFT) - 1u);
  const uint geometry = v.instance >> RENDER_VISIBILITY_GEOMETRY_SHIFT;
  const float t = RenderFloatRef(f.visibility_t).v[texel];
  const mat3 w2o = RenderVisibilityMat3Ref(f.world_to_object).v[custom_index];
  hit = render_triangle_hit(f, custom_index, geometry, v.primitive, vec2(v.barycentric_u, v.barycentric_v), w2o, t);
  p = ray.origin + t * ray.direction;
  return true;
}

#endif
