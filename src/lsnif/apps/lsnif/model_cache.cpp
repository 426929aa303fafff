// model_cache.cpp -- see model_cache.h.
#include "lsnif/apps/lsnif/model_cache.h"

#include <cstdio>

#include "lsnif/format/file_io.h"
#include "lsnif/train/settings_io.h"
#include "lsnif/scene/scene_gltf.h"

namespace lsnif::cli {

int train_or_reuse(const char* command, const Mesh& mesh, const std::string& fingerprint, const std::string& label,
                   const TrainOptions& opts, bool retrain, CachedModel& out, const std::string& quality) {
  out = CachedModel();
  const std::string key_path = opts.output + ".key";
  TrainSettings ts;
  if (!opts.to_settings(ts)) return 2;
  const std::string key =
      model_key_head(fingerprint, quality) + "settings " + settings_to_json(ts).dump() + "\n";
  if (!retrain && scene::check_lsnif_file(opts.output) && file_holds(key_path, key)) {
    out.reused = true;
    std::printf("model     reusing %s (same mesh and settings; --retrain trains it again)\n", opts.output.c_str());
    return 0;
  }
  std::printf("model     training %s for %s (%zu triangles)\n", opts.output.c_str(), label.c_str(),
              mesh.triangles.size());
  std::fflush(stdout);
  TrainReport rep;
  if (int r = train_mesh(mesh, label, opts, nullptr, &rep)) return r;
  if (!write_text_file(command, key_path, key)) {
    std::fprintf(stderr, "lsnif %s: cannot write %s\n", command, key_path.c_str());
    return 1;
  }
  out.train_seconds = rep.seconds;
  return 0;
}

}  // namespace lsnif::cli
