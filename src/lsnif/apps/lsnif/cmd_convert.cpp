// lsnif convert IN.gltf -o OUT.gltf: train LSNIF models for a glTF scene's heavy objects and write
// the scene with LSNIF_neural_object on them (src/lsnif/apps/convert, docs/convert.md).
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/apps/lsnif/commands.h"
#include "lsnif/apps/convert/convert.h"
#include "lsnif/apps/convert/convert_blas_device.h"
#include "lsnif/apps/lsnif/device_option.h"
#include "lsnif/apps/lsnif/train_options.h"

namespace lsnif::cli {

namespace {
// Takes every "--group NAME=REGEX" / "--group=NAME=REGEX" out of argv (Args keeps one value per
// option); returns false with a message when one has no value or no '='.
bool take_groups(int& argc, char** argv, std::vector<convert::GroupRule>& groups) {
  int w = 0;
  for (int i = 0; i < argc; ++i) {
    std::string a = argv[i], value;
    if (a == "--group") {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "lsnif convert: --group needs a value NAME=REGEX\n");
        return false;
      }
      value = argv[++i];
    } else if (a.rfind("--group=", 0) == 0) {
      value = a.substr(8);
    } else {
      argv[w++] = argv[i];
      continue;
    }
    const size_t eq = value.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == value.size()) {
      std::fprintf(stderr, "lsnif convert: --group '%s': expected NAME=REGEX\n", value.c_str());
      return false;
    }
    groups.push_back({value.substr(0, eq), value.substr(eq + 1)});
  }
  argc = w;
  return true;
}
// Models trained at once: each holds its mesh, rays and optimizer state (tens to hundreds of MiB).
constexpr uint32_t kMaxConvertJobs = 64;

}  // namespace

int cmd_convert(int argc, char** argv) {
  convert::ConvertSettings cs;
  TrainOptions opts;
  std::string group_help;  // shown in --help only; the values are taken by take_groups
  // Args reads floats: the margin as given, widened to the settings' double after parsing.
  float margin = float(cs.memory_margin);
  bool blas_on_device = false;
  std::string device;
  Args args("convert",
            "Converts a glTF scene for LSNIF rendering: trains one model per selected glTF mesh (instances\n"
            "share it) or per --group, writes OUT.gltf (-o, must end in .gltf) with the LSNIF_neural_object\n"
            "extension on the converted nodes, OUT.bin and the models OUT.NAME.lsnif (+ .json sidecar with\n"
            "the content hash: unchanged models are not retrained). Node extras {\"lsnif\": true|false}\n"
            "force a node in or out; {\"lsnif_group\": \"NAME\"} puts it in a group. See docs/convert.md.\n"
            "The training options are those of `lsnif train`.");
  args.positional("IN", "input scene (.gltf or .glb)", &cs.input);
  args.option("convert-when",
              "the rule for meshes and groups no tag decides: memory (where the triangle BLASes freed are at "
              "least --memory-margin x the model's bytes) or triangles (at least --min-triangles)",
              "memory|triangles", "memory", [&cs](const std::string& v) {
                if (v != "memory" && v != "triangles") return false;
                cs.convert_when = v == "memory" ? convert::ConvertWhen::Memory : convert::ConvertWhen::Triangles;
                return true;
              });
  args.option("memory-margin",
              "--convert-when memory: BLAS bytes freed per byte of model", &margin,
              float(convert::kMinMemoryMargin), float(convert::kMaxMemoryMargin));
  args.option("blas-size",
              "how the triangle BLAS sizes are found: estimate (calibrated on lavapipe, no device) or device (the "
              "Vulkan device's size query, as the renderer builds them)",
              "estimate|device", "estimate", [&blas_on_device](const std::string& v) {
                if (v != "estimate" && v != "device") return false;
                blas_on_device = v == "device";
                return true;
              });
  add_device_option(args, &device);
  args.option("min-triangles",
              "meshes with fewer triangles stay triangle meshes (the rule of --convert-when triangles, a lower bound "
              "under memory)",
              &cs.min_triangles, 0, UINT64_MAX);
  args.option("select", "convert only nodes whose node or mesh name matches this regex (RE2 syntax)", &cs.select);
  args.option("exclude", "never convert nodes whose node or mesh name matches this regex", &cs.exclude);
  args.option("group", "NAME=REGEX: one model for all selected nodes whose name matches (repeatable)", &group_help);
  args.option("jobs", "models trained at the same time", &cs.jobs, 1, kMaxConvertJobs);
  args.option("eval-rays", "held-out rays to measure each trained model for the report (0 = none)", &cs.eval_rays,
              0, kMaxEvalRays);
  args.flag("keep-meshes", "keep the converted nodes' triangles (needed by `lsnif render --reference`)",
            &cs.keep_meshes);
  args.flag("dry-run", "print the plan (models, instances, memory) without training or writing", &cs.dry_run);
  args.flag("force", "retrain every model, even up-to-date ones", &cs.force);
  args.option("plan", "write one training job per model into DIR (DIR/jobs.txt: one `lsnif train` command per line, "
              "for a Slurm job array, xargs -P or a Kubernetes Indexed Job; docs/cluster.md) instead of training",
              &cs.plan_dir);
  args.option("assemble", "adopt the models the jobs of the plan in DIR wrote (by content hash) and write the scene",
              &cs.assemble_dir);
  args.flag("retrain-missing", "--assemble: train here the models whose jobs have not written them", &cs.retrain_missing);
  args.option("job-command", "--plan: the program the jobs run (default: this program's path)", &cs.job_command);
  opts.add_to(args, "output scene (.gltf); the .lsnif models are written beside it");
  if (!take_groups(argc, argv, cs.groups)) return 2;
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;
  if (opts.output.empty()) {
    std::fprintf(stderr, "lsnif convert: missing -o OUT.gltf\n");
    return 2;
  }
  if (!opts.to_settings(cs.train)) return 2;
  start_threads(opts.threads);
  cs.output = opts.output;
  cs.memory_margin = double(margin);
  if (!device.empty() && !blas_on_device) {
    std::fprintf(stderr, "lsnif convert: --device is the device of --blas-size device; add that option\n");
    return 2;
  }
  convert::DeviceBlasSizer blas_device;
  if (blas_on_device) {
    if (Status s = convert::check_settings(cs); !s) {  // before opening a device for nothing
      std::fprintf(stderr, "lsnif convert: %s\n", s.message().c_str());
      return 2;
    }
    if (Status s = blas_device.open(device); !s) {
      std::fprintf(stderr, "lsnif convert: %s\n", s.message().c_str());
      return 1;
    }
    cs.blas = blas_device.sizer();
  }
  cs.progress = !opts.quiet;
  cs.import_options = opts.import_options;
  convert::ConvertResult result;
  return convert::run_convert(cs, result, stdout, stderr);
}

}  // namespace lsnif::cli
