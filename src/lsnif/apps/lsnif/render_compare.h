// render_compare.h -- the paper's section-6 comparison for one scene: render it in reference and
// LSNIF mode with the same random sequences, FLIP the LSNIF image against the reference, report
// memory and time, and write the images side by side (reference | LSNIF | FLIP heatmap).
#pragma once
#include <string>

#include "lsnif/import/mesh.h"
#include "lsnif/renderer/render_choice.h"
#include "lsnif/renderer/renderer.h"
#include "lsnif/scene/scene.h"
#include "lsnif/format/status.h"

namespace lsnif::cli {

// A scene of one object: `mesh` (its triangles and first material's base color, the color the
// model learned) as a node that is also the LSNIF object `model_path`, standing on a grey ground
// quad, lit by the equirectangular `hdr_path` (empty: a constant sky), with a camera framing it.
scene::Scene object_on_ground(const Mesh& mesh, const std::string& model_path, const std::string& hdr_path);

struct CompareReport {
  render::RenderStats reference, lsnif;
  double flip_mean = 0, flip_median = 0;  // LDR-FLIP of the LSNIF image against the reference
};

// A reference render that several comparisons of the same scene, settings and pipeline share (it
// traces only the meshes, so it does not depend on the models).
struct ReferenceRender {
  image::Image image;  // empty until rendered
  render::RenderStats stats;
};

// Renders `scene` in both modes with `settings` (its `reference` field is ignored), computes
// LDR-FLIP (images clamped to [0, 1] as displayed), writes `side_by_side` (.png) and prints the rows.
// With `shared_reference`, the reference render is taken from it when it holds one, else rendered
// and kept there for the next comparison. With `reference_path`, the reference is rendered with
// its pipeline and primary visibility instead of those of `settings` (the same estimator and random
// sequences: e.g. the fastest triangle path against the LSNIF mode's choice).
Status render_compare(vk::Context& ctx, const scene::Scene& scene, render::RenderSettings settings,
                      const std::string& side_by_side, CompareReport& report,
                      ReferenceRender* shared_reference = nullptr,
                      const render::RenderChoice* reference_path = nullptr);

}  // namespace lsnif::cli
