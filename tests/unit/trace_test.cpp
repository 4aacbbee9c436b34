// Photon tracer, Embree scene, sampling and BSDFs (src/trace). Ordered from construction to
// statistics: geometry queries, exact power bookkeeping per light type, footprints against closed
// forms, path re-validation, determinism across thread counts, then the sampling routines (Sobol
// stratification, chi-square of the emission density, GGX/Fresnel consistency and energy).
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <cstring>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <memory>
#include <numeric>
#include <random>
#include <type_traits>

#include "photonbench/photons.h"
#include "scene/emissive_triangles.h"
#include "test_scenes.h"
#include "trace/bsdf.h"
#include "trace/embree_scene.h"
#include "trace/lights.h"
#include "trace/photon_tracer.h"
#include "trace/sampling.h"

namespace pb::trace {
namespace trace_test {

using namespace test_scenes;

scene::Light point_light(glm::vec3 p, float intensity) {
  scene::Light l;
  l.type = scene::LightType::point;
  l.position = p;
  l.radiant = glm::vec3(intensity);
  return l;
}

glm::dvec3 total_power(const std::vector<PhotonRecord>& photons) {
  glm::dvec3 s(0.0);
  for (const auto& p : photons) s += glm::dvec3(p.power);
  return s;
}

// ---- Embree scene
// --------------------------------------------------------------------------------

TEST(EmbreeScene, HitsReportObjectMaterialAndNormals) {
  TestScene t;
  uint32_t white = t.material(scene::MaterialType::diffuse);
  uint32_t red = t.material(scene::MaterialType::diffuse, {0.8f, 0.1f, 0.1f});
  t.object(quad_mesh({-1, 0, 1}, {2, 0, 0}, {0, 0, -2}), white);
  uint32_t ball =
      t.object(sphere_mesh({0, 0, 0}, 0.25f, 32), red, glm::translate(glm::mat4(1.f), {0, 1, 0}));
  EmbreeScene world(t.scene, t.state);
  Hit hit;
  ASSERT_TRUE(world.intersect({0, 3, 0}, {0, -1, 0}, 100.f, hit));
  EXPECT_EQ(hit.object, ball);
  EXPECT_EQ(hit.material, red);
  EXPECT_NEAR(hit.t, 1.75f, 2e-3f);
  EXPECT_NEAR(hit.shading_normal.y, 1.f, 1e-3f);
  EXPECT_GT(glm::dot(hit.geometric_normal, hit.shading_normal), 0.f);
  // Moving the instance moves the hit; the plane below is found where the ball was.
  scene::FrameState moved = t.state;
  moved.object_to_world[ball] = glm::translate(glm::mat4(1.f), {0.6f, 1, 0});
  world.update(moved);
  ASSERT_TRUE(world.intersect({0, 3, 0}, {0, -1, 0}, 100.f, hit));
  EXPECT_EQ(hit.object, 0u);
  EXPECT_NEAR(hit.t, 3.f, 1e-4f);
  EXPECT_TRUE(world.occluded({0.6f, 3, 0}, {0, -1, 0}, 10.f));
  EXPECT_FALSE(world.occluded({0.6f, 3, 0}, {0, -1, 0}, 1.5f));
  Aabb b = world.object_bounds(ball);
  EXPECT_NEAR(b.lo.x, 0.35f, 1e-3f);
  EXPECT_NEAR(b.hi.y, 1.25f, 1e-3f);
}

// The geometric and shading normals of a hit from the world-space triangle (what the hit record's
// stored per-triangle normals must reproduce): the edges' cross product, turned to the side of the
// interpolated vertex normals where the mesh has them, which are then the shading normal.
void expected_normals(const EmbreeScene& world, const Hit& hit, bool vertex_normals, glm::vec3& ng,
                      glm::vec3& ns) {
  Triangle tri = world.triangle(hit.object, hit.primitive);
  ng = glm::normalize(glm::cross(tri.p[1] - tri.p[0], tri.p[2] - tri.p[0]));
  ns = ng;
  if (!vertex_normals) return;
  float u = hit.barycentric.x, v = hit.barycentric.y;
  ns = glm::normalize((1 - u - v) * tri.n[0] + u * tri.n[1] + v * tri.n[2]);
  if (glm::dot(ng, ns) < 0) ng = -ng;
}

// A stream (intersect_stream, coherent or not) hits what single rays hit, ray for ray, across its
// chunks of 64, and occluded_stream answers as occluded does for rays of any length; and the
// hit's normals, read from per-triangle data stored at build, equal those computed from
// the triangle, on flattened and on instanced objects, under a mirroring transform (which turns
// the winding), for flat and smooth triangles, and for a quad whose vertex normals face against
// its winding.
TEST(EmbreeScene, StreamsAndStoredNormalsMatchSingleRaysAndTheTriangles) {
  TestScene t;
  uint32_t white = t.material(scene::MaterialType::diffuse);
  scene::Mesh bare = quad_mesh({-1, 0, 1}, {2, 0, 0}, {0, 0, -2});  // faces -y by its winding
  bare.normals.clear();
  scene::Mesh against = quad_mesh({-1, 0, -1}, {0, 0, 2}, {0, 2, 0});  // winding faces +x...
  for (auto& n : against.normals) n = -n;                              // ...its normals -x
  glm::mat4 mirror =
      glm::scale(glm::rotate(glm::mat4(1.f), 0.3f, glm::vec3(0, 1, 0)), glm::vec3(-1.f, 1.f, 1.f));
  t.object(bare, white);
  t.object(against, white, glm::translate(glm::mat4(1.f), {0.2f, 0, 0}) * mirror);
  t.object(sphere_mesh({0, 0.5f, 0}, 0.3f, 16), white, mirror);
  t.object(bare, white, glm::translate(glm::mat4(1.f), {0, 1.5f, 0}) * mirror);
  t.scene.objects[2].transform.spin_deg_per_s = {0, 30, 0};  // moves: flattened by flatten_moving
  ASSERT_TRUE(t.scene.objects[2].transform.animated());
  const std::vector<bool> has_normals = {false, true, true, false};
  const glm::vec3 eye{0.3f, 0.6f, 2.5f};
  std::vector<glm::vec3> dirs;
  for (int y = 0; y < 11; ++y)
    for (int x = 0; x < 13; ++x)  // 143 rays: two full chunks and a part
      dirs.push_back(glm::normalize(glm::vec3(-1.2f + 0.2f * x, -0.9f + 0.25f * y, -2.5f)));
  for (int flatten : {0, 1, 2}) {  // nothing, the static objects, every rigid object
    EmbreeOptions options;
    options.flatten_static = flatten >= 1;
    options.flatten_moving = flatten == 2;
    EmbreeScene world(t.scene, t.state, options);
    std::vector<Ray> rays;
    for (const glm::vec3& d : dirs) rays.push_back(Ray{eye, d});
    std::vector<Hit> hits(dirs.size());
    std::vector<uint8_t> found(dirs.size());
    world.intersect_stream(rays, hits, found, /*coherent=*/flatten != 1);
    // Shadow rays of every length from points spread over the view back towards the eye's side;
    // the odd ones stop halfway to the first surface along their direction.
    std::vector<Ray> shadows;
    for (size_t i = 0; i < dirs.size(); ++i) {
      glm::vec3 from = eye + 2.5f * dirs[i];
      glm::vec3 d = glm::normalize(glm::vec3(0.1f * float(i % 7) - 0.3f, 0.8f, 0.4f));
      shadows.push_back(Ray{from, d, i % 2 ? 0.05f * float(i % 13) : kUnboundedRay});
    }
    std::vector<uint8_t> blocked(shadows.size());
    world.occluded_stream(shadows, blocked, /*coherent=*/flatten == 1);
    int blocked_count = 0;
    for (size_t i = 0; i < shadows.size(); ++i) {
      EXPECT_EQ(bool(blocked[i]),
                world.occluded(shadows[i].origin, shadows[i].dir, shadows[i].tmax))
          << "flatten " << flatten << ", shadow ray " << i;
      blocked_count += blocked[i];
    }
    EXPECT_GT(blocked_count, 5);
    EXPECT_LT(blocked_count, int(shadows.size()) - 5);
    int hit_count = 0;
    for (size_t i = 0; i < dirs.size(); ++i) {
      SCOPED_TRACE(::testing::Message() << "flatten " << flatten << ", ray " << i);
      Hit single;
      bool single_found = world.intersect(eye, dirs[i], kUnboundedRay, single);
      ASSERT_EQ(bool(found[i]), single_found);
      if (!single_found) continue;
      ++hit_count;
      const Hit& h = hits[i];
      EXPECT_EQ(h.object, single.object);
      EXPECT_EQ(h.primitive, single.primitive);
      EXPECT_NEAR(h.t, single.t, 1e-5f);
      EXPECT_LT(glm::length(h.position - single.position), 1e-5f);
      glm::vec3 ng, ns;
      expected_normals(world, h, has_normals[h.object], ng, ns);
      EXPECT_LT(glm::length(h.geometric_normal - ng), 1e-4f);
      EXPECT_LT(glm::length(h.shading_normal - ns), 1e-4f);
      EXPECT_LT(glm::length(single.geometric_normal - ng), 1e-4f);
    }
    EXPECT_GT(hit_count, 60);
  }
}

// ---- power bookkeeping
// ---------------------------------------------------------------------------

TraceSettings direct_only(uint32_t paths) {
  TraceSettings s;
  s.paths = paths;
  s.store = kDirectPhotons;
  s.max_bounces = 1;
  s.seed_per_frame = false;
  return s;
}

// Point light 1 m above the centre of a 2 m square: the square subtends 4 asin(1/2) = 2 pi / 3 sr,
// so the first hits receive I 2 pi / 3 (Van Oosterom & Strackee's rectangle formula).
TEST(PhotonTracer, PointLightFirstHitPowerIsIntensityTimesSolidAngle) {
  TestScene t;
  t.object(quad_mesh({-1, 0, 1}, {2, 0, 0}, {0, 0, -2}), t.material(scene::MaterialType::diffuse));
  t.light(point_light({0, 1, 0}, 3.f));
  EmbreeScene world(t.scene, t.state);
  EmbreePhotonTracer tracer(world);
  PhotonBatch batch;
  TraceStats stats = tracer.trace(direct_only(200000), batch);
  double expected = 3.0 * 2.0 * M_PI / 3.0;
  glm::dvec3 got = total_power(batch.photons);
  EXPECT_NEAR(got.x / expected, 1.0, 0.005);
  EXPECT_NEAR(got.z / expected, 1.0, 0.005);
  EXPECT_NEAR(double(stats.photons) / stats.paths, (2.0 * M_PI / 3.0) / (4.0 * M_PI), 0.005 / 6);
  EXPECT_EQ(stats.rays, stats.paths);
  for (const auto& p : batch.photons) {
    EXPECT_EQ(p.bounce, 0u);
    EXPECT_EQ(photon_kind(p), kDirectPhotons);
  }
}

// Every other light type inside a closed box: all of its power reaches the walls at the first hit.
TEST(PhotonTracer, EveryLightTypeDeliversItsPowerToAnEnclosure) {
  auto run = [](auto add_light, double expected) {
    TestScene t;
    t.object(box_mesh({-1, -1, -1}, {1, 1, 1}, true), t.material(scene::MaterialType::diffuse));
    add_light(t);
    EmbreeScene world(t.scene, t.state);
    EmbreePhotonTracer tracer(world);
    PhotonBatch batch;
    tracer.trace(direct_only(100000), batch);
    EXPECT_NEAR(total_power(batch.photons).y / expected, 1.0, 0.005);
    EXPECT_NEAR(tracer.light_power(0).y / expected, 1.0, 1e-5);
  };
  scene::Light spot;
  spot.type = scene::LightType::spot;
  spot.position = {0, 0.5f, 0};
  spot.direction = {0, -1, 0};
  spot.radiant = glm::vec3(2.f);
  spot.spot_inner = glm::radians(20.f);
  spot.spot_outer = glm::radians(35.f);
  double ci = std::cos(glm::radians(20.0)), co = std::cos(glm::radians(35.0));
  run([&](TestScene& t) { t.light(spot); }, 2.0 * 2 * M_PI * ((1 - ci) + 0.5 * (ci - co)));
  scene::Light quad;
  quad.type = scene::LightType::quad;
  quad.position = {-0.2f, 0.9f, -0.1f};
  quad.edge_u = {0, 0, 0.3f};  // cross(edge_u, edge_v) points down
  quad.edge_v = {0.4f, 0, 0};
  quad.radiant = glm::vec3(5.f);
  run([&](TestScene& t) { t.light(quad); }, M_PI * 5.0 * 0.12);
  run(
      [](TestScene& t) {
        uint32_t m = t.material(scene::MaterialType::emissive, glm::vec3(0.f));
        t.scene.materials[m].emission = glm::vec3(4.f);
        t.object(quad_mesh({-0.25f, 0, -0.25f}, {0.5f, 0, 0}, {0, 0, 0.5f}), m);  // faces -y
      },
      M_PI * 4.0 * 0.25);
}

// Emitters of several radiances and areas (a mesh of many triangles among them) and a point light
// inside a closed box: the tracer's lights carry pi A L per emissive object and 4 pi I, and the
// first hits on the walls receive all of it.
TEST(PhotonTracer, EmissiveTrianglesEmitTheirTotalPower) {
  TestScene t;
  t.object(box_mesh({-1, -1, -1}, {1, 1, 1}, true), t.material(scene::MaterialType::diffuse));
  t.object(quad_mesh({-0.2f, 0.9f, -0.1f}, {0, 0, 0.3f}, {0.4f, 0, 0}),
           t.material(scene::MaterialType::emissive, glm::vec3(0.f), glm::vec3(5.f)));
  t.object(sphere_mesh({0.3f, -0.4f, 0.2f}, 0.15f, 12),
           t.material(scene::MaterialType::emissive, glm::vec3(0.f), glm::vec3(2.f)));
  t.point_light({0, 0, -0.5f}, 0.3f);
  double expected = 4 * M_PI * 0.3;
  for (const auto& e : scene::emissive_triangles(t.scene, t.state)) expected += e.flux.y;
  EXPECT_GT(scene::emissive_triangles(t.scene, t.state).size(), 100u);
  EmbreeScene world(t.scene, t.state);
  EmbreePhotonTracer tracer(world);
  ASSERT_EQ(tracer.light_count(), 3u);
  double lights = 0;
  for (uint32_t l = 0; l < 3; ++l) lights += tracer.light_power(l).y;
  EXPECT_NEAR(lights / expected, 1.0, 1e-5);
  PhotonBatch batch;
  tracer.trace(direct_only(200000), batch);
  EXPECT_NEAR(total_power(batch.photons).y / expected, 1.0, 0.005);
}

TEST(PhotonTracer, DirectionalLightCoversTheSceneAndDeliversIrradianceTimesArea) {
  TestScene t;
  t.object(quad_mesh({-1, 0, 1}, {2, 0, 0}, {0, 0, -2}), t.material(scene::MaterialType::diffuse));
  scene::Light sun;
  sun.type = scene::LightType::directional;
  sun.direction = glm::normalize(glm::vec3(0.3f, -1, 0.2f));
  sun.radiant = glm::vec3(2.f);
  t.light(sun);
  EmbreeScene world(t.scene, t.state);
  EmbreePhotonTracer tracer(world);
  PhotonBatch batch;
  tracer.trace(direct_only(100000), batch);
  double expected = 2.0 * 4.0 * std::abs(sun.direction.y);  // E A cos(theta)
  EXPECT_NEAR(total_power(batch.photons).x / expected, 1.0, 0.005);
}

// Photon emission needs no light BVH (Papers III-IV sample lights for shading points; a photon
// cannot depend on one): the tracer shares its paths among the lights by power. Over 10^4 point
// lights in four power classes spanning 100x (lamp-hall's), each light's emitted paths follow its
// share (chi-square against N * Phi_i / sum Phi) and its direct photons carry exactly its power.
TEST(PhotonTracer, PathsPerLightFollowPowerOverTenThousandLights) {
  TestScene t;
  t.object(box_mesh({-1, -1, -1}, {1, 1, 1}, true),
           t.material(scene::MaterialType::diffuse, glm::vec3(0.6f)));
  const float classes[] = {0.01f, 0.1f, 0.3f, 1.f};
  std::vector<float> power;
  uint32_t state = 12345u;
  auto next = [&state] {  // a fixed LCG: the same lights on every platform
    state = state * 1664525u + 1013904223u;
    return state;
  };
  const size_t lights = 10000;
  for (size_t i = 0; i < lights; ++i) {
    glm::vec3 p;
    for (int a = 0; a < 3; ++a) p[a] = -0.9f + 1.8f * float(next() >> 8) / float(1u << 24);
    power.push_back(classes[(next() >> 16) % 4]);
    t.light(point_light(p, power.back()));
  }
  EmbreeScene world(t.scene, t.state);
  EmbreePhotonTracer tracer(world);
  const uint32_t paths = 1000000;
  TraceSettings s = direct_only(paths);
  s.keep_light_paths = true;
  PhotonBatch batch;
  tracer.trace(s, batch);
  const std::vector<uint32_t>& emitted = batch.paths.paths_per_light;
  ASSERT_EQ(emitted.size(), lights);
  const double total = std::accumulate(power.begin(), power.end(), 0.0);
  double chi2 = 0;
  for (size_t i = 0; i < lights; ++i) {
    const double expected = paths * power[i] / total;
    chi2 += (emitted[i] - expected) * (emitted[i] - expected) / expected;
  }
  // chi-square with lights - 1 degrees of freedom: mean 9999, sd 141; 4.75 sd is p ~ 1e-6.
  const double dof = double(lights - 1);
  EXPECT_LT(chi2, dof + 4.75 * std::sqrt(2 * dof)) << "paths per light do not follow power";
  std::vector<double> carried(lights, 0.0);
  for (const PhotonRecord& p : batch.photons) carried[p.light] += p.power.x;
  for (size_t i = 0; i < lights; ++i)
    ASSERT_NEAR(carried[i] / (4 * glm::pi<double>() * power[i]), 1.0, 1e-4) << "light " << i;
  std::printf("10^4 lights, 10^6 paths: chi-square %.1f on %.0f degrees of freedom\n", chi2, dof);
}

TEST(PhotonTracer, PathsAreSplitByPowerAndPhotonTargetKeepsPowerUnbiased) {
  EXPECT_EQ(EmbreePhotonTracer::split_paths({1.f, 3.f}, 1000), (std::vector<uint32_t>{250, 750}));
  EXPECT_EQ(EmbreePhotonTracer::split_paths({1.f, 0.f, 1000.f}, 10),
            (std::vector<uint32_t>{1, 0, 9}));
  TestScene t;
  t.object(box_mesh({-1, -1, -1}, {1, 1, 1}, true),
           t.material(scene::MaterialType::diffuse, glm::vec3(0.6f)));
  t.light(point_light({0.3f, 0.2f, 0}, 1.f));
  t.light(point_light({-0.3f, 0.2f, 0}, 3.f));
  EmbreeScene world(t.scene, t.state);
  EmbreePhotonTracer tracer(world);
  TraceSettings s;
  s.paths = 5000;
  s.photon_target = 60000;
  s.store = kAllPhotons;
  s.seed_per_frame = false;
  PhotonBatch batch;
  TraceStats stats = tracer.trace(s, batch);
  EXPECT_GE(stats.photons, 60000u);
  EXPECT_LT(stats.photons, 70000u);
  // Direct photons alone must carry all of both lights' power, whatever the number of waves.
  glm::dvec3 direct(0.0);
  for (const auto& p : batch.photons)
    if (p.bounce == 0) direct += glm::dvec3(p.power);
  EXPECT_NEAR(direct.x / (4 * M_PI * 4.0), 1.0, 0.005);
  // Light 1 has 3x the power, so about 3x the paths.
  size_t first_hits[2] = {0, 0};
  for (const auto& p : batch.photons)
    if (p.bounce == 0) ++first_hits[p.light];
  EXPECT_NEAR(double(first_hits[1]) / first_hits[0], 3.0, 0.01);
}

// Rough interreflection bookkeeping: in a closed box of albedo a, the expected power stored at
// interaction k is Phi a^k (each bounce keeps a fraction a, Russian roulette keeps the
// expectation).
TEST(PhotonTracer, RussianRouletteKeepsExpectedPowerPerBounce) {
  TestScene t;
  t.object(box_mesh({-1, -1, -1}, {1, 1, 1}, true),
           t.material(scene::MaterialType::diffuse, glm::vec3(0.5f)));
  t.light(point_light({0, 0, 0}, 1.f));
  EmbreeScene world(t.scene, t.state);
  EmbreePhotonTracer tracer(world);
  TraceSettings s;
  s.paths = 200000;
  s.store = kAllPhotons;
  s.max_bounces = 6;
  s.seed_per_frame = false;
  PhotonBatch batch;
  tracer.trace(s, batch);
  double per_bounce[6] = {};
  for (const auto& p : batch.photons) per_bounce[p.bounce] += p.power.x;
  double phi = 4 * M_PI;
  for (int k = 0; k < 4; ++k)
    EXPECT_NEAR(per_bounce[k] / (phi * std::pow(0.5, k)), 1.0, 0.02) << "bounce " << k;
}

// A smooth glass slab at normal incidence transmits T = (1 - R) / (1 + R) of the light once every
// internal reflection is summed, with R = ((n - 1) / (n + 1))^2 (Fresnel at normal incidence).
TEST(PhotonTracer, SmoothDielectricSlabTransmitsTheFresnelSeriesSum) {
  TestScene t;
  t.object(quad_mesh({-4, 0, 4}, {8, 0, 0}, {0, 0, -8}), t.material(scene::MaterialType::diffuse));
  uint32_t glass = t.material(scene::MaterialType::dielectric);
  t.scene.materials[glass].ior = 1.5f;
  t.object(box_mesh({-1, 0.5f, -1}, {1, 0.7f, 1}, false), glass);
  scene::Light sun;
  sun.type = scene::LightType::directional;
  sun.direction = {0, -1, 0};
  sun.radiant = glm::vec3(1.f);
  t.light(sun);
  EmbreeScene world(t.scene, t.state);
  EmbreePhotonTracer tracer(world);
  TraceSettings s;
  s.paths = 400000;
  s.store = kCausticPhotons;
  s.max_bounces = 12;
  s.seed_per_frame = false;
  PhotonBatch batch;
  tracer.trace(s, batch);
  double r = std::pow(0.5 / 2.5, 2.0), transmit = (1 - r) / (1 + r);
  EXPECT_NEAR(total_power(batch.photons).x / (4.0 * transmit), 1.0, 0.01);
  EXPECT_NEAR(fresnel_dielectric(1.f, 1.5f), r, 1e-6);
  EXPECT_NEAR(fresnel_dielectric(-1.f, 1.5f), r, 1e-6);
  EXPECT_EQ(fresnel_dielectric(-0.5f, 1.5f), 1.f);  // beyond the critical angle inside the glass
}

// ---- footprints
// ----------------------------------------------------------------------------------

// N photons of a point light share the sphere equally, 4 pi / N sr each, so on a plane at distance
// r and incidence theta a photon covers 4 pi r^2 / (N cos theta). Through a flat mirror the same
// holds with r the unfolded path length (the mirror image of the light).
TEST(PhotonTracer, FootprintMatchesTheAreaPerPhotonDirectAndThroughAMirror) {
  TestScene t;
  t.object(quad_mesh({-3, 2, -3}, {6, 0, 0}, {0, 0, 6}),
           t.material(scene::MaterialType::diffuse));  // ceiling
  uint32_t mirror = t.material(scene::MaterialType::mirror);
  t.object(quad_mesh({-9, 0, 9}, {18, 0, 0}, {0, 0, -18}), mirror);
  t.light(point_light({0, 1, 0}, 1.f));
  EmbreeScene world(t.scene, t.state);
  EmbreePhotonTracer tracer(world);
  TraceSettings s;
  s.paths = 20000;
  s.store = kDirectPhotons | kCausticPhotons;
  s.max_bounces = 2;
  s.rr_start = 5;
  s.seed_per_frame = false;
  s.footprints = true;
  PhotonBatch batch;
  tracer.trace(s, batch);
  int checked[2] = {0, 0};
  for (const auto& p : batch.photons) {
    glm::vec3 source = p.bounce == 0 ? glm::vec3(0, 1, 0) : glm::vec3(0, -1, 0);
    glm::vec3 d = p.position - source;
    float r2 = glm::dot(d, d);
    float cos_t = std::abs(d.y) / std::sqrt(r2);
    if (cos_t < 0.3f) continue;  // grazing: the linearisation over one spacing is poor
    double expected = 4 * M_PI * r2 / (s.paths * cos_t);
    double got = glm::length(glm::cross(p.footprint_u, p.footprint_v));
    ASSERT_NEAR(got / expected, 1.0, 0.03) << "bounce " << p.bounce;
    ++checked[p.bounce];
  }
  EXPECT_GT(checked[0], 1000);
  EXPECT_GT(checked[1], 1000);
}

// A glass ball focuses the light: behind it the caustic photons are denser, so their footprints
// must be smaller than a direct photon's at the same place (the normal's curvature enters the
// differentials).
TEST(PhotonTracer, CausticFootprintsShrinkBehindAFocusingBall) {
  TestScene t;
  t.object(quad_mesh({-3, 0, 3}, {6, 0, 0}, {0, 0, -6}), t.material(scene::MaterialType::diffuse));
  uint32_t glass = t.material(scene::MaterialType::dielectric);
  t.object(sphere_mesh({0, 1.2f, 0}, 0.4f, 96), glass);
  t.light(point_light({0, 3, 0}, 1.f));
  EmbreeScene world(t.scene, t.state);
  EmbreePhotonTracer tracer(world);
  TraceSettings s;
  s.paths = 200000;
  s.store = kCausticPhotons;
  s.seed_per_frame = false;
  s.footprints = true;
  PhotonBatch batch;
  tracer.trace(s, batch);
  double direct_area = 4 * M_PI * 9.0 / s.paths;  // straight below the light, unobstructed
  int near_axis = 0;
  double mean_area = 0;
  for (const auto& p : batch.photons) {
    // Refracted in and out (S S D); singly reflected photons land elsewhere.
    if (glm::length(glm::vec2(p.position.x, p.position.z)) > 0.05f || p.bounce != 2 ||
        p.specular_mask != 3u)
      continue;
    ++near_axis;
    mean_area += glm::length(glm::cross(p.footprint_u, p.footprint_v));
  }
  ASSERT_GT(near_axis, 50);
  mean_area /= near_axis;
  // Density of photons near the axis relative to the unobstructed density, as the footprint
  // predicts.
  double density_ratio = (near_axis / (M_PI * 0.05 * 0.05)) / (1.0 / direct_area);
  EXPECT_LT(mean_area, direct_area * 0.5);
  EXPECT_NEAR(direct_area / mean_area / density_ratio, 1.0, 0.35);
}

// Footprints are the trace's only output that depends on the differentials: without them every
// other field of every photon keeps its bits (the same paths, powers and decisions), and the
// footprints are zero; with them, every photon has one.
TEST(PhotonTracer, FootprintsOffChangeNothingButTheFootprints) {
  TestScene t;
  uint32_t white = t.material(scene::MaterialType::diffuse, glm::vec3(0.7f));
  t.object(box_mesh({-2, 0, -2}, {2, 3, 2}, true), white);
  t.object(sphere_mesh({0.6f, 0.5f, 0}, 0.35f, 32), t.material(scene::MaterialType::dielectric));
  t.object(quad_mesh({-1.9f, 0.2f, -1}, {0, 0, 2}, {0, 1.5f, 0}),
           t.material(scene::MaterialType::mirror));
  t.light(point_light({0, 2.5f, 0}, 1.f));
  EmbreeScene world(t.scene, t.state);
  EmbreePhotonTracer tracer(world);
  TraceSettings s;
  s.paths = 20000;
  s.store = kAllPhotons;
  s.seed_per_frame = false;
  PhotonBatch with, without;
  s.footprints = true;
  tracer.trace(s, with);
  s.footprints = false;
  tracer.trace(s, without);
  ASSERT_EQ(with.photons.size(), without.photons.size());
  ASSERT_GT(with.photons.size(), 10000u);
  uint32_t caustic = 0, with_area = 0;
  for (size_t i = 0; i < with.photons.size(); ++i) {
    PhotonRecord a = with.photons[i], b = without.photons[i];
    with_area += glm::length(glm::cross(a.footprint_u, a.footprint_v)) > 0;
    ASSERT_EQ(b.footprint_u, glm::vec3(0.f)) << "photon " << i;
    ASSERT_EQ(b.footprint_v, glm::vec3(0.f)) << "photon " << i;
    a.footprint_u = a.footprint_v = glm::vec3(0.f);
    ASSERT_EQ(std::memcmp(&a, &b, sizeof a), 0) << "photon " << i;
    caustic += (a.specular_mask & 1u) != 0;
  }
  EXPECT_EQ(with_area, with.photons.size());
  EXPECT_GT(caustic, 100u);  // paths through the glass and off the mirror are among them
  EXPECT_EQ(with.stats.rays, without.stats.rays);
}

// A trace that stores a few more photons than the last keeps the batch's memory: moving a batch
// of a million photons to fresh pages cost twice the trace itself.
TEST(PhotonTracer, ABatchThatGrowsALittleKeepsItsMemory) {
  TestScene t;
  t.object(box_mesh({-2, 0, -2}, {2, 3, 2}, true),
           t.material(scene::MaterialType::diffuse, glm::vec3(0.7f)));
  t.light(point_light({0, 2.5f, 0}, 1.f));
  EmbreeScene world(t.scene, t.state);
  EmbreePhotonTracer tracer(world);
  TraceSettings s;
  s.paths = 20000;
  s.store = kAllPhotons;
  PhotonBatch batch;
  tracer.trace(s, batch);
  const size_t first = batch.photons.size();
  const PhotonRecord* memory = batch.photons.data();
  s.paths = 21000;  // 5% more paths, about 5% more photons
  tracer.trace(s, batch);
  ASSERT_GT(batch.photons.size(), first);
  EXPECT_EQ(batch.photons.data(), memory);
}

// ---- path re-validation
// --------------------------------------------------------------------------

TEST(PhotonTracer, RetraceInvalidKeepsValidPathsAndMatchesAFreshTrace) {
  TestScene t;
  uint32_t white = t.material(scene::MaterialType::diffuse, glm::vec3(0.7f));
  t.object(box_mesh({-2, 0, -2}, {2, 3, 2}, true), white);
  uint32_t block = t.object(box_mesh({-0.3f, 0, -0.3f}, {0.3f, 0.6f, 0.3f}, false), white,
                            glm::translate(glm::mat4(1.f), {0.8f, 0, 0}));
  t.light(point_light({0, 2.5f, 0}, 1.f));
  EmbreeScene world(t.scene, t.state);
  EmbreePhotonTracer tracer(world);
  TraceSettings s;
  s.paths = 20000;
  s.store = kAllPhotons;
  s.max_bounces = 4;
  s.seed_per_frame = true;  // the frame seed is taken when first traced and kept by the paths
  s.keep_light_paths = true;
  PhotonBatch batch;
  TraceStats first = tracer.trace(s, batch);
  PhotonBatch before = batch;

  // Nothing moved: every path is kept and no segment is re-traced.
  TraceStats same = tracer.retrace_invalid(s, batch);
  EXPECT_EQ(same.paths_retraced, 0u);
  EXPECT_EQ(batch.photons.size(), before.photons.size());

  scene::FrameState next = t.state;
  next.object_to_world[block] = glm::translate(glm::mat4(1.f), {-0.5f, 0, 0.4f});
  world.update(next);
  TraceStats re = tracer.retrace_invalid(s, batch);
  EXPECT_GT(re.paths_retraced, 0u);
  EXPECT_LT(re.paths_retraced, re.paths / 2);
  EXPECT_LT(re.segments_retraced, first.rays / 3);

  // Every re-traced path kept its prefix up to the first segment the block touches, and every kept
  // vertex is bit-identical to the old one.
  const LightPaths& oldp = before.paths;
  const LightPaths& newp = batch.paths;
  ASSERT_EQ(oldp.paths.size(), newp.paths.size());
  size_t changed = 0;
  for (size_t i = 0; i < oldp.paths.size(); ++i) {
    const LightPath &a = oldp.paths[i], &b = newp.paths[i];
    uint32_t same_prefix = 0;
    while (same_prefix < std::min(a.vertex_count, b.vertex_count) &&
           std::memcmp(&oldp.vertices[a.first_vertex + same_prefix],
                       &newp.vertices[b.first_vertex + same_prefix],
                       offsetof(PathVertex, flags)) == 0)
      ++same_prefix;
    if (same_prefix == a.vertex_count && a.vertex_count == b.vertex_count) continue;
    ++changed;
    ASSERT_GE(same_prefix, 1u);  // the light did not move: the emission vertex is kept
    // The first vertex that differs ends a segment that crosses where the block is or was.
    const PathVertex& from = oldp.vertices[a.first_vertex + same_prefix - 1];
    bool touches = false;
    for (glm::vec3 c : {glm::vec3(0.8f, 0, 0), glm::vec3(-0.5f, 0, 0.4f)}) {
      Aabb box;
      box.extend(c + glm::vec3(-0.31f, -0.01f, -0.31f));
      box.extend(c + glm::vec3(0.31f, 0.61f, 0.31f));
      float len =
          same_prefix < a.vertex_count
              ? glm::length(oldp.vertices[a.first_vertex + same_prefix].position - from.position)
              : 100.f;
      touches |= box.intersects(from.position, from.direction, len * 1.001f);
    }
    EXPECT_TRUE(touches) << "path " << i << " changed at vertex " << same_prefix;
  }
  EXPECT_EQ(changed, re.paths_retraced);

  // The result equals a fresh trace of the new frame with the paths' own seed.
  PhotonBatch fresh;
  TraceSettings fs = s;
  fs.seed_per_frame = false;
  fs.seed = hash_combine(s.seed, t.state.frame);
  tracer.trace(fs, fresh);
  ASSERT_EQ(fresh.photons.size(), batch.photons.size());
  for (size_t i = 0; i < fresh.photons.size(); ++i) {
    ASSERT_EQ(fresh.photons[i].path, batch.photons[i].path);
    ASSERT_NEAR(glm::distance(fresh.photons[i].position, batch.photons[i].position), 0.f, 1e-5f);
    ASSERT_NEAR(glm::distance(fresh.photons[i].power, batch.photons[i].power), 0.f, 1e-9f);
  }
}

// A seed axis' tracer (seed_scramble) traces exactly what a plain tracer traces with the scrambled
// seed, so its cells get photons of their own; and it keeps its paths across frames as a plain
// one does (it re-validates them under the same scrambled seed: nothing is re-traced when nothing
// moved).
TEST(PhotonTracer, ASeedScrambleTracesOtherPathsAndKeepsThem) {
  TestScene t;
  uint32_t white = t.material(scene::MaterialType::diffuse, glm::vec3(0.7f));
  t.object(box_mesh({-2, 0, -2}, {2, 3, 2}, true), white);
  t.light(point_light({0, 2.5f, 0}, 1.f));
  EmbreeScene world(t.scene, t.state);
  TraceSettings s;
  s.paths = 2000;
  s.store = kAllPhotons;
  s.max_bounces = 4;
  s.keep_light_paths = true;
  s.seed_per_frame = false;  // the kept paths' seed is then compared with the settings'
  const uint32_t scramble = 77;
  EmbreePhotonTracer plain(world), seeded(world, scramble);
  PhotonBatch a, b, c;
  plain.trace(s, a);
  seeded.trace(s, b);
  TraceSettings scrambled = s;
  scrambled.seed = hash_combine(s.seed, scramble);
  plain.trace(scrambled, c);
  ASSERT_EQ(b.photons.size(), c.photons.size());
  for (size_t i = 0; i < b.photons.size(); ++i)
    ASSERT_EQ(std::memcmp(&b.photons[i], &c.photons[i], sizeof(PhotonRecord)), 0) << i;
  EXPECT_NE(a.photons.front().position, b.photons.front().position);
  TraceStats again = seeded.retrace_invalid(s, b);
  EXPECT_EQ(again.paths_kept, s.paths);  // a fresh trace would keep none
  EXPECT_EQ(again.paths_retraced, 0u);
  EXPECT_EQ(b.photons.size(), c.photons.size());
}

TEST(PhotonTracer, RetraceInvalidRetracesWholePathsOfAMovedLight) {
  TestScene t;
  t.object(box_mesh({-2, 0, -2}, {2, 3, 2}, true),
           t.material(scene::MaterialType::diffuse, glm::vec3(0.5f)));
  t.light(point_light({0, 2.5f, 0}, 1.f));
  t.light(point_light({1, 2.5f, 0}, 1.f));
  EmbreeScene world(t.scene, t.state);
  EmbreePhotonTracer tracer(world);
  TraceSettings s;
  s.paths = 4000;
  s.keep_light_paths = true;
  PhotonBatch batch;
  tracer.trace(s, batch);
  scene::FrameState next = t.state;
  next.lights[1].position.x = 0.5f;
  world.update(next);
  TraceStats re = tracer.retrace_invalid(s, batch);
  EXPECT_EQ(re.paths_retraced, 2000u);  // exactly the moved light's paths
  for (const auto& path : batch.paths.paths)
    if (path.light == 1) EXPECT_EQ(batch.paths.vertices[path.first_vertex].position.x, 0.5f);
}

// ---- determinism
// ---------------------------------------------------------------------------------

TEST(PhotonTracer, DeterministicForAGivenSeedWhateverTheThreadCount) {
  TestScene t;
  t.object(box_mesh({-1, 0, -1}, {1, 2, 1}, true),
           t.material(scene::MaterialType::diffuse, glm::vec3(0.6f)));
  uint32_t glass = t.material(scene::MaterialType::dielectric);
  t.object(sphere_mesh({0, 0.5f, 0}, 0.3f, 32), glass);
  t.light(point_light({0, 1.8f, 0}, 1.f));
  EmbreeScene world(t.scene, t.state);
  EmbreePhotonTracer tracer(world);
  TraceSettings s;
  s.paths = 30000;
  s.store = kAllPhotons;
  PhotonBatch one, two, other_seed;
  tbb::task_arena(1).execute([&] { tracer.trace(s, one); });
  tbb::task_arena(2).execute([&] { tracer.trace(s, two); });
  ASSERT_EQ(one.photons.size(), two.photons.size());
  EXPECT_EQ(std::memcmp(one.photons.data(), two.photons.data(),
                        one.photons.size() * sizeof(PhotonRecord)),
            0);
  // A changing per-frame seed gives other photons, a fixed seed the same ones.
  scene::FrameState next = t.state;
  next.frame = 1;
  world.update(next);
  tracer.trace(s, other_seed);
  EXPECT_NE(other_seed.photons[10].position, one.photons[10].position);
  s.seed_per_frame = false;
  PhotonBatch fixed0, fixed1;
  tracer.trace(s, fixed1);
  world.update(t.state);
  tracer.trace(s, fixed0);
  ASSERT_EQ(fixed0.photons.size(), fixed1.photons.size());
  EXPECT_EQ(std::memcmp(fixed0.photons.data(), fixed1.photons.data(),
                        fixed0.photons.size() * sizeof(PhotonRecord)),
            0);
}

// A batch traced into again keeps its memory from its last trace (no zero fill): what it then
// holds must be exactly what a fresh batch gets, whether the last trace stored more photons or
// fewer, and its kept paths too.
TEST(PhotonTracer, ABatchTracedIntoAgainHoldsWhatAFreshBatchGets) {
  TestScene t;
  t.object(box_mesh({-1, 0, -1}, {1, 2, 1}, true),
           t.material(scene::MaterialType::diffuse, glm::vec3(0.6f)));
  t.object(sphere_mesh({0, 0.5f, 0}, 0.3f, 32), t.material(scene::MaterialType::dielectric));
  t.light(point_light({0, 1.8f, 0}, 1.f));
  EmbreeScene world(t.scene, t.state);
  EmbreePhotonTracer tracer(world);
  auto same = [](const auto& a, const auto& b) {
    using T = typename std::decay_t<decltype(a)>::value_type;
    return a.size() == b.size() &&
           (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
  };
  TraceSettings many, few, kept;
  many.paths = 20000, many.store = kAllPhotons, many.seed = 3;
  few.paths = 5000, few.store = kCausticPhotons, few.seed = 4;
  kept.paths = 8000, kept.keep_light_paths = true, kept.seed = 5;
  PhotonBatch reused;
  for (const TraceSettings* s : {&many, &few, &kept, &many, &kept, &few}) {
    PhotonBatch fresh;
    tracer.trace(*s, reused);
    tracer.trace(*s, fresh);
    ASSERT_GT(fresh.photons.size(), 0u);
    EXPECT_TRUE(same(reused.photons, fresh.photons)) << "store " << s->store;
    EXPECT_TRUE(same(reused.paths.paths, fresh.paths.paths)) << "store " << s->store;
    EXPECT_TRUE(same(reused.paths.vertices, fresh.paths.vertices)) << "store " << s->store;
  }
}

// ---- sampling
// ------------------------------------------------------------------------------------

// Owen-scrambled Sobol pairs are (0, m, 2)-nets: each of the 2^m elementary intervals of every
// shape holds exactly one of the first 2^m points, for both 2D projections of every dimension
// group.
TEST(Sampling, ScrambledSobolPairsAreNets) {
  const int m = 8, n = 1 << m;
  for (uint32_t group : {0u, 1u, 7u}) {
    for (int pair = 0; pair < 2; ++pair) {
      std::vector<glm::vec2> pts;
      for (int i = 0; i < n; ++i) {
        glm::vec4 p = sobol_group(i, group, 1234);
        pts.push_back(pair == 0 ? glm::vec2(p.x, p.y) : glm::vec2(p.z, p.w));
      }
      for (int a = 0; a <= m; ++a) {
        std::vector<int> count(n, 0);
        for (auto p : pts)
          ++count[int(p.x * (1 << a)) * (1 << (m - a)) + int(p.y * (1 << (m - a)))];
        for (int c : count)
          ASSERT_EQ(c, 1) << "group " << group << " pair " << pair << " split " << a;
      }
    }
  }
}

// sobol_group cancels the bit reversals between its Owen scrambles (sampling.h): every value must
// be, bit for bit, the scrambled Sobol point of the definition, for any index and seed.
TEST(Sampling, SobolGroupIsTheScrambledSobolOfItsDefinition) {
  std::mt19937 rng(2024);
  for (int i = 0; i < 200000; ++i) {
    const uint32_t index = i < 1000 ? uint32_t(i) : uint32_t(rng());
    const SobolGroupSeeds seeds = sobol_group_seeds(uint32_t(rng() % 32), uint32_t(rng()));
    const glm::vec4 fast = sobol_group(index, seeds);
    for (int pair = 0; pair < 2; ++pair) {
      const uint32_t shuffled = owen_scramble(index, seeds.pair[pair]);
      for (int d = 0; d < 2; ++d) {
        const float defined =
            u32_to_unit(owen_scramble(sobol_u32(shuffled, d), seeds.digits[pair][d]));
        ASSERT_EQ(fast[2 * pair + d], defined)
            << "index " << index << " dimension " << 2 * pair + d;
      }
    }
  }
}

// Chi-square statistic's upper tail by the Wilson-Hilferty approximation (accurate for dof >= 10).
double chi2_p_value(double chi2, int dof) {
  double z = (std::cbrt(chi2 / dof) - (1 - 2.0 / (9 * dof))) / std::sqrt(2.0 / (9 * dof));
  return 0.5 * std::erfc(z / std::sqrt(2.0));
}

TEST(Sampling, EmissionDensityChiSquare) {
  const int w = 8, h = 6;
  std::vector<float> texels(w * h);
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i)
      texels[j * w + i] = (i == 3 && j == 2) ? 0.f : 1.f + i * j + (i % 3);
  Distribution2D dist(w, h, texels);
  double total = 0;
  for (float x : texels) total += x;
  // Fine histogram (4x4 cells per texel): the position inside a texel must be uniform too.
  const int fw = w * 4, fh = h * 4, samples = 400000;
  std::vector<int> hist(fw * fh, 0);
  Pcg32 rng(7, 3);
  for (int s = 0; s < samples; ++s) {
    float pdf;
    glm::vec2 uv = dist.sample(rng.next_2d(), &pdf);
    int ti = int(uv.x * w), tj = int(uv.y * h);
    ASSERT_NEAR(pdf, texels[tj * w + ti] * w * h / total, 1e-4 * pdf);
    ASSERT_NEAR(dist.pdf(uv), pdf, 1e-6f);
    ++hist[int(uv.y * fh) * fw + int(uv.x * fw)];
  }
  double chi2 = 0;
  int dof = -1;
  for (int j = 0; j < fh; ++j)
    for (int i = 0; i < fw; ++i) {
      double expected = samples * texels[(j / 4) * w + i / 4] / total / 16.0;
      int got = hist[j * fw + i];
      if (expected == 0) {
        EXPECT_EQ(got, 0);
        continue;
      }
      chi2 += (got - expected) * (got - expected) / expected;
      ++dof;
    }
  EXPECT_GT(chi2_p_value(chi2, dof), 0.01) << "chi2 " << chi2 << " dof " << dof;
}

// The tracer emits by the density it was given: a point light's photons, histogrammed over its
// emission domain, follow the texture, and the first-hit power is unchanged (power / pdf).
TEST(PhotonTracer, EmissionFollowsTheDensityTextureAndKeepsPower) {
  TestScene t;
  t.object(box_mesh({-1, -1, -1}, {1, 1, 1}, true), t.material(scene::MaterialType::diffuse));
  t.light(point_light({0, 0, 0}, 1.f));
  EmbreeScene world(t.scene, t.state);
  EmbreePhotonTracer tracer(world);
  EmissionDensity density;
  density.width = 4;
  density.height = 4;
  density.texels = {1, 2, 3, 4, 0.5f, 0, 8, 1, 1, 1, 1, 1, 6, 2, 0.25f, 3};
  tracer.set_emission_density(0, &density);
  TraceSettings s = direct_only(64000);
  s.keep_light_paths = true;
  PhotonBatch batch;
  tracer.trace(s, batch);
  // One texel of 16 has density 0: its sixteenth of the sphere gets no photons, the rest keeps its
  // power.
  EXPECT_NEAR(total_power(batch.photons).x / (4 * M_PI * 15 / 16), 1.0, 0.005);
  std::vector<int> hist(16, 0);
  for (const auto& p : batch.paths.paths)
    ++hist[int(p.emission_uv.y * 4) * 4 + int(p.emission_uv.x * 4)];
  double total = 0;
  for (float x : density.texels) total += x;
  double chi2 = 0;
  int dof = -1;
  for (int c = 0; c < 16; ++c) {
    double expected = s.paths * density.texels[c] / total;
    if (expected == 0) {
      EXPECT_EQ(hist[c], 0);
      continue;
    }
    chi2 += (hist[c] - expected) * (hist[c] - expected) / expected;
    ++dof;
  }
  EXPECT_GT(chi2_p_value(chi2, dof), 0.01) << "chi2 " << chi2;
  tracer.set_emission_density(0, nullptr);
}

// ---- BSDFs
// ----------------------------------------------------------------------------------------

Hit flat_hit() {
  Hit h;
  h.geometric_normal = h.shading_normal = {0, 0, 1};
  return h;
}

// sample() must agree with eval() / pdf() wherever a lobe is not a delta: weight = f cos / pdf.
TEST(Bsdf, SamplingAgreesWithEvalAndPdf) {
  Pcg32 rng(3, 1);
  for (auto type : {scene::MaterialType::diffuse, scene::MaterialType::rough_conductor,
                    scene::MaterialType::rough_dielectric}) {
    for (float alpha : {0.05f, 0.3f, 0.8f}) {
      scene::Material m;
      m.type = type;
      m.roughness = alpha;
      m.ior = 1.5f;
      m.specular = glm::vec3(0.9f, 0.6f, 0.3f);
      Bsdf bsdf(m, flat_hit());
      for (int k = 0; k < 2000; ++k) {
        glm::vec3 wo = sphere_from_unit(rng.next_2d());
        if (type != scene::MaterialType::rough_dielectric && wo.z < 0) wo.z = -wo.z;
        if (std::abs(wo.z) < 0.05f) continue;
        for (Transport mode : {Transport::radiance, Transport::importance}) {
          BsdfSample s;
          glm::vec3 u{rng.next_float(), rng.next_float(), rng.next_float()};
          if (!bsdf.sample(wo, u, mode, s)) continue;
          ASSERT_FALSE(s.delta);
          float pdf = bsdf.pdf(wo, s.wi);
          ASSERT_NEAR(pdf / s.pdf, 1.f, 2e-3f);
          glm::vec3 expected = bsdf.eval(wo, s.wi, mode) / pdf;
          ASSERT_NEAR(s.weight.x, expected.x, 2e-3f * std::max(1.f, expected.x));
        }
      }
    }
  }
}

// Directional albedo by Monte Carlo sampling must equal the quadrature of eval() over the sphere
// (the sampler draws from the distribution eval/pdf describe), and the pdf must integrate to the
// fraction of samples that succeed (a reflection below the horizon is a failed sample:
// single-scattering GGX loses that energy, which grows with roughness: Heitz 2016). A smooth-ish
// conductor with F0 = 1 keeps almost all; a rough dielectric's reflection plus transmission stays
// at or below 1.
TEST(Bsdf, GgxEnergyMatchesQuadratureAndPdfNormalises) {
  Pcg32 rng(11, 2);
  struct Moments {
    double albedo, success;
  };
  auto sampled = [&](const scene::Material& m, glm::vec3 wo) {
    Bsdf bsdf(m, flat_hit());
    double acc = 0, ok = 0;
    const int n = 200000;
    for (int k = 0; k < n; ++k) {
      BsdfSample s;
      if (bsdf.sample(wo, {rng.next_float(), rng.next_float(), rng.next_float()},
                      Transport::importance, s))
        acc += s.weight.x, ok += 1;
    }
    return Moments{acc / n, ok / n};
  };
  auto quadrature = [](const scene::Material& m, glm::vec3 wo) {
    Bsdf bsdf(m, flat_hit());
    const int n = 1200;
    double e = 0, p = 0;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        // Poles of the grid along +-y, away from every lobe of the directions tested (a lobe on a
        // pole of the equal-area grid is resolved poorly).
        glm::vec3 v = sphere_from_unit({(i + 0.5f) / n, (j + 0.5f) / n});
        glm::vec3 wi{v.y, v.z, v.x};
        e += bsdf.eval(wo, wi, Transport::importance).x;
        p += bsdf.pdf(wo, wi);
      }
    double dw = 4 * M_PI / (double(n) * n);
    return Moments{e * dw, p * dw};
  };
  scene::Material metal;
  metal.type = scene::MaterialType::rough_conductor;
  metal.specular = glm::vec3(1.f);
  metal.roughness = 0.05f;
  glm::vec3 normal_incidence{0, 0, 1}, oblique = glm::normalize(glm::vec3(0.6f, 0, 0.8f));
  EXPECT_NEAR(sampled(metal, normal_incidence).albedo, 1.0, 0.005);
  scene::Material glass;
  glass.type = scene::MaterialType::rough_dielectric;
  glass.ior = 1.5f;
  for (float alpha : {0.1f, 0.4f}) {
    metal.roughness = glass.roughness = alpha;
    for (const scene::Material* m : {&metal, &glass})
      for (glm::vec3 wo : {oblique, glm::vec3(0, 0, -1)}) {
        if (m == &metal && wo.z < 0) continue;
        Moments s = sampled(*m, wo), q = quadrature(*m, wo);
        EXPECT_NEAR(s.albedo / q.albedo, 1.0, 0.01) << "alpha " << alpha << " wo.z " << wo.z;
        EXPECT_NEAR(s.success, q.success, 0.01) << "alpha " << alpha << " wo.z " << wo.z;
        EXPECT_LE(s.albedo, 1.0 + 1e-3);
      }
  }
  glass.roughness = 0.1f;
  EXPECT_GT(sampled(glass, normal_incidence).albedo, 0.97);
  EXPECT_GT(sampled(glass, glm::vec3(0, 0, -1)).albedo, 0.97);
}

}  // namespace trace_test
}  // namespace pb::trace
