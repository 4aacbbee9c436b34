// Selective photon emission (photonbench/toolkit/selective_emission.h, seed 001 Ch. 9): the groups
// are Halton cells, a static scene invalidates nothing and probes each photon once per group_size
// updates, a moved object invalidates the groups whose probes it changes and the re-traced groups
// equal a fresh trace of the same emission points, a moving light invalidates all its groups, the
// per-surface ledger equals a recomputation from the kept photons bit for bit, and bad settings
// are refused by key.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <numeric>
#include <random>
#include <string>

#include "photonbench/error.h"
#include "photonbench/toolkit/selective_emission.h"
#include "test_scenes.h"
#include "trace/embree_scene.h"
#include "trace/photon_tracer.h"

namespace pb::toolkit {
namespace {

using trace::test_scenes::box_mesh;
using trace::test_scenes::TestScene;

// A 4 x 3 x 4 m room with a 1.6 x 0.6 x 1.6 m block on the floor under a point light.
struct Room {
  TestScene t;
  uint32_t block = 0;
  Room() {
    const uint32_t white = t.material(scene::MaterialType::diffuse, glm::vec3(0.7f));
    t.object(box_mesh({-2, 0, -2}, {2, 3, 2}, true), white);
    block = t.object(box_mesh({-0.8f, 0, -0.8f}, {0.8f, 0.6f, 0.8f}, false), white,
                     glm::translate(glm::mat4(1.f), {0.8f, 0, 0}));
    t.point_light({0, 2.5f, 0}, 1.f);
  }
};

SelectiveEmissionSettings room_settings() {
  SelectiveEmissionSettings s;
  s.trace.store = trace::kAllPhotons;
  s.trace.max_bounces = 4;
  return s;
}

// The ledger's sums recomputed from scratch over `photons` at the same scale.
std::vector<glm::i64vec3> recomputed(const SurfaceEnergyLedger& like,
                                     const std::vector<trace::PhotonRecord>& photons) {
  SurfaceEnergyLedger fresh({}, like.units_per_watt());
  for (const auto& p : photons) fresh.add(p);
  std::vector<glm::i64vec3> u(fresh.units().begin(), fresh.units().end());
  return u;
}
std::vector<glm::i64vec3> padded(std::span<const glm::i64vec3> units, size_t n) {
  std::vector<glm::i64vec3> u(units.begin(), units.end());
  u.resize(std::max(n, u.size()), glm::i64vec3(0));
  return u;
}

bool same_path(std::span<const trace::PathVertex> a, std::span<const trace::PathVertex> b) {
  if (a.size() != b.size()) return false;
  for (size_t k = 0; k < a.size(); ++k)
    if (a[k].object != b[k].object || a[k].position != b[k].position || a[k].power != b[k].power)
      return false;
  return true;
}

TEST(SelectiveEmission, EachGroupIsOneFirstLevelHaltonCell) {
  const HaltonGroupEmission e({7, 11}, 40);
  ASSERT_EQ(e.group_count(), 77u);
  ASSERT_EQ(e.photons_per_light(), 3080u);
  std::vector<int> members(2 * 77, 0);
  for (uint64_t i = 0; i < 2 * 3080; ++i) {  // two lights
    const uint32_t g = e.group_of(i);
    ASSERT_EQ(g / 77, i / 3080) << "a group holds one light's photons";
    const glm::vec2 p = e.point(i);
    EXPECT_EQ(int(std::floor(p.x * 7)), int(g % 77 % 7)) << "photon " << i;
    EXPECT_EQ(int(std::floor(p.y * 11)), int(g % 77 % 11)) << "photon " << i;
    ++members[g];
  }
  for (uint32_t g = 0; g < 2 * 77; ++g) {
    EXPECT_EQ(members[g], 40) << "group " << g;
    for (uint32_t m = 0; m < 40; ++m) ASSERT_EQ(e.group_of(e.member(g, m)), g);
  }
  EXPECT_DOUBLE_EQ(radical_inverse(5, 2), 0.625);  // 101 -> 0.101
  EXPECT_DOUBLE_EQ(radical_inverse(10, 7), 3.0 / 7 + 1.0 / 49);
}

TEST(SelectiveEmission, AStaticSceneInvalidatesNothingAndProbesEachPhotonOncePerGroupSize) {
  Room room;
  trace::EmbreeScene world(room.t.scene, room.t.state);
  trace::EmbreePhotonTracer tracer(world);
  SelectiveEmission selective(tracer, room_settings());
  const SelectiveEmissionStats first = selective.update();
  EXPECT_TRUE(first.traced_all);
  ASSERT_EQ(selective.path_count(), 3080u);
  const std::vector<glm::i64vec3> before(selective.ledger().units().begin(),
                                         selective.ledger().units().end());
  std::vector<int> probed(selective.path_count(), 0);
  for (int round = 0; round < 2; ++round) {
    for (uint32_t f = 0; f < 40; ++f) {
      const SelectiveEmissionStats s = selective.update();
      EXPECT_FALSE(s.traced_all);
      EXPECT_EQ(s.probes, 77u);
      EXPECT_GT(s.probe_rays, 0u);
      EXPECT_EQ(s.groups_invalidated, 0u);
      EXPECT_EQ(s.paths_retraced, 0u);
      EXPECT_EQ(s.retrace_rays, 0u);
      EXPECT_TRUE(selective.changed_surfaces().empty());
      ASSERT_EQ(selective.probed_paths().size(), 77u);
      for (uint32_t p : selective.probed_paths()) ++probed[p];
    }
    for (uint32_t p = 0; p < probed.size(); ++p)
      ASSERT_EQ(probed[p], round + 1) << "path " << p << " after " << 40 * (round + 1);
  }
  EXPECT_EQ(padded(selective.ledger().units(), before.size()), before);
}

// Moves the block to `to_world`, updates (probing member `probe_member`) and checks the update
// against a fresh trace of the moved scene; returns the groups whose probe moved a hit without
// changing its sequence of objects (what only the divergence tolerance catches).
uint32_t move_and_check(Room& room, trace::EmbreeScene& world, trace::EmbreePhotonTracer& tracer,
                        SelectiveEmission& selective, const glm::mat4& to_world,
                        uint32_t probe_member) {
  std::vector<std::vector<trace::PathVertex>> old_paths;
  std::vector<std::vector<uint32_t>> old_triangles;  // of each path's photons
  for (uint32_t p = 0; p < selective.path_count(); ++p) {
    auto v = selective.path_vertices(p);
    old_paths.emplace_back(v.begin(), v.end());
    old_triangles.emplace_back();
    for (const auto& ph : selective.path_photons(p)) old_triangles.back().push_back(ph.triangle);
  }
  scene::FrameState next = room.t.state;
  next.object_to_world[room.block] = to_world;
  world.update(next);
  const SelectiveEmissionStats s = selective.update();
  EXPECT_FALSE(s.traced_all);
  EXPECT_EQ(s.probes, 77u);
  EXPECT_GT(s.groups_invalidated, 0u);
  EXPECT_LT(s.groups_invalidated, 77u);
  EXPECT_EQ(s.paths_retraced, s.groups_invalidated * 40);
  EXPECT_GT(s.retrace_rays, 0u);
  EXPECT_FALSE(selective.changed_surfaces().empty());

  // A fresh trace of the same emission points in the moved scene.
  SelectiveEmission fresh(tracer, room_settings());
  EXPECT_TRUE(fresh.update().traced_all);
  const HaltonGroupEmission& e = selective.emission();
  std::vector<char> invalid(77, 0);
  for (uint32_t g : selective.invalidated_groups()) invalid[g] = 1;
  const float tolerance = room_settings().divergence_tolerance;
  uint32_t moved_in_place = 0;
  for (uint32_t g = 0; g < 77; ++g) {
    const uint32_t probe = uint32_t(e.member(g, probe_member));
    const auto now = fresh.path_vertices(probe);
    const auto& was = old_paths[probe];
    bool same_objects = now.size() == was.size(), probe_moved = !same_objects;
    bool on_block = false;
    for (size_t k = 0; k < now.size(); ++k) on_block |= now[k].object == room.block;
    for (size_t k = 0; k < was.size(); ++k) on_block |= was[k].object == room.block;
    for (size_t k = 0; same_objects && k < now.size(); ++k) {
      same_objects = now[k].object == was[k].object;
      probe_moved |= !same_objects || glm::distance(now[k].position, was[k].position) > tolerance;
    }
    // A hit at the same place on the same object may lie on another of its triangles (a slid
    // quad's diagonal moved): its photon's surface changed.
    std::vector<uint32_t> triangles;
    for (const auto& ph : fresh.path_photons(probe)) triangles.push_back(ph.triangle);
    probe_moved |= triangles != old_triangles[probe];
    moved_in_place += same_objects && probe_moved;
    EXPECT_EQ(bool(invalid[g]), probe_moved) << "group " << g;
    if (invalid[g]) EXPECT_TRUE(on_block) << "group " << g << ": only the block moved";
    for (uint32_t m = 0; m < 40; ++m) {
      const uint32_t p = uint32_t(e.member(g, m));
      if (invalid[g]) {  // re-traced: the fresh trace's path and photons, bit for bit
        EXPECT_TRUE(same_path(selective.path_vertices(p), fresh.path_vertices(p))) << "path " << p;
        const auto a = selective.path_photons(p), b = fresh.path_photons(p);
        EXPECT_EQ(a.size(), b.size()) << "path " << p;
        for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) {
          EXPECT_EQ(a[i].position, b[i].position);
          EXPECT_EQ(a[i].power, b[i].power);
          EXPECT_EQ(a[i].triangle, b[i].triangle);
        }
      } else {  // kept as it was
        EXPECT_TRUE(same_path(selective.path_vertices(p), old_paths[p])) << "path " << p;
      }
    }
  }
  // The ledger, after the old photons left and the new arrived, equals one recomputed from the
  // kept photons.
  const std::vector<glm::i64vec3> scratch = recomputed(selective.ledger(), selective.photons());
  EXPECT_EQ(padded(selective.ledger().units(), scratch.size()),
            padded(scratch, selective.ledger().units().size()));
  return moved_in_place;
}

TEST(SelectiveEmission, AMovedObjectInvalidatesTheGroupsItsProbesHitAndMatchesAFreshTrace) {
  Room room;
  trace::EmbreeScene world(room.t.scene, room.t.state);
  trace::EmbreePhotonTracer tracer(world);
  SelectiveEmission selective(tracer, room_settings());
  selective.update();
  selective.update();  // probes member 0
  // Slid across the floor: probes that met the block meet other objects (member 1 probes).
  move_and_check(room, world, tracer, selective, glm::translate(glm::mat4(1.f), {-0.5f, 0, 0.4f}),
                 1);
  // Lifted 0.2 m: probes that land on its top land on the same triangles, 0.2 m higher, and only
  // the divergence tolerance tells (member 2 probes).
  EXPECT_GT(move_and_check(room, world, tracer, selective,
                           glm::translate(glm::mat4(1.f), {-0.5f, 0.2f, 0.4f}), 2),
            0u);
}

// Ch. 9: "a moving light source will cause all photon paths from this particular light to be
// invalidated each frame"; a light whose power changes traces everything afresh.
TEST(SelectiveEmission, AMovingLightInvalidatesAllItsGroupsEveryUpdate) {
  Room room;
  trace::EmbreeScene world(room.t.scene, room.t.state);
  trace::EmbreePhotonTracer tracer(world);
  SelectiveEmission selective(tracer, room_settings());
  selective.update();
  scene::FrameState next = room.t.state;
  for (int f = 1; f <= 3; ++f) {
    next.lights[0].position.x = 0.1f * f;
    world.update(next);
    const SelectiveEmissionStats s = selective.update();
    EXPECT_FALSE(s.traced_all);
    EXPECT_EQ(s.groups_invalidated, 77u);
    EXPECT_EQ(s.paths_retraced, 3080u);
  }
  next.lights[0].radiant *= 2.f;
  world.update(next);
  const SelectiveEmissionStats s = selective.update();
  EXPECT_TRUE(s.traced_all);
  EXPECT_EQ(s.probes, 0u);
  EXPECT_EQ(s.paths_retraced, 3080u);
}

TEST(SelectiveEmission, TheLedgerIsExactWhateverTheOrderOfAddsAndRemoves) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> power(1e-6f, 0.3f);
  std::uniform_int_distribution<uint32_t> triangle(0, 11);
  std::vector<trace::PhotonRecord> photons(5000);
  for (auto& p : photons) {
    p.triangle = triangle(rng);
    p.power = {power(rng), power(rng) * 1e-3f, power(rng)};
  }
  // Triangles 0..11 in three surfaces (as charts would map them).
  std::vector<uint32_t> surface_of(12);
  for (uint32_t t = 0; t < 12; ++t) surface_of[t] = t % 3;
  const double units_per_watt = std::ldexp(1.0, 40) / 0.3;
  SurfaceEnergyLedger ledger(surface_of, units_per_watt), scratch(surface_of, units_per_watt);
  for (const auto& p : photons) ledger.add(p);
  // Remove the first half in reverse order, re-trace them (new powers), add them back shuffled.
  for (size_t i = photons.size() / 2; i-- > 0;) ledger.remove(photons[i]);
  for (size_t i = 0; i < photons.size() / 2; ++i) photons[i].power *= 0.5f;
  std::vector<size_t> order(photons.size() / 2);
  std::iota(order.begin(), order.end(), size_t(0));
  std::shuffle(order.begin(), order.end(), rng);
  for (size_t i : order) ledger.add(photons[i]);
  for (const auto& p : photons) scratch.add(p);
  ASSERT_EQ(ledger.units().size(), 3u);
  for (uint32_t s = 0; s < 3; ++s) {
    EXPECT_EQ(ledger.units()[s], scratch.units()[s]) << "surface " << s;
    glm::dvec3 sum(0.0);
    for (const auto& p : photons)
      if (surface_of[p.triangle] == s) sum += glm::dvec3(p.power);
    for (int c = 0; c < 3; ++c)  // each photon rounded to half a unit at most
      EXPECT_NEAR(ledger.watts(s)[c], sum[c], photons.size() * 0.5 / units_per_watt);
  }
  trace::PhotonRecord outside;
  outside.triangle = 12;
  EXPECT_THROW(ledger.add(outside), Error);
}

TEST(SelectiveEmission, RefusesBadSettingsNamingTheKey) {
  Room room;
  trace::EmbreeScene world(room.t.scene, room.t.state);
  trace::EmbreePhotonTracer tracer(world);
  auto refused = [&](SelectiveEmissionSettings s, const std::string& key) {
    try {
      SelectiveEmission selective(tracer, s);
      ADD_FAILURE() << "accepted; expected a refusal naming " << key;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(key + ":"), std::string::npos) << e.what();
    }
  };
  SelectiveEmissionSettings s = room_settings();
  s.halton_bases = {6, 9};
  refused(s, "halton_bases");
  s.halton_bases = {7, 7};
  refused(s, "halton_bases");
  s.halton_bases = {1, 7};
  refused(s, "halton_bases");
  s = room_settings();
  s.group_size = 0;
  refused(s, "group_size");
  s = room_settings();
  s.divergence_tolerance = -1;
  refused(s, "divergence_tolerance");
  s = room_settings();
  s.halton_bases = {2, 3};  // coprime: accepted
  EXPECT_EQ(check_selective_emission(s), "");
}

// The settings as parameter rows (what a technique binds): their values make the policy's
// settings, and a refusal names the row at fault, of the two bases the one a config would change.
TEST(SelectiveEmission, ParameterRowsMakeTheSettingsAndNameTheRowAtFault) {
  SelectiveEmissionParams p;
  p.halton_base_1 = 5;
  p.halton_base_2 = 3;
  p.group_size = 8;
  p.divergence_tolerance = 0.25f;
  trace::TraceSettings trace;
  trace.max_bounces = 3;
  const SelectiveEmissionSettings s = p.settings(trace);
  EXPECT_EQ(s.halton_bases[0], 5u);
  EXPECT_EQ(s.halton_bases[1], 3u);
  EXPECT_EQ(s.group_size, 8u);
  EXPECT_EQ(s.divergence_tolerance, 0.25f);
  EXPECT_EQ(s.trace.max_bounces, 3u);
  EXPECT_EQ(check_selective_emission_params(p), "");
  // The rows' defaults are the thesis's 77 groups of 40 (Ch. 14), the policy's own defaults.
  const SelectiveEmissionSettings defaults;
  EXPECT_EQ(kHaltonBase1Param.default_value, defaults.halton_bases[0]);
  EXPECT_EQ(kHaltonBase2Param.default_value, defaults.halton_bases[1]);
  EXPECT_EQ(kGroupSizeParam.default_value, defaults.group_size);
  EXPECT_FLOAT_EQ(float(kDivergenceToleranceParam.default_value), defaults.divergence_tolerance);
  EXPECT_EQ(std::string(kDivergenceToleranceParam.unit), "m");

  p.halton_base_1 = 6;
  p.halton_base_2 = 9;
  EXPECT_EQ(check_selective_emission_params(p).rfind("halton_base_2: [6, 9] share the factor 3", 0),
            0u)
      << check_selective_emission_params(p);
  p.halton_base_1 = 1;
  EXPECT_EQ(check_selective_emission_params(p).rfind("halton_base_1: ", 0), 0u)
      << check_selective_emission_params(p);
  p = SelectiveEmissionParams{};
  p.group_size = 0;
  EXPECT_EQ(check_selective_emission_params(p), "group_size: must be at least 1");
}

}  // namespace
}  // namespace pb::toolkit
