// output_folder_cli_test.cpp -- what the programs may do to the folders they write into: every
// path-writing command runs with an output folder that already holds files it did not write (a
// picture, a text, a hidden file, a folder of the user's), named unlike any of its outputs, and must
// leave each byte for byte, whether the run succeeds or fails. The GPU check, the one tool that
// removes its earlier results, removes only what an earlier check listed as written
// (src/lsnif/format/output_folder.h) and refuses a folder holding anything else.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "lsnif/format/output_folder.h"
#include "lsnif/testing/test_support.h"

namespace {

namespace fs = std::filesystem;
using lsnif::test::ProcessResult;

const std::string kElephant = std::string(LSNIF_DATA_DIR) + "/meshes/elephant.off";
const std::string kEngine = std::string(LSNIF_DATA_DIR) + "/gltf/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";

ProcessResult run_tool(const std::string& program, std::vector<std::string> args) {
  args.insert(args.begin(), program);
  return lsnif::test::run_process(args, 300.0, 0, {"MESA_SHADER_CACHE_DISABLE=true"});
}

// The user's files a folder is filled with, by path relative to it, and their bytes.
const std::map<std::string, std::string>& user_files() {
  static const std::map<std::string, std::string> files = {
      {"holiday.png", std::string("\x89PNG\r\n\x1a\n not really a picture", 27)},
      {"notes.txt", "the user's notes\n"},
      {".hidden", "a hidden file\n"},
      {"mine/deep.txt", "in a folder of the user's\n"}};
  return files;
}

void fill_with_user_files(const fs::path& dir) {
  for (const auto& [name, bytes] : user_files()) {
    fs::create_directories((dir / name).parent_path());
    std::ofstream(dir / name, std::ios::binary) << bytes;
  }
}

void expect_user_files_kept(const fs::path& dir, const std::string& what) {
  for (const auto& [name, bytes] : user_files()) {
    ASSERT_TRUE(fs::exists(dir / name)) << what << " removed " << (dir / name);
    EXPECT_EQ(lsnif::test::read_text(dir / name), bytes) << what << " changed " << (dir / name);
  }
}

// A GPU check folder whose bin/lsnif-gpu cannot run a step: every check run fails fast, after it
// has taken its output folder and before it writes its report.
fs::path failing_check_folder(const fs::path& root) {
  const fs::path folder = root / "check";
  fs::create_directories(folder / "bin");
  std::ofstream(folder / "bin/lsnif-gpu") << "#!/bin/sh\nexit 3\n";
  fs::permissions(folder / "bin/lsnif-gpu", fs::perms::owner_all);
  return folder;
}

// The GPU check removes its own earlier outputs (they are listed in OUT/.lsnif-outputs) and refuses
// an output folder holding anything else, naming it, before any work: a user's holiday.png survives.
TEST(OutputFolders, TheGpuCheckRemovesOnlyWhatAnEarlierCheckWrote) {
  const lsnif::test::ScopedTestDir dir("lsnif_output_folder");
  const fs::path folder = failing_check_folder(dir.path());
  const fs::path out = dir.path() / "out";
  const auto check = [&]() {
    return run_tool(LSNIF_GPU_CLI, {"check", out.string(), "--folder", folder.string(), "--quick"});
  };
  // A new folder: the check writes its (failed) report there and lists it.
  ProcessResult r = check();
  EXPECT_EQ(r.exit_code, 1) << r.output;
  ASSERT_TRUE(fs::exists(out / "report.json")) << r.output;
  EXPECT_EQ(lsnif::test::read_text(out / lsnif::kOutputRecord), "lsnif-gpu check\nreport.json\nwork\n");
  // Again: the earlier report is the check's own and is replaced.
  fs::create_directories(out / "work" / "left-over");
  r = check();
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_TRUE(fs::exists(out / "report.json")) << r.output;
  EXPECT_FALSE(fs::exists(out / "work" / "left-over"));
  // A file of the user's beside them: refused, nothing removed, the user's file named.
  fill_with_user_files(out);
  const std::string report = lsnif::test::read_text(out / "report.json");
  r = check();
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("holds files that lsnif-gpu check did not write"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("holiday.png"), std::string::npos) << r.output;
  expect_user_files_kept(out, "lsnif-gpu check");
  EXPECT_EQ(lsnif::test::read_text(out / "report.json"), report);
  // A folder of the user's without any record: refused the same way.
  const fs::path mine = dir.path() / "mine";
  fill_with_user_files(mine);
  r = run_tool(LSNIF_GPU_CLI, {"check", mine.string(), "--folder", folder.string(), "--quick"});
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("did not write"), std::string::npos) << r.output;
  expect_user_files_kept(mine, "lsnif-gpu check");
  EXPECT_FALSE(fs::exists(mine / "report.json"));
  EXPECT_FALSE(fs::exists(mine / lsnif::kOutputRecord));
  // Another tool's record, or a record that is not one, is not the check's.
  std::ofstream(mine / lsnif::kOutputRecord) << "lsnif bench\nholiday.png\n";
  r = run_tool(LSNIF_GPU_CLI, {"check", mine.string(), "--folder", folder.string(), "--quick"});
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("holds the outputs of lsnif bench, not of lsnif-gpu check"), std::string::npos) << r.output;
  std::ofstream(mine / lsnif::kOutputRecord) << "lsnif-gpu check\n../../etc/passwd\n";
  r = run_tool(LSNIF_GPU_CLI, {"check", mine.string(), "--folder", folder.string(), "--quick"});
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("is not a record of written files"), std::string::npos) << r.output;
  expect_user_files_kept(mine, "lsnif-gpu check");
  // An output folder that cannot be made says why.
  std::ofstream(dir.path() / "notes") << "a file";
  r = run_tool(LSNIF_GPU_CLI, {"check", (dir.path() / "notes/sub").string(), "--folder", folder.string()});
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("cannot create the output folder: Not a directory"), std::string::npos) << r.output;
}

// The campaign: each path-writing command writes into a folder holding the user's files and leaves
// them as they were; a new command that writes paths belongs in this list.
TEST(OutputFolders, EveryPathWritingCommandLeavesTheFilesItDidNotWrite) {
  for (const std::string& f : {kElephant, kEngine}) {
    if (!fs::exists(f)) GTEST_SKIP() << f << " missing: run scripts/setup.sh";
  }
  const lsnif::test::ScopedTestDir dir("lsnif_output_folder");
  const auto folder = [&](const std::string& name) {
    const fs::path p = dir.path() / name;
    fill_with_user_files(p);
    return p;
  };
  const std::string model = (folder("train") / "elephant.lsnif").string();
  const std::string scene = std::string(LSNIF_SCENE_EXAMPLE);
  struct Case {
    std::string name;
    std::vector<std::string> args;
    bool must_succeed;
  };
  const std::vector<Case> cases = {
      {"train", {"train", kElephant, "-o", model, "--tiny", "--quiet"}, true},
      {"demo",
       {"demo", "-o", (folder("demo") / "bunny.lsnif").string(), "--picture",
        (dir.path() / "demo/pictures/compare.png").string(), "--tiny", "--quiet", "--image-width", "16",
        "--image-height", "12", "--eval-rays", "1000"},
       true},
      {"render",
       {"render", scene, "--lsnif", "bunny=" + model, "--width", "16", "--height", "12", "--spp", "1", "-o",
        (folder("render") / "render.png").string()},
       true},
      {"render (refused)",
       {"render", scene, "--lsnif", "bunny=" + model, "--spp", "0", "-o", (folder("render-bad") / "r.png").string()},
       false},
      {"convert",
       {"convert", kEngine, "-o", (folder("convert") / "engine.gltf").string(), "--convert-when", "triangles",
        "--min-triangles", "20000", "--tiny", "--eval-rays", "100", "--quiet"},
       true},
      {"convert --plan",
       {"convert", kEngine, "-o", (dir.path() / "plan-out/engine.gltf").string(), "--plan", folder("plan").string(),
        "--convert-when", "triangles", "--min-triangles", "20000", "--tiny", "--quiet"},
       true},
      {"bench", {"bench", "bunny", "--quick", "--no-render", "--out", folder("bench").string()}, true},
      {"bench-size",
       {"bench-size", "bunny", "--quick", "--settings", "default", "--out", folder("bench-size").string()},
       false},
      // After render: it compares that render with itself.
      {"flip",
       {"flip", (dir.path() / "render/render.png").string(), (dir.path() / "render/render.png").string(), "--heatmap",
        (folder("flip") / "heat.png").string()},
       true},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const ProcessResult r = run_tool(LSNIF_CLI, c.args);
    EXPECT_FALSE(r.crashed()) << r.output;
    if (c.must_succeed) {
      EXPECT_EQ(r.exit_code, 0) << r.output;
    }
  }
  for (const char* name : {"train", "demo", "render", "render-bad", "convert", "plan", "bench", "bench-size", "flip"})
    expect_user_files_kept(dir.path() / name, name);
}

// Every command of `lsnif --help` is classified: it writes paths (and is in the campaign above),
// or writes none, or is named with where its writing is covered; a new command fails here until it
// is placed.
TEST(OutputFolders, EveryCommandIsInTheCampaignOrWritesNoPath) {
  const std::set<std::string> in_campaign = {"train", "demo", "render", "convert", "bench", "bench-size", "flip"};
  const std::set<std::string> writes_no_path = {"eval", "info", "devices", "bench-trace", "bench-memory"};
  // `view --screenshot` needs a display: tests/gpu/viewer_test.cpp runs it under Xvfb; it writes through the same
  // atomic_file.h as every other image.
  const std::set<std::string> covered_elsewhere = {"view"};
  const ProcessResult r = run_tool(LSNIF_CLI, {"--help"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::istringstream in(r.output);
  size_t commands = 0;
  bool listing = false;
  for (std::string line; std::getline(in, line);) {
    if (line == "commands:") {
      listing = true;
      continue;
    }
    if (!listing || line.size() < 3 || line[0] != ' ' || line[2] == ' ') continue;
    const std::string name = line.substr(2, line.find(' ', 2) - 2);
    ++commands;
    EXPECT_TRUE(in_campaign.count(name) + writes_no_path.count(name) + covered_elsewhere.count(name) == 1)
        << "lsnif " << name << ": add it to the campaign of EveryPathWritingCommandLeavesTheFilesItDidNotWrite";
  }
  EXPECT_EQ(commands, in_campaign.size() + writes_no_path.size() + covered_elsewhere.size()) << r.output;
}

}  // namespace
