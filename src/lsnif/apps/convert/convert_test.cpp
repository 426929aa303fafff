// The converter end to end with tiny models: the extension's round trip through load_scene
// (models, material maps, transforms, removed or kept meshes), groups, skip-on-rerun by content
// hash, parallel jobs, and one bad object not losing the others' work.
#include <filesystem>
#include <map>
#include <utility>

#include "lsnif/format/folder_lock.h"
#include "lsnif/testing/convert_test_support.h"
#include "lsnif/scene/scene_gltf.h"

namespace lsnif::convert {
namespace {
namespace fs = std::filesystem;
using namespace test;

// Each test builds its scene in `s` and runs the converter into `r` with the report in `log`.
class Convert : public ::testing::Test {
 protected:
  TestScene s{"lsnif_convert"};
  ConvertResult r;
  std::string log;
};

const glm::mat4 kE1 = placed({0, 0.5f, 0}, 30, 1), kE2 = placed({2, 0.25f, -1}, 120, 0.5f);

const scene::Instance* instance(const scene::Scene& s, const std::string& name) {
  for (const scene::Instance& i : s.instances)
    if (i.node_name == name) return &i;
  return nullptr;
}

void expect_near(const glm::mat4& a, const glm::mat4& b) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) EXPECT_NEAR(a[c][r], b[c][r], 1e-6f) << c << "," << r;
}

scene::Scene load_or_fail(const std::string& path) {
  scene::Scene s;
  scene::SceneLoadOptions o;
  o.quiet = true;
  Status st = scene::load_scene(path, o, s);
  EXPECT_TRUE(st) << st.message();
  return s;
}

// World-space box of the elephant under `m`.
Aabb elephant_bounds(const glm::mat4& m) {
  Mesh e;
  EXPECT_TRUE(load_mesh(kElephant, e));
  Aabb box;
  for (glm::vec3 p : e.positions) box.grow(glm::vec3(m * glm::vec4(p, 1.0f)));
  return box;
}

void expect_contains(const Aabb& outer, const Aabb& inner) {
  for (int k = 0; k < 3; ++k) {
    EXPECT_LE(outer.lo[k], inner.lo[k] + 1e-5f) << k;
    EXPECT_GE(outer.hi[k], inner.hi[k] - 1e-5f) << k;
  }
}

TEST_F(Convert, ExtensionRoundTripWithInstancesAndMaterials) {
  scene::add_node(s.g, "e1", s.elephant, kE1);
  scene::add_node(s.g, "e2", s.elephant, kE2);
  scene::add_node(s.g, "floor", s.floor, glm::mat4(1.0f));
  save_or_fail(s.g, s.path);
  const std::string out = s.dir.path("out/converted.gltf");
  ConvertSettings settings = tiny_settings(s.path, out);
  ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
  EXPECT_EQ(r.trained, 1u);
  EXPECT_NE(log.find("2 instances sharing it"), std::string::npos) << log;
  EXPECT_NE(log.find("accuracy"), std::string::npos) << log;

  const scene::Scene sc = load_or_fail(out);
  ASSERT_EQ(sc.lsnif_objects.size(), 1u);
  EXPECT_EQ(fs::path(sc.lsnif_objects[0].resolved_path).filename(), "converted.elephant.lsnif");
  // Model material 0 is primitive 0's material (red = glTF 1), material 1 grey (glTF 0).
  EXPECT_EQ(sc.lsnif_objects[0].material_map, (std::vector<uint32_t>{1, 0}));
  for (auto [name, xf] : {std::pair{"e1", kE1}, std::pair{"e2", kE2}}) {
    const scene::Instance* i = instance(sc, name);
    ASSERT_NE(i, nullptr) << name;
    EXPECT_EQ(i->lsnif, 0) << name;
    EXPECT_EQ(i->mesh, -1) << name;  // triangles removed without --keep-meshes
    expect_near(i->object_to_world, xf);
  }
  const scene::Instance* fl = instance(sc, "floor");
  ASSERT_NE(fl, nullptr);
  EXPECT_EQ(fl->lsnif, -1);
  ASSERT_EQ(sc.meshes.size(), 1u);  // the elephant's triangle data is gone
  EXPECT_EQ(scene::triangle_count(sc.meshes[0]), 2u);

  Model model;
  ASSERT_TRUE(load_model(sc.lsnif_objects[0].resolved_path, model));
  ASSERT_EQ(model.materials.size(), 2u);
  EXPECT_EQ(model.materials[0].name, "red");
  EXPECT_EQ(model.materials[1].name, "grey");
  expect_contains(model.bounds(), elephant_bounds(glm::mat4(1.0f)));  // object space of the mesh
  // The plan's estimate (from the settings and, for the indexed coarse level, the mesh's voxels) is
  // the model's memory; the file holds the training record besides.
  ASSERT_TRUE(model.config.indexed(0)) << "the default indexes the coarse level";
  Mesh elephant;
  ASSERT_TRUE(load_mesh(kElephant, elephant));
  const uint64_t estimate = estimated_model_bytes(settings.train, 2, false, &elephant);
  EXPECT_EQ(memory_breakdown(model).total(), estimate);
  // The record's section: its bytes, a section header and alignment padding.
  const uint64_t file = fs::file_size(sc.lsnif_objects[0].resolved_path);
  EXPECT_GE(file, estimate + model.training.size());
  EXPECT_LE(file, estimate + model.training.size() + 48);
  EXPECT_NE(model.training.find("\"settings\":{\"voxels\":"), std::string::npos) << model.training;

  // --keep-meshes: the nodes keep their triangles as the reference.
  settings.output = s.dir.path("kept/converted.gltf");
  settings.keep_meshes = true;
  ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
  const scene::Scene kept = load_or_fail(settings.output);
  const scene::Instance* e1 = instance(kept, "e1");
  ASSERT_NE(e1, nullptr);
  EXPECT_EQ(e1->lsnif, 0);
  ASSERT_GE(e1->mesh, 0);
  EXPECT_EQ(scene::triangle_count(kept.meshes[size_t(e1->mesh)]), 5558u);
}

// A primitive without a material trains as the default material; the output gains a glTF material
// for it (glTF defaults) and the map points there.
TEST_F(Convert, PrimitiveWithoutMaterialMapsToAnAppendedDefault) {
  s.g.meshes[size_t(s.elephant)].primitives[1].material = -1;
  scene::add_node(s.g, "e1", s.elephant, kE1);
  save_or_fail(s.g, s.path);
  ConvertSettings settings = tiny_settings(s.path, s.dir.path("converted.gltf"));
  ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
  const scene::Scene sc = load_or_fail(settings.output);
  ASSERT_EQ(sc.lsnif_objects.size(), 1u);
  EXPECT_EQ(sc.lsnif_objects[0].material_map, (std::vector<uint32_t>{1, 2}));  // red, then the new one
  ASSERT_GE(sc.materials.size(), 3u);
  EXPECT_EQ(sc.materials[2].name, "lsnif_default");
  EXPECT_EQ(glm::vec4(sc.materials[2].base_color, sc.materials[2].alpha), glm::vec4(1.0f));
  EXPECT_EQ(sc.materials[2].metallic, 1.0f);
  EXPECT_EQ(sc.materials[2].roughness, 1.0f);
}

TEST_F(Convert, RerunSkipsUnchangedModelsAndRetrainsChangedOnes) {
  scene::add_node(s.g, "e1", s.elephant, kE1);
  save_or_fail(s.g, s.path);
  const std::string out = s.dir.path("converted.gltf");
  const std::string model = s.dir.path("converted.elephant.lsnif");
  ConvertSettings settings = tiny_settings(s.path, out);
  ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
  ASSERT_EQ(r.trained, 1u);
  const auto time = fs::last_write_time(model);
  const std::string hash = read_json(sidecar_path(model))["hash"].get<std::string>();
  EXPECT_EQ(hash, r.models[0].hash);

  // Same mesh and settings, another node transform: nothing trained.
  s.g.nodes[0].matrix.clear();
  s.g.nodes[0].translation = {5, 0, 0};
  save_or_fail(s.g, s.path);
  ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
  EXPECT_EQ(r.trained, 0u);
  EXPECT_EQ(r.up_to_date, 1u);
  EXPECT_EQ(fs::last_write_time(model), time);
  EXPECT_NE(log.find("up to date"), std::string::npos) << log;
  expect_near(instance(load_or_fail(out), "e1")->object_to_world,
              glm::translate(glm::mat4(1.0f), glm::vec3(5, 0, 0)));
  // A dry run sees it up to date too.
  settings.dry_run = true;
  ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
  EXPECT_TRUE(r.models[0].up_to_date_on_disk);
  settings.dry_run = false;

  // A training setting changes: retrained, new hash.
  settings.train.steps = 31;
  ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
  EXPECT_EQ(r.trained, 1u);
  EXPECT_NE(read_json(sidecar_path(model))["hash"].get<std::string>(), hash);
  ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
  EXPECT_EQ(r.trained, 0u);

  // The mesh changes (one vertex moves): retrained.
  tinygltf::Model g2 = scene::new_gltf_model("convert_test");
  scene::add_material(g2, scene::Material{"grey"});
  scene::add_material(g2, scene::Material{"red"});
  scene::Mesh moved = elephant_mesh("elephant", 1, 0, true);
  for (scene::Primitive& p : moved.primitives) p.positions[0] += glm::vec3(0.01f);
  scene::add_node(g2, "e1", add_mesh_or_fail(g2, moved), kE1);
  save_or_fail(g2, s.path);
  ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
  EXPECT_EQ(r.trained, 1u);

  // --force retrains an up-to-date model.
  settings.force = true;
  ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
  EXPECT_EQ(r.trained, 1u);
}

// Up to date is the model file's own word: its training record of these settings and this mesh,
// with a sidecar that agrees. A model and a sidecar of different runs (what a kill between their two
// renames leaves) are retrained, whichever of the two matches the settings, and so is a model
// without its sidecar; the report says why.
TEST_F(Convert, UpToDateIsDecidedByTheModelsOwnRecord) {
  scene::add_node(s.g, "e1", s.elephant, kE1);
  save_or_fail(s.g, s.path);
  const std::string out = s.dir.path("converted.gltf"), model = s.dir.path("converted.elephant.lsnif");
  ConvertSettings settings = tiny_settings(s.path, out);
  std::map<uint64_t, std::pair<std::string, std::string>> runs;  // seed -> model, sidecar bytes
  for (const uint64_t seed : {1u, 2u}) {
    settings.train.seed = seed;
    ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
    ASSERT_EQ(r.trained, 1u) << log;
    runs[seed] = {lsnif::test::read_text(model), lsnif::test::read_text(sidecar_path(model))};
  }
  const auto put = [&](uint64_t model_seed, uint64_t sidecar_seed) {
    std::ofstream(model, std::ios::binary) << runs[model_seed].first;
    std::ofstream(sidecar_path(model), std::ios::binary) << runs[sidecar_seed].second;
  };
  // Seed 2 asked for: the model of seed 1 with the sidecar of seed 2, then the reverse.
  put(1, 2);
  settings.dry_run = true;
  ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
  EXPECT_FALSE(r.models[0].up_to_date_on_disk);
  EXPECT_NE(log.find("would be retrained: the model on disk is not of these settings and this mesh: it records "
                     "seed=1, the settings give seed=2"), std::string::npos) << log;
  settings.dry_run = false;
  ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
  EXPECT_EQ(r.trained, 1u) << log;
  EXPECT_EQ(lsnif::test::read_text(model), runs[2].first);  // seed 2's model again (deterministic)
  put(2, 1);
  ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
  EXPECT_EQ(r.trained, 1u) << log;
  EXPECT_NE(log.find("retrained: its sidecar " + sidecar_path(model) + " is missing or of another run"),
            std::string::npos) << log;
  EXPECT_EQ(lsnif::test::read_text(sidecar_path(model)), runs[2].second);
  fs::remove(sidecar_path(model));
  ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
  EXPECT_EQ(r.trained, 1u) << log;
  ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
  EXPECT_EQ(r.up_to_date, 1u) << log;
  EXPECT_TRUE(r.models[0].stale.empty()) << r.models[0].stale;
}

// The output folder is one run's at a time: a held lock fails the run before it reads or trains
// anything (a dry run only warns); stale temporary files of our outputs go when a run starts.
TEST_F(Convert, TheOutputFolderIsLockedAndCleaned) {
  scene::add_node(s.g, "e1", s.elephant, kE1);
  save_or_fail(s.g, s.path);
  fs::create_directories(s.dir.path("out"));
  ConvertSettings settings = tiny_settings(s.path, s.dir.path("out/converted.gltf"));
  FolderLock other;
  bool busy = false;
  ASSERT_TRUE(other.acquire(s.dir.path("out"), ".lsnif-convert.lock", busy));
  EXPECT_EQ(run_quiet(settings, r, &log), 1);
  EXPECT_NE(log.find("another lsnif convert is writing into the output folder '" + s.dir.path("out") + "'"),
            std::string::npos) << log;
  EXPECT_TRUE(r.models.empty());
  EXPECT_FALSE(fs::exists(s.dir.path("out/converted.elephant.lsnif")));
  settings.dry_run = true;
  EXPECT_EQ(run_quiet(settings, r, &log), 0) << log;
  EXPECT_NE(log.find("warning: another lsnif convert is writing into the output folder"), std::string::npos) << log;
  settings.dry_run = false;
  other.release();

  const std::string stale = s.dir.path("out/.converted.elephant.lsnif.tmp-00112233aabb");
  const std::string foreign = s.dir.path("out/.notes.md.tmp-00112233aabb");
  std::ofstream(stale) << "partial";
  std::ofstream(foreign) << "not ours";
  ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(foreign));
  EXPECT_NE(log.find("cleanup   removed " + stale), std::string::npos) << log;
  EXPECT_FALSE(fs::exists(s.dir.path("out/.lsnif-convert.lock")));
}

TEST_F(Convert, GroupIsOneObjectInWorldSpaceAndJobsTrainInParallel) {
  scene::add_node(s.g, "e1", s.elephant, kE1);
  scene::add_node(s.g, "e2", s.elephant, kE2);
  scene::add_node(s.g, "floor", s.floor, glm::mat4(1.0f));
  scene::add_node(s.g, "e3", s.elephant, placed({-3, 0, 0}, 0, 1));
  save_or_fail(s.g, s.path);
  const std::string out = s.dir.path("converted.gltf");
  ConvertSettings settings = tiny_settings(s.path, out);
  settings.groups = {{"herd", "^(e1|e2|floor)$"}};
  settings.keep_meshes = true;
  settings.jobs = 2;
  ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
  EXPECT_EQ(r.trained, 2u);  // the group and e3's mesh, at the same time
  EXPECT_NE(log.find("group     'herd': 1 model"), std::string::npos) << log;
  EXPECT_NE(log.find("instead of 2 models"), std::string::npos) << log;
  EXPECT_NE(log.find("per-object model 'elephant'"), std::string::npos) << log;

  const scene::Scene sc = load_or_fail(out);
  EXPECT_EQ(instance(sc, "e1"), nullptr);  // the members no longer draw themselves
  EXPECT_EQ(instance(sc, "floor"), nullptr);
  const scene::Instance* herd = instance(sc, "herd");
  ASSERT_NE(herd, nullptr);
  ASSERT_GE(herd->lsnif, 0);
  expect_near(herd->object_to_world, glm::mat4(1.0f));
  ASSERT_GE(herd->mesh, 0);  // --keep-meshes: the members' triangles in world space
  EXPECT_EQ(scene::triangle_count(sc.meshes[size_t(herd->mesh)]), 2u * 5558u + 2u);
  const scene::LsnifObject& obj = sc.lsnif_objects[size_t(herd->lsnif)];
  EXPECT_EQ(obj.material_map, (std::vector<uint32_t>{1, 0}));
  Model model;
  ASSERT_TRUE(load_model(obj.resolved_path, model));
  expect_contains(model.bounds(), elephant_bounds(kE1));
  expect_contains(model.bounds(), elephant_bounds(kE2));
  EXPECT_LE(model.bounds().lo.x, -2.0f + 1e-5f);  // the floor spans x in [-2, 2]
  EXPECT_GE(model.bounds().hi.x, 2.0f - 1e-5f);
  const scene::Instance* e3 = instance(sc, "e3");
  ASSERT_NE(e3, nullptr);
  EXPECT_GE(e3->lsnif, 0);
  EXPECT_NE(e3->lsnif, herd->lsnif);
}

TEST_F(Convert, OneBadObjectDoesNotLoseTheOthers) {
  const int broken = add_mesh_or_fail(s.g, elephant_mesh("broken_mesh", 0, 0, false));
  const int outside = add_mesh_or_fail(s.g, elephant_mesh("outside_mesh", 0, 0, false));
  const int wire = add_mesh_or_fail(s.g, quad_mesh("wire_mesh", 0));
  const int short_mesh = add_mesh_or_fail(s.g, elephant_mesh("short_mesh", 0, 0, false));
  s.g.meshes[size_t(wire)].primitives[0].mode = TINYGLTF_MODE_LINE;
  scene::add_node(s.g, "e1", s.elephant, kE1);
  scene::add_node(s.g, "broken", broken, glm::mat4(1.0f));
  scene::add_node(s.g, "outsider", outside, glm::mat4(1.0f));
  scene::add_node(s.g, "wireframe", wire, glm::mat4(1.0f));
  scene::add_node(s.g, "shorty", short_mesh, glm::mat4(1.0f));
  set_extra(s.g, 3, "lsnif", true);  // the 2-triangle wire mesh is selected by its tag
  fs::create_directories(s.dir.path() / "scene");
  const std::string path = s.dir.path("scene/scene.gltf");
  save_or_fail(s.g, path);
  // Mesh "broken_mesh" reads from a missing file, "outside_mesh" from a file outside the folder.
  nlohmann::json j = read_json(path);
  const uint64_t length = fs::file_size(s.dir.path("scene/scene.bin"));
  fs::copy_file(s.dir.path("scene/scene.bin"), s.dir.path("outside.bin"));
  j["buffers"].push_back({{"uri", "missing.bin"}, {"byteLength", length}});
  j["buffers"].push_back({{"uri", "../outside.bin"}, {"byteLength", length}});
  for (auto [mesh, buffer] : {std::pair{broken, 1}, std::pair{outside, 2}}) {
    const nlohmann::json& prim = j["meshes"][size_t(mesh)]["primitives"][0];
    for (int acc : {prim["attributes"]["POSITION"].get<int>(), prim["indices"].get<int>()})
      j["bufferViews"][j["accessors"][size_t(acc)]["bufferView"].get<size_t>()]["buffer"] = buffer;
  }
  // Mesh "short_mesh" claims 3 vertices: its indices run past them (found while flattening).
  j["accessors"][j["meshes"][size_t(short_mesh)]["primitives"][0]["attributes"]["POSITION"].get<size_t>()]["count"] = 3;
  write_json(path, j);

  const std::string out = s.dir.path("scene/converted.gltf");
  ConvertSettings settings = tiny_settings(path, out);
  EXPECT_EQ(run_quiet(settings, r, &log), 1) << log;
  EXPECT_EQ(r.trained, 1u);
  EXPECT_EQ(r.failed, 4u);
  for (const char* expected : {"node 'broken' (mesh 'broken_mesh')", "missing.bin", "does not exist",
                               "node 'outsider'", "outside the folder", "--allow-outside-refs", "node 'wireframe'", "LINES",
                               "model 'short_mesh' (node 'shorty')"})
    EXPECT_NE(log.find(expected), std::string::npos) << expected << "\n" << log;
  ASSERT_TRUE(r.wrote_output);
  const scene::Scene sc = load_or_fail(out);
  const scene::Instance* e1 = instance(sc, "e1");
  ASSERT_NE(e1, nullptr);
  EXPECT_GE(e1->lsnif, 0);
  EXPECT_TRUE(fs::exists(s.dir.path("scene/converted.elephant.lsnif")));
  EXPECT_EQ(instance(sc, "broken"), nullptr);  // its triangles could not be read, so not written
  EXPECT_EQ(instance(sc, "shorty"), nullptr);
  EXPECT_NE(log.find("node 'shorty': mesh 'short_mesh' left out of the output"), std::string::npos) << log;
}

}  // namespace
}  // namespace lsnif::convert
