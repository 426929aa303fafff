// convert_cluster.cpp -- the plan folder of a cluster conversion and the adoption of its models
// (convert_cluster.h).
#include "lsnif/apps/convert/convert_cluster.h"

#include <unistd.h>

#include <filesystem>
#include <set>

#include <nlohmann/json.hpp>

#include "lsnif/core/model.h"
#include "lsnif/format/atomic_file.h"
#include "lsnif/format/file_io.h"
#include "lsnif/format/model_format.h"
#include "lsnif/format/settings_table.h"
#include "lsnif/import/json_text.h"
#include "lsnif/import/training_mesh.h"
#include "lsnif/train/settings_io.h"

namespace lsnif::convert {
namespace fs = std::filesystem;

namespace {

constexpr const char* kPlanFormat = "lsnif-cluster-plan";
constexpr int kPlanVersion = 1;
constexpr uint64_t kMaxManifestBytes = uint64_t(64) << 20;

// `text` as one shell word: unchanged when it holds only characters no shell treats specially,
// else in single quotes. Every word has passed command_line_problem (check_settings for the options,
// write_job_plan for the program's own path; the rest are made of hashes and cleaned names).
std::string shell_word(const std::string& text) {
  const bool plain = !text.empty() && text.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz"
                                                             "0123456789_-./+,:=@%") == std::string::npos;
  if (plain) return text;
  std::string quoted = "'";
  for (char c : text) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

bool is_hash_name(const std::string& name) {
  return name.size() == 16 && name.find_first_not_of("0123456789abcdef") == std::string::npos;
}

struct Job {
  size_t model = 0;            // Plan::models index
  std::string folder;          // jobs/HASH
  std::string mesh, settings;  // relative to the plan folder
  std::string command;
};

Job make_job(const Plan& plan, const std::vector<ModelResult>& models, size_t i, const std::string& program) {
  Job job;
  job.model = i;
  const ModelResult& r = models[i];
  job.folder = std::string(kPlanJobFolder) + "/" + r.hash;
  // The mesh file carries the model's name: the training record names the mesh by its file name,
  // as a local conversion names it by the model.
  job.mesh = job.folder + "/" + plan.models[i].name + kTrainingMeshExtension;
  job.settings = job.folder + "/settings.json";
  job.command = shell_word(program) + " train " + shell_word(job.mesh) + " --config " + shell_word(job.settings) +
                " -o " + shell_word(planned_model_path(r.hash)) + " --csv " + shell_word(job.folder + "/loss.csv") +
                " --keep-current --quiet";
  return job;
}

// Writes one job's folder: the training mesh (read back to prove it is the planned mesh), the
// settings, job.json.
Status write_job(const ConvertSettings& settings, const Plan& plan, const ModelResult& r, const Job& job,
                 const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir / job.folder, ec);
  if (ec) return Status::error("%s: cannot create the folder: %s", (dir / job.folder).c_str(), ec.message().c_str());
  const std::string mesh_file = (dir / job.mesh).string();
  if (Status s = save_training_mesh(r.mesh, mesh_file); !s) return s;
  Mesh back;
  if (Status s = load_mesh(mesh_file, back); !s) return s;
  if (mesh_hash(back) != r.mesh_hash)
    return Status::error("%s does not read back as the planned mesh (another program changed it?)", mesh_file.c_str());
  const std::string config = settings_to_json(settings.train).dump(2) + "\n";
  if (Status s = write_file_atomic((dir / job.settings).string(), config); !s) return s;
  nlohmann::ordered_json j;
  j["hash"] = r.hash;
  j["model"] = plan.models[job.model].name;
  j["triangles"] = r.mesh.triangles.size();
  j["mesh"] = job.mesh;
  j["settings"] = job.settings;
  j["output"] = planned_model_path(r.hash);
  j["command"] = job.command;
  return write_file_atomic((dir / job.folder / "job.json").string(), j.dump(2) + "\n");
}

// Removes the job folders of an earlier plan that this one does not have: only jobs/HASH folders
// the earlier plan's manifest (`earlier`) lists; anything else there is someone else's and stays.
Status remove_other_jobs(const fs::path& dir, const std::set<std::string>& earlier, const std::set<std::string>& keep,
                         FILE* out) {
  std::error_code ec;
  const fs::path jobs = dir / kPlanJobFolder;
  if (!fs::is_directory(jobs, ec)) return Status::ok();
  std::vector<fs::path> stale;
  for (fs::directory_iterator it(jobs, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (is_hash_name(name) && earlier.count(name) && !keep.count(name) && it->is_directory(ec)) stale.push_back(it->path());
  }
  if (ec) return Status::error("%s: cannot list: %s", jobs.c_str(), ec.message().c_str());
  for (const fs::path& p : stale) {
    fs::remove_all(p, ec);
    if (ec) return Status::error("%s: cannot remove the job of an earlier plan: %s", p.c_str(), ec.message().c_str());
    std::fprintf(out, "cleanup   removed %s, a job of an earlier plan\n", p.c_str());
  }
  return Status::ok();
}

Status read_manifest(const std::string& dir, nlohmann::json& manifest) {
  const std::string path = (fs::path(dir) / kPlanManifest).string();
  std::string text;
  ReadFailure f;
  if (!read_file(path, text, kMaxManifestBytes, &f))
    return Status::error("%s is not a plan folder: cannot read %s (%s); write one with `lsnif convert IN -o OUT --plan "
                         "%s`", dir.c_str(), path.c_str(), f.reason.empty() ? "missing" : f.reason.c_str(), dir.c_str());
  if (Status s = json::parse(text, path, manifest); !s) return s;
  if (!manifest.is_object() || manifest.value("format", "") != kPlanFormat || !manifest.contains("version") ||
      !manifest["version"].is_number_integer() || !manifest.contains("jobs") || !manifest["jobs"].is_array())
    return Status::error("%s: not an LSNIF plan manifest (format \"%s\", version, jobs)", path.c_str(), kPlanFormat);
  if (manifest["version"].get<int64_t>() != kPlanVersion)
    return Status::error("%s: plan version %lld (this build reads version %d)", path.c_str(),
                         (long long)manifest["version"].get<int64_t>(), kPlanVersion);
  return Status::ok();
}

// The job hashes a read manifest lists (a job's folder is jobs/HASH).
std::set<std::string> manifest_hashes(const nlohmann::json& manifest) {
  std::set<std::string> hashes;
  for (const nlohmann::json& job : manifest["jobs"])
    if (job.is_object() && job.contains("hash") && job["hash"].is_string()) hashes.insert(job["hash"].get<std::string>());
  return hashes;
}

// The job folders an earlier plan in `dir` wrote, as its manifest lists them (none without a
// readable manifest of this version).
std::set<std::string> planned_job_folders(const fs::path& dir) {
  nlohmann::json manifest;
  return read_manifest(dir.string(), manifest) ? manifest_hashes(manifest) : std::set<std::string>();
}

// A job's model as read: its file's bytes (what is copied) and the model they hold.
struct JobModel {
  std::vector<uint8_t> bytes;
  Model model;
};

// The most bytes a model of these settings can have, whatever its mesh: every material slot, the
// surface channels, each indexed level as large as an index may be (a table of the largest size
// plus a displacement per entry) and the longest training record.
uint64_t planned_model_budget(const TrainSettings& settings) {
  Config c = settings.config;
  c.material_count = LSNIF_MAX_MATERIALS;
  c.surface_channels = 1;
  uint64_t displacements = 0;
  for (uint32_t l = 0; l < c.grid_levels; ++l)
    if (settings.indexed[l]) {
      c.table_log2[l] = max_u32(SettingId::TableLog2);
      displacements += 2 * (uint64_t(1) << c.table_log2[l]);
    }
  // A header of the newest version and its section padding are within the last term.
  return model_file_sizes(c, kMaxTrainingRecordBytes).file + displacements + 4096;
}

// Reads and checks the job's model of r, once: returns why it cannot be adopted (empty: `out`
// holds it). Its header is checked before its body is read, against the file's size and the most a
// model of these settings can have (a planted file is refused before it costs memory).
std::string check_job_model(const ConvertSettings& settings, const std::string& from, const ModelResult& r,
                            JobModel& out) {
  ReadFailure f;
  if (Status s = read_model_file(from, out.bytes, planned_model_budget(settings.train), &f); !s)
    return f.problem == ReadProblem::Missing ? "missing (its job has not finished)" : "cannot read it: " + s.message();
  if (Status s = load_model_from_memory(out.bytes.data(), out.bytes.size(), out.model);
      !s)
    return "not loadable: " + s.message();
  if (std::string why = training_record_difference(out.model.training, settings.train, r.mesh_hash); !why.empty())
    return "not the model of this mesh and these settings: " + why;
  return "";
}

// Adopts a checked model: its bytes written into the output folder, then recorded. Returns why not
// (empty: adopted).
std::string adopt(const ConvertSettings& settings, const PlannedModel& m, const JobModel& job, const std::string& to,
                  ModelResult& r) {
  if (Status s = write_file_atomic(to, job.bytes.data(), job.bytes.size()); !s) return "cannot copy it: " + s.message();
  if (Status s = record_model(settings, m, job.model, to, r); !s) return s.message();
  r.state = ModelState::Adopted;
  return "";
}

}  // namespace

std::string planned_model_path(const std::string& hash) { return std::string(kPlanModelFolder) + "/" + hash + ".lsnif"; }

std::string command_line_problem(const std::string& what, const std::string& text) {
  for (size_t i = 0; i < text.size(); ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c < 0x20 || c == 0x7f)
      return format("%s holds a control character (0x%02x at byte %zu): it would land in a command line of the plan, "
                    "where a newline starts another command and shifts every later job of jobs.txt",
                    what.c_str(), c, i);
  }
  return "";
}

std::string job_program(const std::string& job_command) {
  if (!job_command.empty()) return job_command;
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  return ec || self.empty() ? std::string("lsnif") : self.string();
}

Status write_job_plan(const ConvertSettings& settings, const Plan& plan, const std::vector<ModelResult>& models,
                      FILE* out) {
  const fs::path dir = settings.plan_dir;
  std::error_code ec;
  fs::create_directories(dir / kPlanModelFolder, ec);
  if (ec) return Status::error("%s: cannot create the plan folder: %s", dir.c_str(), ec.message().c_str());
  const std::set<std::string> earlier = planned_job_folders(dir);  // read before this plan's manifest replaces it
  const std::string program = job_program(settings.job_command);
  if (std::string why = command_line_problem("the program the jobs run (" + printable(program) + ")", program);
      !why.empty())
    return Status::error("%s; give another with --job-command", why.c_str());
  std::vector<Job> jobs;
  std::set<std::string> hashes;
  for (size_t i = 0; i < models.size(); ++i) {
    if (models[i].state == ModelState::Failed || !hashes.insert(models[i].hash).second) continue;
    jobs.push_back(make_job(plan, models, i, program));
    if (Status s = write_job(settings, plan, models[i], jobs.back(), dir); !s) return s;
  }
  if (Status s = remove_other_jobs(dir, earlier, hashes, out); !s) return s;
  std::string list;
  nlohmann::ordered_json manifest;
  manifest["format"] = kPlanFormat;
  manifest["version"] = kPlanVersion;
  manifest["input"] = fs::absolute(settings.input, ec).lexically_normal().string();
  manifest["output"] = fs::absolute(settings.output, ec).lexically_normal().string();
  manifest["settings"] = settings_to_json(settings.train);
  manifest["program"] = program;
  manifest["jobs"] = nlohmann::ordered_json::array();
  for (const Job& job : jobs) {
    const ModelResult& r = models[job.model];
    list += job.command + "\n";
    manifest["jobs"].push_back({{"hash", r.hash},
                                {"model", plan.models[job.model].name},
                                {"triangles", r.mesh.triangles.size()},
                                {"folder", job.folder},
                                {"output", planned_model_path(r.hash)},
                                {"command", job.command}});
    std::fprintf(out, "job       model '%s' (%zu triangles): %s/ -> %s\n", plan.models[job.model].name.c_str(),
                 r.mesh.triangles.size(), job.folder.c_str(), planned_model_path(r.hash).c_str());
  }
  if (Status s = write_file_atomic((dir / kPlanJobList).string(), list); !s) return s;
  if (Status s = write_file_atomic((dir / kPlanManifest).string(), manifest.dump(2) + "\n"); !s) return s;
  std::fprintf(out,
               "plan      %s: %zu jobs, one per line of %s (each a shell command, run from the plan folder, in any "
               "order, anywhere it is shared); they write %s/HASH.lsnif\n"
               "          e.g. cd %s && xargs -P 4 -d '\\n' -n 1 sh -c < %s   (Slurm, GNU parallel, Kubernetes: "
               "docs/cluster.md)\n"
               "          then: lsnif convert %s -o %s --assemble %s (with the same options)\n",
               dir.c_str(), jobs.size(), kPlanJobList, (dir / kPlanModelFolder).c_str(), shell_word(dir).c_str(),
               kPlanJobList, shell_word(settings.input).c_str(), shell_word(settings.output).c_str(),
               shell_word(dir).c_str());
  return Status::ok();
}

Status adopt_planned_models(const ConvertSettings& settings, const Plan& plan, const std::string& out_dir,
                            std::vector<ModelResult>& models, std::vector<std::string>& missing) {
  missing.clear();
  nlohmann::json manifest;
  if (Status s = read_manifest(settings.assemble_dir, manifest); !s) return s;
  const std::set<std::string> planned = manifest_hashes(manifest);
  // Every model is checked before any is copied: a run that stops for a missing model writes nothing.
  std::vector<JobModel> checked(models.size());
  std::vector<size_t> ready;
  const auto list_missing = [&](size_t i, const std::string& from, const std::string& why) {
    std::string text = format("model '%s' (hash %s): %s: %s", plan.models[i].name.c_str(), models[i].hash.c_str(),
                              from.c_str(), why.c_str());
    if (!planned.count(models[i].hash))
      text += format("; the plan in %s has no job of this hash: it was made from another input or with other "
                     "options", settings.assemble_dir.c_str());
    missing.push_back(text);
  };
  for (size_t i = 0; i < models.size(); ++i) {
    if (models[i].state != ModelState::Planned) continue;
    const std::string from = (fs::path(settings.assemble_dir) / planned_model_path(models[i].hash)).string();
    if (std::string why = check_job_model(settings, from, models[i], checked[i]); !why.empty())
      list_missing(i, from, why);
    else
      ready.push_back(i);
  }
  if (!missing.empty() && !settings.retrain_missing) return Status::ok();
  for (size_t i : ready) {
    const PlannedModel& m = plan.models[i];
    if (std::string why = adopt(settings, m, checked[i], (fs::path(out_dir) / m.file).string(), models[i]); !why.empty())
      list_missing(i, (fs::path(settings.assemble_dir) / planned_model_path(models[i].hash)).string(), why);
    checked[i] = JobModel();  // adopted models are released as they go
  }
  return Status::ok();
}

}  // namespace lsnif::convert
