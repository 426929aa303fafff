// The converter's plan on small scenes: which nodes become LSNIF objects under the threshold,
// --select / --exclude, the extras tag and groups; one model per mesh however many nodes use it;
// and a dry run that writes nothing.
#include <filesystem>

#include "lsnif/testing/convert_test_support.h"

namespace lsnif::convert {
namespace {
namespace fs = std::filesystem;
using namespace test;

// Materials 0 grey, 1 red. Mesh 0 "elephant" (5558 triangles in two primitives: red, grey), mesh 1
// "floor" (2 triangles). Nodes: e1, e2, e3 (elephant instances), floor, statue (elephant, extras
// "lsnif": false), tagged (floor mesh, extras "lsnif": true).
struct SceneA : TestScene {
  SceneA() : TestScene("lsnif_convert_plan") {}
  void build() {
    scene::add_node(g, "e1", elephant, placed({0, 0, 0}, 0, 1));
    scene::add_node(g, "e2", elephant, placed({2, 0, 0}, 90, 0.5f));
    scene::add_node(g, "e3", elephant, placed({-2, 0, 1}, 45, 2));
    scene::add_node(g, "floor", floor, glm::mat4(1.0f));
    set_extra(g, scene::add_node(g, "statue", elephant, placed({0, 0, -3}, 0, 1)), "lsnif", false);
    set_extra(g, scene::add_node(g, "tagged", floor, placed({0, 1, 0}, 0, 1)), "lsnif", true);
  }
  void save() { save_or_fail(g, path); }
};

const PlannedNode& node(const Plan& p, const std::string& name) {
  for (const PlannedNode& n : p.nodes)
    if (n.name == name) return n;
  ADD_FAILURE() << "no node " << name;
  static PlannedNode none;
  return none;
}

const PlannedModel* model_of(const Plan& p, const std::string& node_name) {
  const PlannedNode& n = node(p, node_name);
  return n.model >= 0 ? &p.models[size_t(n.model)] : nullptr;
}

Plan plan_for(const ConvertSettings& settings) {
  Plan p;
  Status st = make_plan(settings, p);
  EXPECT_TRUE(st) << st.message();
  return p;
}

TEST(ConvertPlan, OneModelPerMeshThresholdAndTags) {
  SceneA s;
  s.build();
  s.save();
  const Plan p = plan_for(tiny_settings(s.path, s.dir.path("out.gltf")));
  ASSERT_EQ(p.nodes.size(), 6u);
  // The elephant.off header: 5558 faces; the quad: 2.
  EXPECT_EQ(node(p, "e1").triangles, 5558u);
  EXPECT_EQ(node(p, "floor").triangles, 2u);
  EXPECT_EQ(node(p, "floor").decision, Decision::BelowThreshold);
  EXPECT_EQ(node(p, "statue").decision, Decision::TaggedOff);
  EXPECT_EQ(node(p, "tagged").decision, Decision::Convert);  // the tag overrides the threshold
  ASSERT_EQ(p.models.size(), 2u);
  const PlannedModel* m = model_of(p, "e1");
  ASSERT_NE(m, nullptr);
  EXPECT_EQ(m, model_of(p, "e2"));
  EXPECT_EQ(m, model_of(p, "e3"));
  EXPECT_EQ(m->nodes.size(), 3u);
  EXPECT_EQ(m->triangles, 5558u);
  EXPECT_TRUE(m->group.empty());
  EXPECT_EQ(m->file, "out.elephant.lsnif");
  EXPECT_EQ(planned_material_count(p, *m), 2u);
  EXPECT_EQ(model_of(p, "tagged")->nodes.size(), 1u);
  EXPECT_EQ(planned_material_count(p, *model_of(p, "tagged")), 1u);
  EXPECT_EQ(p.instances_converted(), 4u);
  EXPECT_EQ(p.failed_models(), 0u);
  // World transforms: e2 is translated by (2, 0, 0).
  EXPECT_EQ(glm::vec3(node(p, "e2").world[3]), glm::vec3(2, 0, 0));

  ConvertSettings high = tiny_settings(s.path, s.dir.path("out.gltf"));
  high.min_triangles = 6000;
  const Plan q = plan_for(high);
  EXPECT_EQ(node(q, "e1").decision, Decision::BelowThreshold);
  EXPECT_EQ(q.models.size(), 1u);  // only the tagged floor
}

TEST(ConvertPlan, SelectAndExcludeMatchNodeOrMeshNames) {
  SceneA s;
  s.build();
  s.save();
  ConvertSettings settings = tiny_settings(s.path, s.dir.path("out.gltf"));
  settings.exclude = "^e2$";
  Plan p = plan_for(settings);
  EXPECT_EQ(node(p, "e2").decision, Decision::Excluded);
  EXPECT_EQ(model_of(p, "e1")->nodes.size(), 2u);

  settings.exclude = "";
  settings.select = "^elephant$";  // the mesh name selects all three instances
  p = plan_for(settings);
  EXPECT_EQ(model_of(p, "e3")->nodes.size(), 3u);
  EXPECT_EQ(node(p, "floor").decision, Decision::NotSelected);
  EXPECT_EQ(node(p, "statue").decision, Decision::TaggedOff);  // the tag wins over --select
  EXPECT_EQ(node(p, "tagged").decision, Decision::Convert);

  settings.select = "^e[13]$";
  settings.exclude = "3";
  p = plan_for(settings);
  EXPECT_EQ(node(p, "e1").decision, Decision::Convert);
  EXPECT_EQ(node(p, "e2").decision, Decision::NotSelected);
  EXPECT_EQ(node(p, "e3").decision, Decision::Excluded);

  settings.select = "(";
  Plan bad;
  Status st = make_plan(settings, bad);
  ASSERT_FALSE(st);
  EXPECT_NE(st.message().find("--select"), std::string::npos) << st.message();
}

TEST(ConvertPlan, GroupsMakeOneModelForSeveralNodes) {
  SceneA s;
  s.build();
  set_extra(s.g, 2, "lsnif_group", std::string("herd"));  // e3 joins by its extras
  s.save();
  ConvertSettings settings = tiny_settings(s.path, s.dir.path("out.gltf"));
  settings.groups = {{"herd", "^e1$"}, {"pair", "^e2$"}};
  Plan p = plan_for(settings);
  const PlannedModel* herd = model_of(p, "e1");
  ASSERT_NE(herd, nullptr);
  EXPECT_EQ(herd->group, "herd");
  EXPECT_EQ(herd, model_of(p, "e3"));
  EXPECT_EQ(herd->nodes.size(), 2u);
  EXPECT_EQ(herd->triangles, 2u * 5558u);
  EXPECT_EQ(model_of(p, "e2")->group, "pair");
  EXPECT_EQ(p.models.size(), 3u);  // herd, pair, the tagged floor

  // A group counts all its members against the threshold.
  settings.min_triangles = 10000;
  p = plan_for(settings);
  EXPECT_EQ(node(p, "e1").decision, Decision::Convert);
  EXPECT_EQ(node(p, "e2").decision, Decision::BelowThreshold);
  settings.min_triangles = 20000;
  p = plan_for(settings);
  EXPECT_EQ(node(p, "e1").decision, Decision::BelowThreshold);
  EXPECT_EQ(p.models.size(), 1u);

  settings.groups = {{"", "x"}};
  Plan bad;
  EXPECT_FALSE(make_plan(settings, bad));
}

TEST(ConvertPlan, DryRunPrintsThePlanAndWritesNothing) {
  SceneA s;
  s.build();
  s.save();
  const fs::path out = s.dir.path() / "out";
  ConvertSettings settings = tiny_settings(s.path, (out / "scene.gltf").string());
  settings.dry_run = true;
  ConvertResult r;
  std::string log;
  EXPECT_EQ(run_quiet(settings, r, &log), 0) << log;
  EXPECT_FALSE(fs::exists(out));
  ASSERT_EQ(r.models.size(), 2u);
  for (const ModelResult& m : r.models) EXPECT_EQ(m.state, ModelState::Planned);
  EXPECT_EQ(r.trained, 0u);
  EXPECT_FALSE(r.wrote_output);
  EXPECT_NE(log.find("would be trained"), std::string::npos) << log;
  EXPECT_NE(log.find("3 instances sharing it"), std::string::npos) << log;
  // The estimate is the size of the model training gives (with its material count and, for the
  // indexed coarse level of the default, the table its mesh needs).
  const std::vector<ModelResult> planned = r.models;
  settings.dry_run = false;
  EXPECT_EQ(run_quiet(settings, r, &log), 0) << log;
  ASSERT_EQ(r.models.size(), planned.size());
  for (size_t i = 0; i < planned.size(); ++i) {
    ASSERT_EQ(r.models[i].state, ModelState::Trained) << i;
    EXPECT_EQ(planned[i].bytes, r.models[i].bytes) << i;
  }
}

TEST(ConvertPlan, NonTriangleModesAndDracoFailTheirObjectOnly) {
  SceneA s;
  s.build();
  const int lines = add_mesh_or_fail(s.g, elephant_mesh("wire", 0, 0, false));
  s.g.meshes[size_t(lines)].primitives[0].mode = TINYGLTF_MODE_LINE;
  scene::add_node(s.g, "wireframe", lines, glm::mat4(1.0f));
  const int draco = add_mesh_or_fail(s.g, elephant_mesh("squeezed", 0, 0, false));
  s.g.meshes[size_t(draco)].primitives[0].extensions["KHR_draco_mesh_compression"] =
      tinygltf::Value(tinygltf::Value::Object{});
  scene::add_node(s.g, "compressed", draco, glm::mat4(1.0f));
  s.save();
  ConvertSettings settings = tiny_settings(s.path, s.dir.path("out.gltf"));
  settings.min_triangles = 0;
  const Plan p = plan_for(settings);
  EXPECT_EQ(node(p, "wireframe").decision, Decision::Failed);
  const PlannedModel* m = model_of(p, "wireframe");
  ASSERT_NE(m, nullptr);
  EXPECT_NE(m->error.find("wireframe"), std::string::npos) << m->error;
  EXPECT_NE(m->error.find("LINES"), std::string::npos) << m->error;
  const PlannedModel* d = model_of(p, "compressed");
  ASSERT_NE(d, nullptr);
  EXPECT_NE(d->error.find("node 'compressed' (mesh 'squeezed')"), std::string::npos) << d->error;
  EXPECT_NE(d->error.find("Draco"), std::string::npos) << d->error;
  EXPECT_EQ(node(p, "e1").decision, Decision::Convert);
  EXPECT_EQ(p.failed_models(), 2u);
}

}  // namespace
}  // namespace lsnif::convert
