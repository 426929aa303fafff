// The memory rule of the converter (ConvertWhen::Memory): a mesh converts when the triangle BLAS
// it frees is at least --memory-margin x its model, checked against a brute force over every set
// of meshes; BLAS sizes per primitive, instanced meshes counted once, a mesh another node keeps
// frees nothing; groups, tags and --min-triangles under the rule; the memory table of a dry run;
// the margin's range; a BLAS size query in place of the estimate.
#include <cmath>
#include <limits>
#include <map>
#include <set>

#include "lsnif/testing/convert_test_support.h"

namespace lsnif::convert {
namespace {
using namespace test;

// The first `triangles` triangles of the elephant, one primitive (all its vertices).
scene::Mesh elephant_part(const std::string& name, size_t triangles) {
  scene::Mesh m = elephant_mesh(name, 0, 0, false);
  m.primitives[0].indices.resize(3 * triangles);
  return m;
}

// Meshes of 10, 300, 800, 1500 and 5558 triangles (the last one in two primitives, three
// instances), the quad, and "shared" (the whole elephant) on two nodes of which --exclude keeps
// one. Against a tiny model (0.04 MiB) their BLASes give ratios from 0.03 to 14.
struct SizesScene : TestScene {
  std::vector<std::string> mesh_names = {"e10", "e300", "e800", "e1500", "elephant", "floor", "shared"};
  SizesScene() : TestScene("lsnif_convert_memory") {
    int k = 0;
    for (size_t t : {10, 300, 800, 1500}) {
      const int m = add_mesh_or_fail(g, elephant_part("e" + std::to_string(t), t));
      scene::add_node(g, "n" + std::to_string(t), m, placed({float(k++), 0, 0}, 0, 1));
    }
    for (int i = 0; i < 3; ++i) scene::add_node(g, "herd" + std::to_string(i), elephant, placed({0, 0, float(i)}, 0, 1));
    scene::add_node(g, "ground", floor, glm::mat4(1.0f));
    const int shared = add_mesh_or_fail(g, elephant_mesh("shared", 0, 1, false));
    scene::add_node(g, "shared_a", shared, placed({5, 0, 0}, 0, 1));
    scene::add_node(g, "shared_b", shared, placed({6, 0, 0}, 0, 1));
    save_or_fail(g, path);
  }
  ConvertSettings settings(double margin) const {
    ConvertSettings s = tiny_settings(path, dir.path("out.gltf"));
    s.convert_when = ConvertWhen::Memory;
    s.memory_margin = margin;
    s.min_triangles = 1;
    s.exclude = "^shared_b$";
    return s;
  }
};

Plan plan_or_fail(const ConvertSettings& s) {
  Plan p;
  const Status st = make_plan(s, p);
  EXPECT_TRUE(st) << st.message();
  return p;
}

const PlannedNode& node(const Plan& p, const std::string& name) {
  for (const PlannedNode& n : p.nodes)
    if (n.name == name) return n;
  ADD_FAILURE() << "no node " << name;
  static const PlannedNode none;
  return none;
}

int mesh_index(const Plan& p, const std::string& name) {
  for (size_t m = 0; m < p.gltf.meshes.size(); ++m)
    if (p.gltf.meshes[m].name == name) return int(m);
  ADD_FAILURE() << "no mesh " << name;
  return -1;
}

// The meshes converted (a node of theirs is Convert).
std::set<int> converted_meshes(const Plan& p) {
  std::set<int> out;
  for (const PlannedNode& n : p.nodes)
    if (n.decision == Decision::Convert) out.insert(n.mesh);
  return out;
}

// The brute-force truth: of all sets of meshes converted (every candidate node of a converted
// mesh converted), the one with the least triangle BLAS bytes left plus margin x model bytes
// added; among equals the largest (the rule converts at equality). A mesh's BLAS is left while
// any node draws it as triangles.
std::set<int> best_meshes(const Plan& p, const ConvertSettings& s, const std::vector<int>& meshes,
                          const std::map<int, uint64_t>& model_bytes) {
  double best = std::numeric_limits<double>::infinity();
  std::set<int> best_set;
  for (uint32_t mask = 0; mask < (1u << meshes.size()); ++mask) {
    std::set<int> chosen;
    for (size_t k = 0; k < meshes.size(); ++k)
      if (mask & (1u << k)) chosen.insert(meshes[k]);
    std::set<int> drawn;
    for (const PlannedNode& n : p.nodes) {
      const bool candidate = n.decision != Decision::Excluded;
      if (!(candidate && chosen.count(n.mesh))) drawn.insert(n.mesh);
    }
    double cost = 0;
    for (int m : drawn) cost += double(p.mesh_blas[size_t(m)]);
    for (int m : chosen) cost += s.memory_margin * double(model_bytes.at(m));
    if (cost < best || (cost == best && chosen.size() > best_set.size())) {
      best = cost;
      best_set = chosen;
    }
  }
  return best_set;
}

TEST(ConvertMemory, TheRuleConvertsTheMeshesABruteForceFindsBest) {
  SizesScene s;
  const Plan base = plan_or_fail(s.settings(1.0));
  std::vector<int> meshes;
  std::map<int, uint64_t> model_bytes;
  for (const std::string& name : s.mesh_names) {
    const int m = mesh_index(base, name);
    meshes.push_back(m);
    PlannedModel one;
    one.mesh = m;
    model_bytes[m] = planned_model_bytes(s.settings(1.0).train, base, one);
  }
  // BLAS bytes: one per primitive, summed; the instanced elephant counted once.
  const int elephant = mesh_index(base, "elephant");
  EXPECT_EQ(base.mesh_blas[size_t(elephant)], estimated_blas_bytes(2779) + estimated_blas_bytes(2779));
  EXPECT_EQ(base.mesh_blas[size_t(mesh_index(base, "e300"))], estimated_blas_bytes(300));
  EXPECT_EQ(base.blas_source, estimated_blas_source());
  // Margins around every mesh's ratio (just below, at, just above) and the range's ends.
  std::vector<double> margins = {kMinMemoryMargin, kMaxMemoryMargin};
  for (int m : meshes) {
    const double ratio = double(base.mesh_blas[size_t(m)]) / double(model_bytes[m]);
    for (double f : {0.999, 1.0, 1.001})
      if (ratio * f >= kMinMemoryMargin && ratio * f <= kMaxMemoryMargin) margins.push_back(ratio * f);
  }
  std::set<std::set<int>> outcomes;
  for (double margin : margins) {
    const ConvertSettings settings = s.settings(margin);
    const Plan p = plan_or_fail(settings);
    const std::set<int> got = converted_meshes(p);
    EXPECT_EQ(got, best_meshes(p, settings, meshes, model_bytes)) << "margin " << margin;
    outcomes.insert(got);
    // The excluded node keeps the shared mesh: converting its other node would free nothing.
    EXPECT_EQ(node(p, "shared_a").decision, Decision::NoMemorySaved) << margin;
    // The scene's memory after is what the chosen conversions leave and add.
    const SceneMemory mem = scene_memory(p);
    uint64_t before = 0, after = 0, models = 0;
    for (int m : meshes) {
      before += p.mesh_blas[size_t(m)];
      if (m == mesh_index(p, "shared") || !got.count(m)) after += p.mesh_blas[size_t(m)];
      if (got.count(m)) models += model_bytes[m];
    }
    EXPECT_EQ(mem.blas_before, before);
    EXPECT_EQ(mem.blas_after, after);
    EXPECT_EQ(mem.models, models);
  }
  EXPECT_GE(outcomes.size(), 4u);  // the sweep crosses several meshes' ratios
}

TEST(ConvertMemory, TagsGroupsAndMinTrianglesUnderTheRule) {
  SizesScene s;
  set_extra(s.g, 0, "lsnif", true);  // n10: the smallest mesh, forced in
  save_or_fail(s.g, s.path);
  ConvertSettings settings = s.settings(kMaxMemoryMargin);
  Plan p = plan_or_fail(settings);
  EXPECT_EQ(converted_meshes(p), std::set<int>{mesh_index(p, "e10")});  // only the tag converts
  EXPECT_EQ(node(p, "n300").decision, Decision::NoMemorySaved);

  // --min-triangles stays a lower bound: margin 1 would convert e1500 (its BLAS is larger than a
  // tiny model), 2000 triangles keep it.
  settings = s.settings(1.0);
  Plan q = plan_or_fail(settings);
  ASSERT_EQ(node(q, "n1500").decision, Decision::Convert);
  settings.min_triangles = 2000;
  q = plan_or_fail(settings);
  EXPECT_EQ(node(q, "n1500").decision, Decision::BelowThreshold);

  // A group weighs the BLASes of its distinct member meshes (the herd: the elephant's once)
  // against its one model.
  settings = s.settings(1.0);
  settings.groups = {{"herd", "^herd"}};
  p = plan_or_fail(settings);
  const PlannedNode& h = node(p, "herd0");
  ASSERT_GE(h.model, 0);
  const PlannedModel& herd = p.models[size_t(h.model)];
  EXPECT_EQ(herd.group, "herd");
  EXPECT_EQ(freed_blas_bytes(p, herd.nodes), p.mesh_blas[size_t(mesh_index(p, "elephant"))]);
  const double ratio = double(freed_blas_bytes(p, herd.nodes)) / double(herd.model_bytes);
  settings.memory_margin = ratio * 1.01;
  p = plan_or_fail(settings);
  EXPECT_EQ(node(p, "herd0").decision, Decision::NoMemorySaved);
  EXPECT_EQ(node(p, "herd0").model, -1);
  settings.memory_margin = ratio * 0.99;
  p = plan_or_fail(settings);
  EXPECT_EQ(node(p, "herd0").decision, Decision::Convert);

  // The triangle rule ignores memory: every mesh of 1000 triangles and more (and the tagged one).
  settings = s.settings(kMaxMemoryMargin);
  settings.convert_when = ConvertWhen::Triangles;
  settings.min_triangles = 1000;
  p = plan_or_fail(settings);
  EXPECT_EQ(converted_meshes(p), (std::set<int>{mesh_index(p, "e10"), mesh_index(p, "e1500"),
                                                mesh_index(p, "elephant"), mesh_index(p, "shared")}));
}

TEST(ConvertMemory, TheMemoryTableHasARowPerMeshAndGroup) {
  SizesScene s;
  ConvertSettings settings = s.settings(1.0);
  settings.groups = {{"pair", "^n(10|300)$"}};
  const Plan p = plan_or_fail(settings);
  std::map<std::string, const MemoryRow*> rows;
  for (const MemoryRow& r : p.memory) rows[(r.group ? "group " : "") + r.name] = &r;
  ASSERT_EQ(rows.size(), 6u);  // group pair, e800, e1500, elephant, floor, shared
  const MemoryRow& herd = *rows.at("elephant");
  EXPECT_EQ(herd.nodes.size(), 3u);
  EXPECT_EQ(herd.triangles, 5558u);
  EXPECT_EQ(herd.blas_bytes, herd.freed_bytes);
  const MemoryRow& shared = *rows.at("shared");
  EXPECT_EQ(shared.blas_bytes, p.mesh_blas[size_t(mesh_index(p, "shared"))]);
  EXPECT_EQ(shared.freed_bytes, 0u);  // shared_b keeps drawing it
  const MemoryRow& pair = *rows.at("group pair");
  EXPECT_EQ(pair.triangles, 310u);
  EXPECT_EQ(pair.blas_bytes, estimated_blas_bytes(10) + estimated_blas_bytes(300));

  // The report: the table's header, a row per mesh and group, the scene before and after.
  settings.dry_run = true;
  settings.output = (s.dir.path() / "dry" / "out.gltf").string();
  ConvertResult r;
  std::string log;
  EXPECT_EQ(run_quiet(settings, r, &log), 0) << log;
  for (const char* text : {"trade     the triangle BLASes a conversion frees vs its model", "BLAS MiB", "model MiB",
                           "group 'pair'", "stays: frees < margin x model", "calibrated estimate",
                           "* other nodes still draw the mesh", "scene     ", "of triangle BLASes before"})
    EXPECT_NE(log.find(text), std::string::npos) << text << "\n" << log;
}

// With --texture-coordinates auto the textures the converted objects' hits sample are reported
// beside the memory trade, counted on both sides (decoded RGBA8): BoxTextured's one 211 x 211
// texture is 178,084 bytes; without texture coordinates, no such line.
TEST(ConvertMemory, TexturesTheHitsSampleAreReportedOnBothSides) {
  const std::string box = lsnif::test::data_dir() + "/gltf/BoxTextured-glTF/BoxTextured.gltf";
  ASSERT_TRUE(std::filesystem::exists(box)) << box << " missing: run scripts/setup.sh";
  lsnif::test::ScopedTestDir dir("lsnif_convert_textures");
  for (const uint32_t coordinates : {kTextureCoordinatesAuto, kTextureCoordinatesOff}) {
    ConvertSettings settings = tiny_settings(box, dir.path("out.gltf"));
    settings.dry_run = true;
    settings.min_triangles = 1;  // the box's 12
    settings.train.texture_coordinates = coordinates;
    ConvertResult r;
    std::string log;
    ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
    const size_t at = log.find("textures  ");
    if (coordinates == kTextureCoordinatesOff) {
      EXPECT_EQ(at, std::string::npos) << log;
      continue;
    }
    ASSERT_NE(at, std::string::npos) << log;
    EXPECT_EQ(log.compare(at, 20, "textures  0.170 MiB "), 0) << log.substr(at);
    EXPECT_NE(log.find("needed with triangles too", at), std::string::npos) << log.substr(at);
  }
}

// The model estimates count the uv cells of texture-coordinate models: with the mesh (a dry run's,
// by the voxels and build_uv_cells) exactly the trained model's bytes; the plan's, without the
// mesh, the cells of a typical surface: BoxTextured's (a cube: about 6 V^2 occupied voxels against
// the assumed 4 V^2) within a factor of two of the trained model's cells. Without texture
// coordinates neither counts any.
TEST(ConvertMemory, TheEstimatesCountTheUvCells) {
  const std::string box = lsnif::test::data_dir() + "/gltf/BoxTextured-glTF/BoxTextured.gltf";
  ASSERT_TRUE(std::filesystem::exists(box)) << box << " missing: run scripts/setup.sh";
  lsnif::test::ScopedTestDir dir("lsnif_convert_uv_estimate");
  uint64_t planned[2] = {0, 0}, cells = 0;
  for (const uint32_t coordinates : {kTextureCoordinatesAuto, kTextureCoordinatesOff}) {
    SCOPED_TRACE(coordinates == kTextureCoordinatesAuto ? "auto" : "off");
    const bool uv = coordinates == kTextureCoordinatesAuto;
    ConvertSettings settings = tiny_settings(box, dir.path(uv ? "auto/out.gltf" : "off/out.gltf"));
    settings.min_triangles = 1;  // the box's 12
    settings.eval_rays = 0;
    settings.train.texture_coordinates = coordinates;
    settings.dry_run = true;
    ConvertResult dry;
    std::string log;
    ASSERT_EQ(run_quiet(settings, dry, &log), 0) << log;
    ASSERT_EQ(dry.plan.models.size(), 1u);
    EXPECT_TRUE(planned_textured(dry.plan, dry.plan.models[0]));
    planned[uv ? 0 : 1] = dry.plan.models[0].model_bytes;
    settings.dry_run = false;
    ConvertResult run;
    ASSERT_EQ(run_quiet(settings, run, &log), 0) << log;
    Model model;
    ASSERT_TRUE(load_model(dir.path(uv ? "auto" : "off") + "/" + run.plan.models[0].file, model));
    const MemoryBreakdown actual = memory_breakdown(model);
    EXPECT_EQ(dry.models[0].bytes, actual.total()) << "the estimate with the mesh";
    EXPECT_EQ(actual.uv_cell_bytes > 0, uv);
    if (uv) cells = actual.uv_cell_bytes;
  }
  // The plans differ by the cells alone.
  ASSERT_GT(planned[0], planned[1]);
  const double ratio = double(planned[0] - planned[1]) / double(cells);
  std::printf("BoxTextured: the plan's uv cells %llu bytes, the trained model's %llu (%.2fx)\n",
              (unsigned long long)(planned[0] - planned[1]), (unsigned long long)cells, ratio);
  EXPECT_GT(ratio, 0.5);
  EXPECT_LT(ratio, 2.0);
}

TEST(ConvertMemory, TheMarginHasARange) {
  SizesScene s;
  for (double bad : {0.0, 0.5, 0.999, 1e6 * 1.001, std::nan(""), -2.0}) {
    ConvertSettings settings = s.settings(bad);
    const Status st = check_settings(settings);
    ASSERT_FALSE(st) << bad;
    EXPECT_NE(st.message().find("--memory-margin"), std::string::npos) << st.message();
    EXPECT_NE(st.message().find("[1, 1000000]"), std::string::npos) << st.message();
    ConvertResult r;
    std::string log;
    EXPECT_EQ(run_quiet(settings, r, &log), 2) << log;
  }
  for (double good : {kMinMemoryMargin, 2.0, kMaxMemoryMargin}) EXPECT_TRUE(check_settings(s.settings(good))) << good;
}

TEST(ConvertMemory, AQueryReplacesTheEstimate) {
  SizesScene s;
  ConvertSettings settings = s.settings(2.0);
  std::vector<BlasPrimitive> asked;
  settings.blas.source = "test query";
  settings.blas.query = [&asked](const BlasPrimitive& prim, uint64_t& bytes) {
    asked.push_back(prim);
    bytes = 1000 * prim.triangles + prim.vertices;
    return Status::ok();
  };
  Plan p = plan_or_fail(settings);
  EXPECT_EQ(p.blas_source, "test query");
  // The elephant: two primitives of 2779 triangles over all 2775 vertices; asked once for its three nodes.
  EXPECT_EQ(p.mesh_blas[size_t(mesh_index(p, "elephant"))], 2 * (1000 * 2779 + 2775));
  EXPECT_EQ(asked.size(), 4u + 2u + 1u + 1u);  // e10, e300, e800, e1500; elephant (2); floor; shared
  settings.blas.query = [](const BlasPrimitive&, uint64_t&) { return Status::error("device lost"); };
  Plan bad;
  const Status st = make_plan(settings, bad);
  ASSERT_FALSE(st);
  EXPECT_NE(st.message().find("mesh 'e10'"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("primitive 0"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("device lost"), std::string::npos) << st.message();
}

}  // namespace
}  // namespace lsnif::convert
