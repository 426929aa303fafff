// render_compare.cpp -- see render_compare.h.
#include "lsnif/apps/lsnif/render_compare.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "lsnif/scene/environment.h"
#include "lsnif/apps/flip/flip.h"
#include "lsnif/image/image_io.h"
#include "lsnif/apps/common/progress.h"

namespace lsnif::cli {

scene::Scene object_on_ground(const Mesh& mesh, const std::string& model_path, const std::string& hdr_path) {
  scene::Scene s;
  s.path = "(" + model_path + " on a ground quad)";
  scene::Material object, ground;
  object.name = "object";
  object.base_color = mesh.materials.empty() ? glm::vec3(1.0f) : mesh.materials[0].base_color;
  object.metallic = 0.0f;
  object.roughness = 0.5f;
  ground.name = "ground";
  ground.base_color = glm::vec3(0.45f);
  ground.metallic = 0.0f;
  ground.roughness = 0.8f;
  s.materials = {object, ground};
  scene::Mesh m;
  m.name = "object";
  m.primitives.push_back(scene::primitive_from(mesh, 0));
  const Aabb b = mesh.bounds();
  const glm::vec3 c = b.center();
  const float r = 3.0f * b.diagonal(), y = b.lo.y;
  scene::Mesh quad;
  quad.name = "ground";
  scene::Primitive q;
  q.positions = {{c.x - r, y, c.z - r}, {c.x + r, y, c.z - r}, {c.x + r, y, c.z + r}, {c.x - r, y, c.z + r}};
  q.normals.assign(4, glm::vec3(0, 1, 0));
  q.indices = {0, 2, 1, 0, 3, 2};
  q.material = 1;
  quad.primitives.push_back(q);
  s.meshes = {m, quad};
  scene::LsnifObject obj;
  obj.model_path = model_path;
  obj.material_map = {0};
  s.lsnif_objects = {obj};
  scene::Instance o, g;
  o.node_name = "object";
  o.mesh = 0;
  o.lsnif = 0;
  g.node_name = "ground";
  g.mesh = 1;
  s.instances = {o, g};
  s.environment.path = hdr_path;
  scene::Camera cam;
  cam.name = "front";
  cam.yfov = 0.6f;
  const glm::vec3 eye = c + 1.25f * b.diagonal() * glm::normalize(glm::vec3(0.35f, 0.3f, 1.0f));
  const glm::vec3 fwd = glm::normalize(c - eye), right = glm::normalize(glm::cross(fwd, glm::vec3(0, 1, 0)));
  cam.camera_to_world =
      glm::mat4(glm::vec4(right, 0), glm::vec4(glm::cross(right, fwd), 0), glm::vec4(-fwd, 0), glm::vec4(eye, 1));
  s.cameras = {cam};
  return s;
}

namespace {

image::Image clamped(const image::Image& img) {
  image::Image out = img;
  for (float& v : out.rgb) v = std::isfinite(v) ? std::clamp(v, 0.0f, 1.0f) : 0.0f;
  return out;
}

}  // namespace

Status render_compare(vk::Context& ctx, const scene::Scene& scene, render::RenderSettings settings,
                      const std::string& side_by_side, CompareReport& report, ReferenceRender* shared_reference,
                      const render::RenderChoice* reference_path) {
  report = CompareReport();
  scene::EnvironmentMap env;
  if (!scene.environment.path.empty()) {
    if (Status s = scene::load_environment_map(scene.environment, env); !s) return s;
    settings.environment = &env;
  }
  render::Renderer renderer(ctx);
  image::Image ref, lsnif;
  const bool reuse = shared_reference && !shared_reference->image.rgb.empty();
  if (reuse) {
    ref = shared_reference->image;
    report.reference = shared_reference->stats;
    std::printf("render (reference): the same scene's reference render is reused\n");
  }
  // The reference's settings: the LSNIF mode's, on `reference_path` where given.
  settings.reference = false;
  render::RenderSettings ref_settings = settings;
  ref_settings.reference = true;
  if (reference_path) {
    ref_settings.pipeline = reference_path->pipeline;
    ref_settings.primary = reference_path->primary;
  }
  for (const bool reference : {true, false}) {
    if (reference && reuse) continue;
    const render::RenderSettings& rs = reference ? ref_settings : settings;
    ProgressBar bar(reference ? "render (reference)" : "render (LSNIF)", rs.spp);
    if (Status s = renderer.render(scene, rs, reference ? ref : lsnif, reference ? report.reference : report.lsnif,
                                   [&](uint32_t done) { bar.update(done); });
        !s)
      return s;
    bar.finish();
  }
  if (shared_reference && !reuse) *shared_reference = {ref, report.reference};
  const image::Image ref_c = clamped(ref), lsnif_c = clamped(lsnif);
  flip::FlipSettings fs;
  flip::FlipResult fr;
  if (Status s = flip::ldr_flip(ref_c, lsnif_c, fs, fr); !s) return s;
  report.flip_mean = fr.stats.mean;
  report.flip_median = fr.stats.weighted_median;

  image::Image row;
  row.width = 3 * ref.width;
  row.height = ref.height;
  row.rgb.resize(size_t(row.width) * row.height * 3);
  const image::Image* parts[3] = {&ref_c, &lsnif_c, &fr.heatmap};
  for (uint32_t y = 0; y < row.height; ++y)
    for (uint32_t k = 0; k < 3; ++k)
      for (uint32_t x = 0; x < ref.width; ++x)
        std::copy_n(parts[k]->at(x, y), 3, row.at(k * ref.width + x, y));
  if (Status s = image::save_image(side_by_side, row); !s) return s;

  const render::RenderStats& r = report.reference;
  const render::RenderStats& l = report.lsnif;
  std::printf("\nrendering %ux%u, %u spp, %u bounces on %s\n", settings.width, settings.height, settings.spp,
              settings.max_bounces, ctx.device_name().c_str());
  std::printf("  %-22s %14s %14s %10s\n", "", "reference", "LSNIF", "ratio");
  std::printf("  %-22s %14s %14s\n", "pipeline, primary", (std::string(render::pipeline_name(ref_settings.pipeline)) + ", " +
              render::primary_name(ref_settings.primary)).c_str(), (std::string(render::pipeline_name(settings.pipeline)) +
              ", " + render::primary_name(settings.primary)).c_str());
  std::printf("  %-22s %14.3f %14.3f %9.2fx\n", "geometry memory (MiB)", double(r.triangle_blas_bytes) / 1048576.0,
              double(l.lsnif_bytes + l.triangle_blas_bytes) / 1048576.0,
              double(r.triangle_blas_bytes) / double(std::max<uint64_t>(1, l.lsnif_bytes + l.triangle_blas_bytes)));
  std::printf("  %-22s %14.2f %14.2f %9.2fx\n", "ms per sample", r.ms_per_sample, l.ms_per_sample,
              l.ms_per_sample / std::max(1e-9, r.ms_per_sample));
  std::printf("  LDR-FLIP of LSNIF vs reference: mean %.4f, weighted median %.4f\n", report.flip_mean,
              report.flip_median);
  std::printf("  images: %s (reference | LSNIF | FLIP)\n", side_by_side.c_str());
  return Status::ok();
}

}  // namespace lsnif::cli
