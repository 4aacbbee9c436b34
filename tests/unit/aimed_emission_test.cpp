// Aimed emission, the photon tracer's density policy (PhotonTracer::aimed_emission_densities,
// photonbench/photons.h), read through the public interface as techniques and the reference's
// photon mapping read it: the density it gives a light must be 1 on every texel a caustic-type
// photon can start from, or photon mapping would lose that light; and it must drop most texels
// where the specular surfaces are small, or it would aim at nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include "scene/scene.h"
#include "test_scenes.h"
#include "trace/photon_tracer.h"

namespace pb::trace {
namespace aimed_emission_test {

using namespace test_scenes;

// Traces `paths` light paths with uniform emission, keeping those that stored a photon whose
// first interaction was specular, and checks that each started on a texel the aimed density keeps.
// Returns the fraction of the density's texels that are kept.
double check_every_caustic_path_is_aimed_at(const EmbreeScene& world, uint32_t paths) {
  EmbreePhotonTracer embree_tracer(world);
  PhotonTracer& tracer = embree_tracer;
  std::vector<std::optional<EmissionDensity>> densities = tracer.aimed_emission_densities();
  EXPECT_EQ(densities.size(), tracer.light_count());
  TraceSettings ts;
  ts.paths = paths;
  ts.store = kCausticPhotons | kCausticIndirectPhotons;
  ts.max_bounces = 8;
  ts.rr_start = 0;
  ts.keep_light_paths = true;
  ts.seed = 5;
  PhotonBatch batch;
  tracer.trace(ts, batch);
  size_t caustic_paths = 0, missed = 0;
  for (const LightPath& p : batch.paths.paths) {
    if (p.photon_count == 0) continue;
    ++caustic_paths;
    EXPECT_TRUE(densities.at(p.light).has_value()) << "light " << p.light;
    if (!densities[p.light]) continue;
    const EmissionDensity& d = *densities[p.light];
    int i = std::min(d.width - 1, int(p.emission_uv.x * d.width));
    int j = std::min(d.height - 1, int(p.emission_uv.y * d.height));
    if (d.texels[size_t(j) * d.width + i] == 0.f) ++missed;
  }
  EXPECT_GT(caustic_paths, 100u) << "too few caustic paths to check anything";
  EXPECT_EQ(missed, 0u) << "of " << caustic_paths << " caustic paths";
  double kept = 0, texels = 0;
  for (const auto& d : densities) {
    if (!d) continue;
    for (float v : d->texels) kept += v > 0 ? 1 : 0;
    texels += double(d->texels.size());
  }
  return texels > 0 ? kept / texels : 1.0;
}

scene::Scene load(const char* name) {
  return scene::load_scene(std::filesystem::path(PB_SOURCE_DIR) / "scenes" / name);
}

// A shipped scene's frame 4, its caustic paths from `paths` light paths, and the most of the
// density's texels aimed emission may keep there.
struct ShippedCase {
  const char* scene;
  uint32_t paths;
  double most_kept;
  friend void PrintTo(const ShippedCase& c, std::ostream* os) { *os << c.scene; }
};

class AimedEmissionShipped : public ::testing::TestWithParam<ShippedCase> {};

// cornell-glass: a point light, the glass sphere covers about 2% of its directions;
// torus-in-glass-cube: a spot light whose cone the cube fills much of.
TEST_P(AimedEmissionShipped, KeepsEveryTexelACausticPathStartsFrom) {
  scene::Scene scene = load(GetParam().scene);
  EmbreeScene world(scene, scene.at(4));
  double kept = check_every_caustic_path_is_aimed_at(world, GetParam().paths);
  EXPECT_LT(kept, GetParam().most_kept);
  RecordProperty("kept", std::to_string(kept));
}

INSTANTIATE_TEST_SUITE_P(PointAndSpot, AimedEmissionShipped,
                         ::testing::Values(ShippedCase{"cornell-glass.yaml", 400000, 0.06},
                                           ShippedCase{"torus-in-glass-cube.yaml", 200000, 0.8}),
                         [](const ::testing::TestParamInfo<ShippedCase>& info) {
                           std::string name = info.param.scene;
                           name = name.substr(0, name.find('.'));
                           std::replace(name.begin(), name.end(), '-', '_');
                           return name;
                         });

// A directional light over a small mirror sphere on a floor: parallel rays from a square of
// origins.
TEST(AimedEmission, KeepsEveryTexelACausticPathStartsFromUnderADirectionalLight) {
  TestScene t;
  t.object(quad_mesh({-2, 0, -2}, {4, 0, 0}, {0, 0, 4}),
           t.material(scene::MaterialType::diffuse, glm::vec3(0.8f)));
  t.object(sphere_mesh({0.3f, 0.25f, 0.1f}, 0.2f, 24),
           t.material(scene::MaterialType::mirror, glm::vec3(0.9f)));
  scene::Light sun;
  sun.type = scene::LightType::directional;
  sun.direction = glm::normalize(glm::vec3(0.3f, -1.f, 0.2f));
  sun.radiant = glm::vec3(1.f);
  t.light(sun);
  t.camera({0, 2, 2}, {0, 0, 0}, {0, 1, 0}, 60.f);
  EmbreeScene world(t.scene, t.state);
  double kept = check_every_caustic_path_is_aimed_at(world, 400000);
  EXPECT_LT(kept, 0.1);
  RecordProperty("kept", std::to_string(kept));
}

}  // namespace aimed_emission_test
}  // namespace pb::trace
