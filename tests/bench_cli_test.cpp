// `lsnif bench` as a user runs it: a quick run of the bunny scene in a temporary folder (tiny
// models of both quality presets, tiny images, both pipelines) writes results.md, whose rows are
// checked against independent measurements
// (the mesh file's triangle count, `lsnif bench-memory` on the same mesh and model for the memory
// columns) and for internal consistency, plus the side-by-side image and the scene files; a second
// run reuses the scene and the model; unknown scene names and missing data are clear errors.
// `lsnif bench-trace` with few rays: its JSON has the batched path's, lsnifCmdQuery's and the CPU
// GEMM's numbers, and the batched and query hits agree with the intersection shader's ray by ray.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "lsnif/testing/test_support.h"
#include "gltf_validator/gltf_validator.h"

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using lsnif::test::number;
using lsnif::test::read_text;
using lsnif::test::off_faces;
const std::string kBunny = std::string(LSNIF_DATA_DIR) + "/meshes/bunny00.off";

lsnif::test::CommandResult run_cli(const std::string& args) {
  return lsnif::test::run_command(std::string(LSNIF_CLI) + " " + args + " 2>&1");
}

bool has(const std::string& text, const std::string& what) { return text.find(what) != std::string::npos; }

// Width and height from a PNG's IHDR chunk; false when the file is not a PNG.
bool png_size(const fs::path& path, uint32_t& width, uint32_t& height) {
  const std::string b = read_text(path);
  if (b.size() < 24 || b.compare(0, 8, "\x89PNG\r\n\x1a\n") != 0 || b.compare(12, 4, "IHDR") != 0) return false;
  auto be32 = [&](size_t at) {
    return uint32_t(uint8_t(b[at])) << 24 | uint32_t(uint8_t(b[at + 1])) << 16 | uint32_t(uint8_t(b[at + 2])) << 8 |
           uint32_t(uint8_t(b[at + 3]));
  };
  width = be32(16);
  height = be32(20);
  return true;
}

TEST(BenchCli, QuickBunnyWritesTheTableAndImages) {
  if (!fs::exists(kBunny)) GTEST_SKIP() << kBunny << " missing: run scripts/setup.sh";
  lsnif::test::ScopedTestDir dir("lsnif_bench_cli_test");
  const std::string out = dir.path().string();
  // The paper's two presets (Table 1's H and L), both pipelines, traced: four rows.
  lsnif::test::CommandResult r =
      run_cli("bench bunny --quick --quality high,low --pipeline both --primary traced --out " + out);
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* want : {"scene     wrote", "model     training", "render (LSNIF)", "LDR-FLIP", "results.md"})
    EXPECT_TRUE(has(r.out, want)) << want << " missing in:\n" << r.out;

  const std::string md = read_text(dir.path() / "results.md");
  // Tris: every triangle of bunny00.off (all valid) on one instance.
  const uint64_t faces = off_faces(kBunny);
  ASSERT_GT(faces, 1000u);
  char tris[32];
  std::snprintf(tris, sizeof tris, "%.1fk", double(faces) / 1e3);
  std::map<std::string, std::string> reference_cell;  // per pipeline: the high row's T reference
  for (const char* preset : {"high", "low"}) {
    // The model of the preset: the low one has the paper's H = 10 (--quick keeps its tiny width).
    const fs::path model = dir.path() / "bunny" / ("bunny." + std::string(preset) + ".lsnif");
    ASSERT_TRUE(fs::exists(model)) << model;
    r = lsnif::test::run_command(std::string(LSNIF_CLI) + " info " + model.string() + " 2>&1");
    ASSERT_EQ(r.code, 0) << r.out;
    EXPECT_TRUE(has(r.out, std::string(preset) == "high" ? " H=18 " : " H=10 ")) << r.out;
    // The memory columns against `lsnif bench-memory` (plugin upload and the driver's size query
    // for the same mesh and model, a separate code path from the renderer's statistics).
    r = lsnif::test::run_command(std::string(LSNIF_CLI) + " bench-memory " + kBunny + " " + model.string() +
                                 " --subdivide-targets '' --json 2>/dev/null");
    ASSERT_EQ(r.code, 0) << r.out;
    const json mem = json::parse(r.out);
    // The wavefront rows name the broad phase their queries ran with: on lavapipe, which has ray
    // queries, the plugin's automatic choice is the ray-query one.
    for (const auto& [pipeline, label] : {std::pair{"inline", "inline"}, std::pair{"wavefront", "wavefront (ray-query)"}}) {
      const std::string what = std::string(preset) + " " + pipeline;
      const std::vector<std::string> row =
          lsnif::test::table_row(md, "| bunny | " + std::string(preset) + " | " + label + " |");
      ASSERT_EQ(row.size(), 12u) << what << "\n" << md;
      EXPECT_EQ(row[3], tris);
      EXPECT_EQ(row[4], "1 (1)");
      const double lsnif_mib = number(row[5]), blas_mib = number(row[6]), ratio = number(row[7]);
      const double t_lsnif = number(row[8]), t_ref = number(row[9]), t_ratio = number(row[10]), flip = number(row[11]);
      EXPECT_GT(ratio, 1.0);
      EXPECT_NEAR(ratio, blas_mib / lsnif_mib, 0.02 * ratio);
      EXPECT_GT(t_lsnif, 0.0);
      EXPECT_GT(t_ref, 0.0);
      EXPECT_NEAR(t_ratio, t_lsnif / t_ref, 0.05 * t_ratio + 0.01);
      // One reference render per pipeline, shared by both quality rows (it traces only meshes).
      if (std::string(preset) == "high")
        reference_cell[pipeline] = row[9];
      else
        EXPECT_EQ(row[9], reference_cell[pipeline]) << what << ": the reference render is shared";
      EXPECT_GT(flip, 0.0);
      EXPECT_LT(flip, 0.5);  // a render that lost the object entirely would be far off here
      EXPECT_NEAR(lsnif_mib, mem["lsnif"]["total_bytes"].get<double>() / 1048576.0, 0.0006) << what;
      EXPECT_NEAR(blas_mib, mem["triangle_blas"][0]["blas_bytes"].get<double>() / 1048576.0, 0.0006) << what;
      EXPECT_NEAR(ratio, mem["triangle_blas"][0]["ratio_blas"].get<double>(), 0.01) << what;

      // The side-by-side picture (reference | LSNIF | FLIP) at the quick image size.
      const std::string image = "bunny." + std::string(preset) + "." + pipeline + ".png";
      uint32_t w = 0, h = 0;
      ASSERT_TRUE(png_size(dir.path() / image, w, h)) << image;
      EXPECT_EQ(w, 3u * 64u);
      EXPECT_EQ(h, 48u);
      EXPECT_TRUE(has(md, "(" + image + ")")) << md;

      // The wavefront renders' stages add up to at most their wall time per sample (the other
      // clock), and to most of it (lavapipe runs the passes on the host's cores).
      if (std::string(pipeline) != "wavefront") continue;
      for (const auto& [mode, wall] : {std::pair{"LSNIF", t_lsnif}, std::pair{"reference", t_ref}}) {
        const std::vector<std::string> st =
            lsnif::test::table_row(md, "| bunny | " + std::string(preset) + " | " + mode + " |");
        ASSERT_EQ(st.size(), 12u) << what << " " << mode << " stages\n" << md;
        double sum = 0;
        for (size_t k = 3; k < 11; ++k) {
          EXPECT_GE(number(st[k]), 0.0) << st[k];
          sum += number(st[k]);
        }
        EXPECT_EQ(number(st[3]), 0.0) << "traced primary visibility: no raster pass";
        EXPECT_NEAR(number(st[11]), sum, 0.1) << "the total is the stages' sum";
        EXPECT_LE(sum, wall * 1.01 + 0.1) << what << " " << mode;
        EXPECT_GE(sum, 0.5 * wall) << what << " " << mode;
      }
    }
  }
  EXPECT_TRUE(fs::exists(dir.path() / "bunny" / "bunny.gltf"));
  EXPECT_TRUE(fs::exists(dir.path() / "bunny" / "bunny.bin"));
  EXPECT_TRUE(fs::exists(dir.path() / "bunny" / "forest.exr"));
  // The scene it wrote is valid glTF (the Khronos validator).
  r = lsnif::test::validate_gltf({(dir.path() / "bunny" / "bunny.gltf").string()});
  EXPECT_EQ(r.code, 0) << r.out;
  // The presets are different models, and render differently.
  for (const char* pipeline : {"inline", "wavefront"})
    EXPECT_TRUE(read_text(dir.path() / ("bunny.high." + std::string(pipeline) + ".png")) !=
                read_text(dir.path() / ("bunny.low." + std::string(pipeline) + ".png")))
        << pipeline << ": the high and low models rendered the same image";

  // Run again, one preset and pipeline: scene and model are reused, not rebuilt or retrained.
  const fs::path model = dir.path() / "bunny" / "bunny.high.lsnif";
  const auto model_time = fs::last_write_time(model);
  r = run_cli("bench bunny --quick --spp 1 --quality high --pipeline inline --out " + out);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(has(r.out, "scene     reusing")) << r.out;
  EXPECT_TRUE(has(r.out, "model     reusing")) << r.out;
  EXPECT_FALSE(has(r.out, "model     training")) << r.out;
  EXPECT_EQ(fs::last_write_time(model), model_time);
  const std::string again = read_text(dir.path() / "results.md");
  EXPECT_TRUE(has(again, "reused (same mesh and settings)"));
  EXPECT_EQ(lsnif::test::table_row(again, "| bunny | high | wavefront |").size(), 0u) << again;
  EXPECT_EQ(lsnif::test::table_row(again, "| bunny | low |").size(), 0u) << again;
  // Other training settings do not match the stored model: it is trained again.
  r = run_cli("bench bunny --quick --steps 5 --spp 1 --quality high --pipeline inline --out " + out);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(has(r.out, "model     training")) << r.out;
  // Presets and pipelines outside the lists are usage errors.
  r = run_cli("bench bunny --quick --quality medium --out " + out);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(has(r.out, "--quality takes a list of default, high and low, not 'medium'")) << r.out;
  r = run_cli("bench bunny --quick --pipeline sideways --out " + out);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(has(r.out, "--pipeline must be auto, inline, wavefront or both, not 'sideways'")) << r.out;

  // The default model and --pipeline auto: the bench's bunny keeps its mesh, so the LSNIF mode runs
  // the wavefront pipeline with rasterized primary visibility (lavapipe runs lsnifCmdQuery; at
  // 160 x 120 its 75k triangles are ~4 per pixel, under the CPU device's limit of 10, where
  // --quick's 64 x 48 would be 24.5: tests/gpu/render_choice_test.cpp), against the fastest
  // triangle path (inline, traced).
  r = run_cli("bench bunny --quick --spp 1 --width 160 --height 120 --quality default --out " + out);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(dir.path() / "bunny" / "bunny.lsnif"));
  const std::string chosen = read_text(dir.path() / "results.md");
  const std::vector<std::string> row =
      lsnif::test::table_row(chosen, "| bunny | default | wavefront (ray-query), raster; reference inline, traced |");
  ASSERT_EQ(row.size(), 12u) << chosen;
  EXPECT_NEAR(number(row[10]), number(row[8]) / number(row[9]), 0.05 * number(row[10]) + 0.01);
  const std::vector<std::string> stages = lsnif::test::table_row(chosen, "| bunny | default | LSNIF |");
  ASSERT_EQ(stages.size(), 12u) << chosen;
  EXPECT_GT(number(stages[3]), 0.0) << "rasterized primary visibility: a raster pass";
  EXPECT_EQ(lsnif::test::table_row(chosen, "| bunny | default | reference |").size(), 0u) << "inline: no stages";
  const json chosen_json = json::parse(read_text(dir.path() / "results.json"));
  ASSERT_EQ(chosen_json["rows"].size(), 1u);
  EXPECT_EQ(chosen_json["rows"][0]["primary"], "raster");
  EXPECT_EQ(chosen_json["rows"][0]["reference_pipeline"], "inline");
  EXPECT_TRUE(fs::exists(dir.path() / "bunny.auto.png"));
}

// The batched path (lsnifCmdIntersectModelRays, compute) and lsnifCmdQuery (the model as one LSNIF
// instance of a TLAS) against the intersection shader (lsnif.rint in a ray-tracing pipeline) on the
// same rays and model: separate implementations of the same per-ray computation, so they must agree
// (hit or miss, t, the walk's points) up to float rounding. A tiny model of the bunny, few rays, one repeat, a short GEMM: seconds.
TEST(BenchCli, TraceBatchedAndQueryPathsAgreeWithTheIntersectionShader) {
  if (!fs::exists(kBunny)) GTEST_SKIP() << kBunny << " missing: run scripts/setup.sh";
  lsnif::test::ScopedTestDir dir("lsnif_bench_trace_cli_test");
  const std::string model = dir.path("bunny.lsnif");
  // Not --tiny, deliberately: its voxels, table and MLP, but H=9, one grid level and 60 steps at the
  // full learning rate (no decay) give a model that hits a useful share of the rays.
  lsnif::test::CommandResult r = run_cli("train " + kBunny + " -o " + model +
                                         " --voxels 16 --points 9 --levels 1 --res-min 32 --res-max 64"
                                         " --table-log2 12 --width 32 --steps 60 --batch 1024 --lr-schedule constant"
                                         " --quiet");
  ASSERT_EQ(r.code, 0) << r.out;
  constexpr uint32_t kRays = 4096;
  r = lsnif::test::run_command(std::string(LSNIF_CLI) + " bench-trace " + kBunny + " " + model + " --rays " +
                               std::to_string(kRays) + " --repeat 1 --gemm-seconds 0.05 --json --device " +
                               lsnif::test::test_device() + " 2>/dev/null");
  ASSERT_EQ(r.code, 0) << r.out;
  const json j = json::parse(r.out);
  // The existing keys stay.
  for (const char* key : {"lsnif", "triangles", "network_evaluations", "network_evaluations_per_second",
                          "hit_agreement", "walk_points_mismatches"})
    EXPECT_TRUE(j.contains(key)) << key;
  for (const char* key : {"query_pipeline_create_seconds", "batched", "batched_hits", "batched_network_evaluations",
                          "batched_network_evaluations_per_second",
                          "batched_over_inline_network_evaluations_per_second", "batched_inline_hit_agreement", "batched_inline_both_hit",
                          "batched_inline_max_t_difference_over_diagonal", "batched_inline_points_mismatches",
                          "batched_walk_points_mismatches", "gemm", "batched_over_gemm_network_evaluations_per_second",
                          "batched_mlp_stage_evaluations_per_second"})
    ASSERT_TRUE(j.contains(key)) << key << " missing in " << r.out;
  const json& batched = j["batched"];
  for (const char* key : {"first_trace_seconds", "median_trace_seconds", "median_trace_device_seconds",
                          "rays_per_second", "trace_seconds", "calls_per_run", "first_run_stages",
                          "median_narrow_seconds", "median_mlp_seconds", "median_decode_seconds"})
    EXPECT_TRUE(batched.contains(key)) << key;
  EXPECT_EQ(batched["trace_seconds"].size(), 1u);
  EXPECT_EQ(batched["calls_per_run"].get<uint32_t>(), 1u);
  EXPECT_GT(batched["median_trace_seconds"].get<double>(), 0.0);
  if (j["device_timestamps"].get<bool>()) {  // lavapipe has them: stages within the device time
    const double stages = batched["median_narrow_seconds"].get<double>() + batched["median_mlp_seconds"].get<double>() +
                          batched["median_decode_seconds"].get<double>();
    EXPECT_GT(stages, 0.0);
    EXPECT_LE(stages, batched["median_trace_device_seconds"].get<double>() * 1.0001);
  }
  const json& gemm = j["gemm"];
  // Input H*L*F = 9*1*3 = 27, padded to 28 as the GPU model pads it; 2 hidden layers; 8 + 1 outputs.
  EXPECT_EQ(gemm["layer_widths"], json::parse("[28, 32, 32, 9]")) << gemm;
  EXPECT_GT(gemm["threads"].get<uint32_t>(), 0u);
  EXPECT_GE(gemm["seconds"].get<double>(), 0.05);
  EXPECT_GT(gemm["evaluations_per_second"].get<double>(), 0.0);

  // The same evaluations: every ray with boundary points, counted by the batched path and by the
  // host walk; the same hits as the intersection shader.
  const uint32_t evaluations = j["network_evaluations"].get<uint32_t>();
  EXPECT_GT(evaluations, kRays / 4);
  EXPECT_EQ(j["batched_network_evaluations"].get<uint32_t>(), evaluations);
  EXPECT_EQ(j["batched_walk_points_mismatches"].get<uint32_t>(), 0u);
  EXPECT_EQ(j["batched_inline_points_mismatches"].get<uint32_t>(), 0u);
  EXPECT_GE(j["batched_inline_hit_agreement"].get<double>(), 0.999);
  EXPECT_GT(j["lsnif_hits"].get<uint32_t>(), kRays / 10);
  EXPECT_NEAR(double(j["batched_hits"].get<uint32_t>()), double(j["lsnif_hits"].get<uint32_t>()), kRays * 0.001);
  EXPECT_GT(j["batched_inline_both_hit"].get<uint32_t>(), kRays / 10);
  EXPECT_LT(j["batched_inline_max_t_difference_over_diagonal"].get<double>(), 1e-4);
  EXPECT_NEAR(j["batched_over_inline_network_evaluations_per_second"].get<double>(),
              j["batched_network_evaluations_per_second"].get<double>() /
                  j["network_evaluations_per_second"].get<double>(),
              1e-3 * j["batched_over_inline_network_evaluations_per_second"].get<double>());

  // lsnifCmdQuery: timed as the batched path, one candidate per ray crossing the box (none
  // dropped or left unevaluated), the same hits as the intersection shader.
  for (const char* key : {"query", "query_hits", "query_incomplete_rays", "query_candidates", "query_dropped",
                          "query_unevaluated", "query_network_evaluations_per_second",
                          "query_over_inline_network_evaluations_per_second", "query_inline_hit_agreement",
                          "query_inline_both_hit", "query_inline_max_t_difference_over_diagonal"})
    ASSERT_TRUE(j.contains(key)) << key << " missing in " << r.out;
  EXPECT_EQ(j["query_broad_phase"], "ray-query") << "the automatic choice on lavapipe";
  EXPECT_EQ(j["mlp_kernel"], "portable") << "the default";
  const json& query = j["query"];
  EXPECT_EQ(query["trace_seconds"].size(), 1u);
  EXPECT_GT(query["median_trace_seconds"].get<double>(), 0.0);
  if (j["device_timestamps"].get<bool>()) {
    EXPECT_GT(query["median_trace_device_seconds"].get<double>(), 0.0);
  }
  EXPECT_NEAR(double(j["query_candidates"].get<uint32_t>()), double(j["intersection_shader_rays"].get<uint32_t>()),
              kRays * 0.001);
  EXPECT_EQ(j["query_dropped"].get<uint32_t>(), 0u);
  EXPECT_EQ(j["query_unevaluated"].get<uint32_t>(), 0u);
  EXPECT_EQ(j["query_incomplete_rays"].get<uint32_t>(), 0u);
  EXPECT_GE(j["query_inline_hit_agreement"].get<double>(), 0.999);
  EXPECT_NEAR(double(j["query_hits"].get<uint32_t>()), double(j["lsnif_hits"].get<uint32_t>()), kRays * 0.001);
  EXPECT_GT(j["query_inline_both_hit"].get<uint32_t>(), kRays / 10);
  EXPECT_LT(j["query_inline_max_t_difference_over_diagonal"].get<double>(), 1e-4);
  EXPECT_NEAR(j["query_over_inline_network_evaluations_per_second"].get<double>(),
              j["query_network_evaluations_per_second"].get<double>() /
                  j["network_evaluations_per_second"].get<double>(),
              1e-3 * j["query_over_inline_network_evaluations_per_second"].get<double>());

  // The unverified cooperative-matrix MLP kernel: an error naming what lavapipe lacks, never a
  // silent run of the portable kernel; an unknown kernel name is a usage error.
  const std::string again = std::string(LSNIF_CLI) + " bench-trace " + kBunny + " " + model +
                            " --rays 64 --repeat 1 --gemm-seconds 0.05 --device " + lsnif::test::test_device();
  r = lsnif::test::run_command(again + " --mlp-kernel cooperative-matrix 2>&1");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("LSNIF_QUERY_PIPELINE_CREATE_COOPERATIVE_MATRIX_MLP_BIT_NV"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("VK_NV_cooperative_matrix"), std::string::npos) << r.out;
  r = lsnif::test::run_command(again + " --mlp-kernel tensor 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--mlp-kernel 'tensor'"), std::string::npos) << r.out;
}

// The foliage scene: alpha-tested cards textured with sprites from a Debian package. The glTF it
// writes passes the Khronos validator with its textures beside it (copies of the data files, byte
// for byte) and alphaMode MASK at 0.5 on both materials; its row measures the reference on the
// ray-tracing pipeline (the any-hit shaders' alpha test); a missing texture is named.
TEST(BenchCli, QuickFoliageIsAlphaTestedCards) {
  const fs::path textures = fs::path(LSNIF_DATA_DIR) / "textures";
  if (!fs::exists(textures / "default_fern_3.png")) GTEST_SKIP() << textures << " missing: run scripts/setup.sh";
  lsnif::test::ScopedTestDir dir("lsnif_bench_cli_test");
  const std::string out = dir.path().string();
  lsnif::test::CommandResult r = run_cli("bench foliage --quick --quality default --spp 1 --out " + out);
  ASSERT_EQ(r.code, 0) << r.out;
  const fs::path scene = dir.path() / "foliage" / "foliage.gltf";
  r = lsnif::test::validate_gltf({scene.string()});
  EXPECT_EQ(r.code, 0) << r.out;
  const json j = json::parse(read_text(scene));
  std::map<std::string, std::string> material_image;
  for (const json& m : j.at("materials")) {
    if (m.value("name", "") == "ground") continue;
    EXPECT_EQ(m.value("alphaMode", ""), "MASK") << m.dump();
    EXPECT_DOUBLE_EQ(m.value("alphaCutoff", 0.5), 0.5) << m.dump();  // glTF's default when absent
    const int texture = m.at("pbrMetallicRoughness").at("baseColorTexture").at("index").get<int>();
    const int image = j.at("textures").at(size_t(texture)).at("source").get<int>();
    material_image[m.at("name").get<std::string>()] = j.at("images").at(size_t(image)).at("uri").get<std::string>();
  }
  EXPECT_EQ(material_image, (std::map<std::string, std::string>{{"bush", "default_aspen_leaves.png"},
                                                                {"fern", "default_fern_3.png"}}));
  for (const auto& [material, uri] : material_image)
    EXPECT_EQ(read_text(dir.path() / "foliage" / uri), read_text(textures / uri)) << uri;
  const std::string results = read_text(dir.path() / "results.md");
  EXPECT_TRUE(has(results, "| foliage | default |")) << results;
  EXPECT_TRUE(has(results, "reference inline, traced")) << results;

  // A data folder without the sprites: the missing file named.
  const fs::path data = dir.path() / "data";
  fs::create_directories(data / "hdr");
  fs::copy_file(fs::path(LSNIF_DATA_DIR) / "hdr" / "courtyard.exr", data / "hdr" / "courtyard.exr");
  r = run_cli("bench foliage --quick --data " + data.string() + " --out " + (dir.path() / "out2").string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(has(r.out, "data/textures/default_aspen_leaves.png (needed by scene 'foliage') not found")) << r.out;
  EXPECT_FALSE(fs::exists(dir.path() / "out2"));
}

TEST(BenchCli, UnknownSceneAndMissingData) {
  lsnif::test::ScopedTestDir dir("lsnif_bench_cli_test");
  const std::string out = (dir.path() / "out").string();
  lsnif::test::CommandResult r = run_cli("bench bunny teapots --quick --out " + out);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(has(r.out, "unknown scene 'teapots'")) << r.out;
  EXPECT_TRUE(has(r.out, "bunny, dragons, heavy, strands, foliage")) << r.out;
  EXPECT_FALSE(fs::exists(out));

  // No data folder: named, with how to get it; a data folder without the scene's files: the file named.
  const fs::path nodata = dir.path() / "nodata";
  r = run_cli("bench dragons --quick --data " + nodata.string() + " --out " + out);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(has(r.out, "the data folder " + nodata.string() + " does not exist")) << r.out;
  EXPECT_TRUE(has(r.out, "run scripts/setup.sh")) << r.out;
  EXPECT_TRUE(has(r.out, "--data")) << r.out;
  EXPECT_FALSE(fs::exists(out));
  fs::create_directories(nodata);
  r = run_cli("bench dragons --quick --data " + nodata.string() + " --out " + out);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(has(r.out, "nodata/meshes/ChineseDragon-10kv.off")) << r.out;
  EXPECT_TRUE(has(r.out, "run scripts/setup.sh")) << r.out;
  EXPECT_FALSE(fs::exists(out));

  r = run_cli("bench --quick --width many");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(has(r.out, "--width")) << r.out;
}

// The GPU check's programs: `lsnif bench --no-render` prepares models; `lsnif-gpu bench` (no training in
// it) renders with them only through --models, after checking each key names the scene's mesh;
// `lsnif-gpu` links none of OpenImageIO, Embree and GLFW; `lsnif-gpu check` refuses a wrong folder
// and numbers out of range.
TEST(BenchCli, PreparedModelsAndTheGpuProgram) {
  if (!fs::exists(kBunny)) GTEST_SKIP() << kBunny << " missing: run scripts/setup.sh";
  lsnif::test::ScopedTestDir dir("lsnif_bench_cli_test");
  const fs::path models = dir.path() / "models", out = dir.path() / "out";
  lsnif::test::CommandResult r = run_cli("bench bunny --quick --quality high,low --no-render --out " + models.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(has(r.out, "--no-render: nothing rendered")) << r.out;
  EXPECT_TRUE(fs::is_regular_file(models / "bunny" / "bunny.high.lsnif"));
  EXPECT_TRUE(fs::is_regular_file(models / "bunny" / "bunny.high.lsnif.key"));
  EXPECT_FALSE(fs::exists(models / "results.md"));
  EXPECT_FALSE(fs::exists(models / "bunny.inline.png"));

  const std::string gpu = std::string(LSNIF_GPU_CLI) + " bench bunny --quick --quality high --pipeline wavefront --out " +
                          out.string();
  r = lsnif::test::run_command(gpu + " 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(has(r.out, "--models DIR is required")) << r.out;
  // The portable image reader reads no EXR: the data folder's environment must be .hdr (as the GPU
  // check folder carries it), else a clear error.
  r = lsnif::test::run_command(gpu + " --models " + models.string() + " 2>&1");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(has(r.out, "this build reads no EXR")) << r.out;
  const fs::path data = dir.path() / "data";
  fs::create_directories(data / "meshes");
  fs::create_directories(data / "hdr");
  fs::copy_file(kBunny, data / "meshes" / "bunny00.off");
  r = lsnif::test::run_command("oiiotool " + std::string(LSNIF_DATA_DIR) + "/hdr/forest.exr --resize 64x32 -o " +
                               (data / "hdr" / "forest.hdr").string() + " 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  r = lsnif::test::run_command(gpu + " --models " + models.string() + " --data " + data.string() + " 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(read_text(out / "bunny" / "bunny.high.lsnif"), read_text(models / "bunny" / "bunny.high.lsnif"));
  const json results = json::parse(read_text(out / "results.json"));
  ASSERT_EQ(results["rows"].size(), 1u) << results.dump(1);
  const json& row = results["rows"][0];
  EXPECT_EQ(row["scene"], "bunny");
  EXPECT_EQ(row["pipeline"], "wavefront");
  EXPECT_GT(row["ms_per_sample_lsnif"].get<double>(), 0.0);
  EXPECT_GT(row["flip_mean"].get<double>(), 0.0);
  EXPECT_LT(row["flip_mean"].get<double>(), 1.0);
  EXPECT_TRUE(fs::is_regular_file(out / row["image"].get<std::string>()));
  EXPECT_TRUE(has(read_text(out / "results.md"), "models prepared in " + models.string()));

  // A preset that was not prepared, a model of another preset copied over the row's (alone, or with
  // its key), a key of another mesh: named, nothing rendered.
  const fs::path bunny = models / "bunny";
  fs::rename(bunny / "bunny.low.lsnif", dir.path() / "bunny.low.lsnif");
  fs::rename(bunny / "bunny.low.lsnif.key", dir.path() / "bunny.low.lsnif.key");
  r = lsnif::test::run_command(gpu + " --models " + models.string() + " --data " + data.string() + " --quality low 2>&1");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(has(r.out, "bunny.low.lsnif (or its .key) not found")) << r.out;
  const auto refused = [&](const std::string& words) {
    const lsnif::test::CommandResult run =
        lsnif::test::run_command(gpu + " --models " + models.string() + " --data " + data.string() + " 2>&1");
    EXPECT_EQ(run.code, 1) << run.out;
    EXPECT_TRUE(has(run.out, "bunny.high.lsnif is not the high-quality model of bunny: " + words)) << run.out;
    EXPECT_FALSE(fs::exists(out / "bunny.high.wavefront.png.tmp"));
  };
  const std::string high = read_text(bunny / "bunny.high.lsnif"), high_key = read_text(bunny / "bunny.high.lsnif.key");
  fs::copy_file(dir.path() / "bunny.low.lsnif", bunny / "bunny.high.lsnif", fs::copy_options::overwrite_existing);
  refused("the model is not the one its key describes: it records points=10, the settings give points=");
  fs::copy_file(dir.path() / "bunny.low.lsnif.key", bunny / "bunny.high.lsnif.key", fs::copy_options::overwrite_existing);
  refused("its key names another quality than high");
  std::ofstream(bunny / "bunny.high.lsnif", std::ios::trunc | std::ios::binary) << high;
  std::ofstream(bunny / "bunny.high.lsnif.key", std::ios::trunc) << "mesh 00000000\nquality high\nsettings {}\n";
  refused("its key names another mesh than the scene's bunny");
  std::ofstream(bunny / "bunny.high.lsnif.key", std::ios::trunc) << high_key;
  r = run_cli("bench bunny --quick --no-render --models " + models.string() + " --out " + out.string());
  EXPECT_EQ(r.code, 2) << r.out;

  r = lsnif::test::run_command("ldd " + std::string(LSNIF_GPU_CLI));
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* lib : {"libOpenImageIO", "libembree", "libglfw", "libtbb"}) EXPECT_FALSE(has(r.out, lib)) << r.out;
  EXPECT_TRUE(has(r.out, "liblsnif_vk")) << r.out;

  r = lsnif::test::run_command(std::string(LSNIF_GPU_CLI) + " check " + out.string() + " --folder " +
                               (dir.path() / "none").string() + " 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(has(r.out, "--folder must name the GPU check folder")) << r.out;
  r = lsnif::test::run_command(std::string(LSNIF_GPU_CLI) + " check " + out.string() + " --width 5 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(has(r.out, "for --width: out of range [16, 7680]")) << r.out;
}

}  // namespace
