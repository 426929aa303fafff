// Converting on a cluster (docs/cluster.md), end to end on a real scene (assimp's 2CylinderEngine,
// five of its meshes over --min-triangles 5000): `lsnif convert --plan` writes the jobs, a scheduler
// runs them, `lsnif convert --assemble` adopts their models. The truth is a local `lsnif convert` of
// the same scene with the same options: the assembled folder must hold the same models (same
// content hashes, byte-identical files), the same scene, and render the same image. Schedulers: plain
// `xargs -P` in shuffled order, a rerun after a job was killed mid-way, and a real single-node Slurm
// (Debian's slurm-wlm and munge, started and stopped by tests/cluster/slurm_local.sh) running the
// plan as a job array.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "lsnif/testing/test_support.h"

namespace {

namespace fs = std::filesystem;
using lsnif::test::ProcessResult;

const std::string kEngine = std::string(LSNIF_DATA_DIR) + "/gltf/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
const std::vector<std::string> kOptions = {"--convert-when", "triangles", "--min-triangles", "5000", "--tiny",
                                           "--eval-rays", "1000", "--quiet"};
constexpr size_t kJobs = 5;  // the engine's meshes of at least 5000 triangles

ProcessResult run(std::vector<std::string> argv, double timeout_s = 300.0) {
  return lsnif::test::run_process(argv, timeout_s, 0, {"MESA_SHADER_CACHE_DISABLE=true"});
}

ProcessResult lsnif(std::vector<std::string> args) {
  args.insert(args.begin(), LSNIF_CLI);
  return run(args);
}

ProcessResult shell(const std::string& script, double timeout_s = 300.0) { return run({"/bin/sh", "-c", script}, timeout_s); }

// `lsnif convert ENGINE -o OUT` with the test's options and `extra`.
ProcessResult convert(const std::string& out, std::vector<std::string> extra = {}) {
  std::vector<std::string> args = {"convert", kEngine, "-o", out};
  args.insert(args.end(), kOptions.begin(), kOptions.end());
  args.insert(args.end(), extra.begin(), extra.end());
  return lsnif(args);
}

std::string sh_quoted(const std::string& p) { return "'" + p + "'"; }

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) out.push_back(line);
  return out;
}

// The files of a conversion's folder (scene, buffer, models, sidecars) and their bytes.
std::map<std::string, std::string> folder_files(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const fs::directory_entry& e : fs::directory_iterator(dir))
    if (e.is_regular_file() && e.path().filename().string()[0] != '.')
      files[e.path().filename().string()] = lsnif::test::read_text(e.path());
  return files;
}

// The local conversion and its picture, made once for every test.
class ClusterConvert : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!fs::exists(kEngine)) return;
    // A folder of the suite's own (ScopedTestDir names its folder after the running test).
    root_ = new fs::path(fs::temp_directory_path() / ("lsnif_cluster_reference_" + std::to_string(::getpid())));
    fs::remove_all(*root_);
    const ProcessResult r = convert((*root_ / "local/engine.gltf").string());
    ASSERT_EQ(r.exit_code, 0) << r.output;
    ASSERT_NE(r.output.find(lsnif::format("trained   %zu, up to date 0, failed 0", kJobs)), std::string::npos) << r.output;
    local_files_ = new std::map<std::string, std::string>(folder_files(*root_ / "local"));
    local_picture_ = new std::string(picture(*root_ / "local/engine.gltf"));
  }
  static void TearDownTestSuite() {
    if (root_) fs::remove_all(*root_);
    delete root_;
    delete local_files_;
    delete local_picture_;
  }
  void SetUp() override {
    if (!fs::exists(kEngine)) GTEST_SKIP() << kEngine << " missing: run scripts/setup.sh";
    ASSERT_TRUE(local_files_ && local_picture_) << "the local conversion failed";
  }

  // A PNG of the scene, small and one sample per pixel: the same models and scene give the same bytes.
  static std::string picture(const fs::path& scene) {
    const std::string png = scene.string() + ".png";
    const ProcessResult r = lsnif({"render", scene.string(), "-o", png, "--width", "64", "--height", "48", "--spp", "1"});
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return lsnif::test::read_text(png);
  }

  // Writes the plan into dir/plan and returns its job lines.
  std::vector<std::string> plan() {
    const ProcessResult r = convert(path("out/engine.gltf"), {"--plan", path("plan")});
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_FALSE(fs::exists(path("out/engine.gltf"))) << "--plan trains and writes nothing of the scene";
    return lines(lsnif::test::read_text(path("plan/jobs.txt")));
  }

  // Assembles into dir/out and expects it to equal the local conversion, picture included.
  void expect_assembled_like_local(bool render) {
    const ProcessResult r = convert(path("out/engine.gltf"), {"--assemble", path("plan")});
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find(lsnif::format("trained   0, adopted %zu, up to date 0, failed 0", kJobs)), std::string::npos)
        << r.output;
    const std::map<std::string, std::string> files = folder_files(dir_.path() / "out");
    ASSERT_EQ(files.size(), local_files_->size());
    for (const auto& [name, bytes] : *local_files_) {
      ASSERT_TRUE(files.count(name)) << name;
      EXPECT_TRUE(files.at(name) == bytes) << name << " differs from the local conversion's";
    }
    if (render) {
      EXPECT_TRUE(picture(dir_.path() / "out/engine.gltf") == *local_picture_) << "the pictures differ";
    }
  }

  std::string path(const std::string& relative) const { return (dir_.path() / relative).string(); }

  lsnif::test::ScopedTestDir dir_{"lsnif_cluster"};
  static fs::path* root_;
  static std::map<std::string, std::string>* local_files_;
  static std::string* local_picture_;
};

fs::path* ClusterConvert::root_ = nullptr;
std::map<std::string, std::string>* ClusterConvert::local_files_ = nullptr;
std::string* ClusterConvert::local_picture_ = nullptr;

// The plan is self-contained: a folder per job with the training mesh, its settings and its command,
// a manifest naming every job by content hash, one command per model in jobs.txt.
TEST_F(ClusterConvert, ThePlanHoldsOneSelfContainedJobPerModel) {
  const std::vector<std::string> jobs = plan();
  ASSERT_EQ(jobs.size(), kJobs);
  const nlohmann::json manifest = nlohmann::json::parse(lsnif::test::read_text(path("plan/manifest.json")));
  ASSERT_EQ(manifest["jobs"].size(), kJobs);
  for (size_t i = 0; i < kJobs; ++i) {
    const nlohmann::json& job = manifest["jobs"][i];
    const std::string hash = job["hash"];
    EXPECT_EQ(job["command"], jobs[i]);
    EXPECT_EQ(job["output"], "models/" + hash + ".lsnif");
    const fs::path folder = dir_.path() / "plan/jobs" / hash;
    EXPECT_TRUE(fs::exists(folder / (job["model"].get<std::string>() + ".lsmesh")));
    EXPECT_TRUE(fs::exists(folder / "settings.json"));
    EXPECT_EQ(nlohmann::json::parse(lsnif::test::read_text(folder / "job.json"))["command"], jobs[i]);
    // The local conversion's sidecar of this model carries the same content hash.
    const std::string sidecar = "engine." + job["model"].get<std::string>() + ".lsnif.json";
    ASSERT_TRUE(local_files_->count(sidecar)) << sidecar;
    EXPECT_EQ(nlohmann::json::parse(local_files_->at(sidecar))["hash"], hash);
  }
  // Nothing trained yet: assembling lists every model and writes nothing.
  const ProcessResult r = convert(path("out/engine.gltf"), {"--assemble", path("plan")});
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find(lsnif::format("%zu of the plan's models are missing", kJobs)), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("missing (its job has not finished)"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(path("out/engine.gltf")));
  // A plan made with other options has other hashes: its models are not adopted for these.
  const ProcessResult other = lsnif({"convert", kEngine, "-o", path("out/engine.gltf"), "--convert-when", "triangles",
                                     "--min-triangles", "5000", "--tiny", "--seed", "99", "--quiet", "--assemble",
                                     path("plan")});
  EXPECT_EQ(other.exit_code, 1) << other.output;
  EXPECT_NE(other.output.find("the plan in " + path("plan") + " has no job of this hash"), std::string::npos)
      << other.output;
}

// xargs -P 2 runs the jobs in a shuffled order, each listed twice (a job array run twice at once:
// the second run of a model waits for the first or finds its model current); the assembled scene is
// the local conversion's. Running the whole list again changes nothing: every job finds its model
// current and exits.
TEST_F(ClusterConvert, JobsRunByXargsInAnyOrderAssembleToTheLocalConversion) {
  std::vector<std::string> jobs = plan();
  ASSERT_EQ(jobs.size(), kJobs);
  jobs.insert(jobs.end(), jobs.begin(), jobs.end());
  std::shuffle(jobs.begin(), jobs.end(), std::mt19937(2026));
  {
    std::ofstream shuffled(path("plan/shuffled.txt"));
    for (const std::string& j : jobs) shuffled << j << "\n";
  }
  ProcessResult r = shell("cd " + sh_quoted(path("plan")) + " && xargs -P 2 -d '\\n' -n 1 sh -c < shuffled.txt");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  expect_assembled_like_local(true);

  const auto before = fs::last_write_time(dir_.path() / "plan/models" / (nlohmann::json::parse(
      lsnif::test::read_text(path("plan/manifest.json")))["jobs"][0]["hash"].get<std::string>() + ".lsnif"));
  r = shell("cd " + sh_quoted(path("plan")) + " && xargs -P 2 -d '\\n' -n 1 sh -c < jobs.txt");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(lines(r.output).size(), kJobs) << r.output;  // one line each: "current ... kept"
  for (const std::string& line : lines(r.output)) EXPECT_NE(line.find("already holds the model"), std::string::npos) << line;
  EXPECT_EQ(fs::last_write_time(dir_.path() / "plan/models" / (nlohmann::json::parse(
      lsnif::test::read_text(path("plan/manifest.json")))["jobs"][0]["hash"].get<std::string>() + ".lsnif")), before);
}

// A job killed mid-way (SIGKILL while it loads, trains or writes) and the temporary file a job
// killed while writing leaves: rerunning the list converges to the same result; the leftover is
// removed by the job of its model. A model missing at assembly is trained here with
// --retrain-missing, and the result is still the local conversion's.
TEST_F(ClusterConvert, KilledJobsRerunAndMissingModelsRetrainToTheSameResult) {
  const std::vector<std::string> jobs = plan();
  ASSERT_EQ(jobs.size(), kJobs);
  const nlohmann::json manifest = nlohmann::json::parse(lsnif::test::read_text(path("plan/manifest.json")));
  // Killed while it runs: made long by --steps (options after --config override it), since the
  // tiny model itself trains in less than the 0.4 s before the kill on a fast host; the reruns
  // below run the plan's own command.
  ProcessResult killed = shell("cd " + sh_quoted(path("plan")) + " && exec " + jobs[0] + " --steps 100000", 0.4);
  EXPECT_TRUE(killed.timed_out) << killed.output;
  const std::string second = manifest["jobs"][1]["hash"];
  const fs::path leftover = dir_.path() / "plan/models" / ("." + second + ".lsnif.tmp-0123456789ab");
  std::ofstream(leftover) << "half a model";
  // The rerun of every job but the last.
  for (size_t i = 0; i + 1 < kJobs; ++i) {
    const ProcessResult r = shell("cd " + sh_quoted(path("plan")) + " && " + jobs[i]);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    if (i == 1) {
      EXPECT_NE(r.output.find("removed models/" + leftover.filename().string()), std::string::npos) << r.output;
    }
  }
  EXPECT_FALSE(fs::exists(leftover));
  ProcessResult r = convert(path("out/engine.gltf"), {"--assemble", path("plan")});
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("1 of the plan's models are missing"), std::string::npos) << r.output;
  r = convert(path("out/engine.gltf"), {"--assemble", path("plan"), "--retrain-missing"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find(lsnif::format("trained   1, adopted %zu, up to date 0, failed 0", kJobs - 1)), std::string::npos)
      << r.output;
  const std::map<std::string, std::string> files = folder_files(dir_.path() / "out");
  for (const auto& [name, bytes] : *local_files_) {
    ASSERT_TRUE(files.count(name)) << name;
    EXPECT_TRUE(files.at(name) == bytes) << name << " differs from the local conversion's";
  }
}

// Options that contradict each other end with exit 2 before any work, naming both.
TEST_F(ClusterConvert, ContradictoryOptionsAreRefused) {
  const std::string p = path("p");
  for (const auto& [extra, message] :
       {std::pair<std::vector<std::string>, std::string>{{"--plan", p, "--dry-run"}, "--dry-run writes nothing"},
        {{"--plan", p, "--assemble", p}, "--plan writes the jobs, --assemble adopts"},
        {{"--assemble", p, "--force"}, "--force retrains every model here"},
        {{"--retrain-missing"}, "--retrain-missing goes with --assemble"},
        {{"--job-command", "lsnif"}, "--job-command goes with --plan"}}) {
    const ProcessResult r = convert(path("out/engine.gltf"), extra);
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find(message), std::string::npos) << r.output;
  }
  EXPECT_FALSE(fs::exists(p));
  const ProcessResult r = convert(path("out/engine.gltf"), {"--assemble", path("nowhere")});
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("is not a plan folder"), std::string::npos) << r.output;
}

// A control character in any value that lands in a command line of the plan is refused before any
// work: a newline in --job-command would make jobs.txt run a second command (and shift every later
// line off its job); the plan folder is not even created.
TEST_F(ClusterConvert, ControlCharactersNeverReachACommandLine) {
  const std::string p = path("p");
  for (const auto& [extra, what] : {std::pair<std::vector<std::string>, std::string>{
                                        {"--plan", p, "--job-command", "lsnif\ntouch " + path("PWN")}, "--job-command"},
                                    {{"--plan", p, "--job-command", "lsnif\tx"}, "--job-command"},
                                    {{"--plan", p, "--job-command", std::string("lsnif\x7f")}, "--job-command"},
                                    {{"--plan", p + "\nx"}, "--plan"}}) {
    const ProcessResult r = convert(path("out/engine.gltf"), extra);
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find(what + " holds a control character"), std::string::npos) << r.output;
  }
  EXPECT_FALSE(fs::exists(p));
  EXPECT_FALSE(fs::exists(p + "\nx"));
  EXPECT_FALSE(fs::exists(path("PWN")));
  // A program path with spaces and quotes is one quoted word: one job a line, run by sh as documented.
  const ProcessResult r = convert(path("out/engine.gltf"), {"--plan", p, "--job-command", "/no such/it's lsnif"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::vector<std::string> jobs = lines(lsnif::test::read_text(p + "/jobs.txt"));
  ASSERT_EQ(jobs.size(), kJobs);
  for (const std::string& job : jobs) EXPECT_EQ(job.rfind("'/no such/it'\\''s lsnif' train ", 0), 0u) << job;
}

// A new plan in the folder of an earlier one removes the earlier plan's jobs that it does not have,
// those its manifest listed, and nothing else: a folder named like a job that no plan wrote stays.
TEST_F(ClusterConvert, ANewPlanRemovesOnlyTheJobsAnEarlierPlanWrote) {
  const std::string p = path("plan");
  ProcessResult r = convert(path("out/engine.gltf"), {"--plan", p, "--seed", "99"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json earlier = nlohmann::json::parse(lsnif::test::read_text(p + "/manifest.json"));
  const fs::path mine = fs::path(p) / "jobs/0123456789abcdef";
  fs::create_directories(mine);
  std::ofstream(mine / "mine.txt") << "the user's\n";
  const std::vector<std::string> jobs = plan();
  ASSERT_EQ(jobs.size(), kJobs);
  for (const nlohmann::json& job : earlier["jobs"])
    EXPECT_FALSE(fs::exists(fs::path(p) / "jobs" / job["hash"].get<std::string>())) << job["hash"];
  EXPECT_EQ(lsnif::test::read_text(mine / "mine.txt"), "the user's\n");
}

// A planted model file is judged by its header before its body is read: a 3 GiB sparse file whose
// header declares its size is refused as more than a model of these settings can have, one whose
// header declares another size as truncated or trailing, and a FIFO with the reason; each within
// seconds and without reading the file (the run is capped at 1 GiB of address space).
TEST_F(ClusterConvert, APlantedModelIsRefusedByItsHeaderBeforeItIsRead) {
  plan();
  const nlohmann::json manifest = nlohmann::json::parse(lsnif::test::read_text(path("plan/manifest.json")));
  const std::string hash = manifest["jobs"][0]["hash"];
  const fs::path planted = dir_.path() / "plan/models" / (hash + ".lsnif");
  // A real model's header (the local conversion's first model), its declared size replaced.
  std::string header;
  for (const auto& [name, bytes] : *local_files_)
    if (name.size() > 6 && name.compare(name.size() - 6, 6, ".lsnif") == 0) header = bytes.substr(0, 256);
  ASSERT_EQ(header.size(), 256u);
  const auto plant = [&](uint64_t declared, uint64_t size) {
    std::string h = header;
    for (int i = 0; i < 8; ++i) h[size_t(16 + i)] = char((declared >> (8 * i)) & 0xff);
    fs::remove(planted);
    std::ofstream(planted, std::ios::binary) << h;
    fs::resize_file(planted, size);
  };
  const uint64_t big = uint64_t(3) << 30;
  const std::string cap = "ulimit -v 1048576; ";
  const auto assemble = [&]() {
    std::string cmd = cap + sh_quoted(LSNIF_CLI) + " convert " + sh_quoted(kEngine) + " -o " +
                      sh_quoted(path("out/engine.gltf"));
    for (const std::string& o : kOptions) cmd += " " + sh_quoted(o);
    return shell(cmd + " --assemble " + sh_quoted(path("plan")), 60.0);
  };
  for (const auto& [declared, size, message] :
       {std::tuple<uint64_t, uint64_t, std::string>{big, big, "more than a model of these settings can have"},
        {1000, big, "trailing data: the header says the file has 1000 bytes"},
        {big, 4096, "truncated: expected 3221225472 bytes"}}) {
    plant(declared, size);
    const ProcessResult r = assemble();
    EXPECT_FALSE(r.timed_out) << r.output;
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_NE(r.output.find(hash + ".lsnif: cannot read it: loading "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(message), std::string::npos) << r.output;
  }
  fs::remove(planted);
  ASSERT_EQ(::mkfifo(planted.c_str(), 0600), 0);
  const ProcessResult r = assemble();
  EXPECT_FALSE(r.timed_out) << r.output;
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("not a regular file"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(path("out/engine.gltf")));
}

// A real single-node Slurm on this machine runs the plan as a job array (sbatch --array --wait, the
// recipe of docs/cluster.md); the assembled scene is the local conversion's.
TEST_F(ClusterConvert, ASlurmJobArrayAssemblesToTheLocalConversion) {
  const std::string cluster = path("slurm");
  ProcessResult started = run({"/bin/bash", LSNIF_SLURM_SCRIPT, "start", cluster}, 120.0);
  struct Stop {
    std::string dir;
    ~Stop() { run({"/bin/bash", LSNIF_SLURM_SCRIPT, "stop", dir}, 60.0); }
  } stop{cluster};
  if (started.exit_code == 77) GTEST_SKIP() << "no Slurm here: " << started.output;
  ASSERT_EQ(started.exit_code, 0) << started.output;
  const std::vector<std::string> jobs = plan();
  ASSERT_EQ(jobs.size(), kJobs);
  const std::string array = "SLURM_CONF=" + sh_quoted(cluster + "/slurm.conf") + " sbatch --wait --quiet --array=1-" +
                            std::to_string(kJobs) + " --chdir=" + sh_quoted(path("plan")) + " --output=" +
                            sh_quoted(path("plan/slurm-%a.log")) + " --wrap 'sed -n \"${SLURM_ARRAY_TASK_ID}p\" jobs.txt | sh'";
  const ProcessResult r = shell(array);
  ASSERT_EQ(r.exit_code, 0) << r.output << "\n" << lsnif::test::read_text(path("plan/slurm-1.log"));
  for (size_t i = 1; i <= kJobs; ++i)
    EXPECT_NE(lsnif::test::read_text(path("plan/slurm-" + std::to_string(i) + ".log")).find("wrote     models/"),
              std::string::npos) << "task " << i;
  expect_assembled_like_local(true);
}

}  // namespace
