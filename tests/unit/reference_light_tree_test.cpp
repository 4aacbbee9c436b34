// The reference path tracer's next-event estimation through the light BVH
// (trace/incident_light_tree.h, LightSelection::bvh): its MIS density for an emitter hit is the
// density it samples that point with, it renders the image power sampling renders, and on lights
// of very different power and distance its variance is the lower of the two.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "metrics/z_test.h"
#include "reference/reference.h"
#include "test_scenes.h"
#include "trace/embree_scene.h"
#include "trace/incident_light_tree.h"
#include "trace/lights.h"

namespace pb::trace {
namespace reference_light_tree_test {

using namespace test_scenes;

// An 8 x 8 m room, 2 m high, lit by an 8 x 8 grid of emissive squares of side `lamp_size` (one
// object each, two triangles, facing down) hanging `low` to `low` + 0.5 m high with radiances
// spanning `decades` powers of ten in a scattered pattern: from a point on the floor the near lamps
// matter most, while power sampling spends most samples on the bright ones wherever they are. Plus
// a quad light, a point light and, if asked, a directional light.
TestScene many_light_room(bool directional, float lamp_size = 0.15f, float low = 1.4f,
                          float decades = 2.f) {
  TestScene t;
  uint32_t white = t.material(scene::MaterialType::diffuse, glm::vec3(0.6f));
  t.object(box_mesh({-4, 0, -4}, {4, 2, 4}, true), white);
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 8; ++j) {
      int k = i * 8 + j;
      float level = float((k * 5) % 8) / 7.f;  // 0..1, scattered over the grid
      float radiance = 2.f * std::pow(10.f, decades * level);
      float height = low + 0.5f * float((k * 3) % 4) / 3.f;
      glm::vec3 corner{-3.6f + 1.f * i, height, -3.6f + 1.f * j};
      // Facing down: cross(eu, ev) = -y.
      t.object(quad_mesh(corner, {lamp_size, 0, 0}, {0, 0, lamp_size}),
               t.material(scene::MaterialType::emissive, glm::vec3(0.f), glm::vec3(radiance)));
    }
  scene::Light quad;
  quad.type = scene::LightType::quad;
  quad.position = {1.2f, 1.95f, 1.2f};
  quad.edge_u = {0.3f, 0, 0};  // facing down: cross(edge_u, edge_v) = -y
  quad.edge_v = {0, 0, 0.3f};
  quad.radiant = glm::vec3(20.f);
  t.light(quad);
  t.point_light({-1.5f, 1.0f, 1.5f}, 0.5f);
  if (directional) {
    scene::Light sun;
    sun.type = scene::LightType::directional;
    sun.direction = glm::normalize(glm::vec3(0.3f, -1.f, 0.2f));
    sun.radiant = glm::vec3(0.02f);
    t.light(sun);
  }
  // Looking down at the floor, the lamps out of view.
  t.camera({0.f, 1.5f, 3.9f}, {0.f, 0.f, 1.f}, {0, 1, 0}, 60.f);
  return t;
}

// A receiving point on the room's floor, walls or ceiling, with its inward normal.
struct Receiver {
  glm::vec3 p, n;
};
Receiver random_receiver(Pcg32& rng) {
  glm::vec2 u = rng.next_2d();
  float a = -3.99f + 7.98f * u.x, b = 0.01f + 1.98f * u.y;
  switch (rng.next_u32() % 4) {
    case 0:
      return {{a, 0.f, -3.99f + 7.98f * u.y}, {0, 1, 0}};
    case 1:
      return {{a, 2.f, -3.99f + 7.98f * u.y}, {0, -1, 0}};
    case 2:
      return {{-4.f, b, a}, {1, 0, 0}};
    default:
      return {{a, b, -4.f}, {0, 0, 1}};
  }
}

// For random shading points: the walk's pick probabilities of every light and the directional
// share sum to at most 1 (less where the walk can end on lights whose importance bound is zero: it
// then returns no sample); a sampled point on an area light, found again by a ray from the shading
// point, gets from pdf_incident exactly the density sample_incident drew it with (the walk's
// probability of that light from the shading point, times 1/area, in solid angle); and at a point
// of the floor, of a wall and of the ceiling the walk's picks, counted over many numbers, follow
// pick_probability and its shortfall from 1.
TEST(ReferenceLightTree, PdfIncidentIsTheWalksPickProbabilityTimesThePointDensity) {
  TestScene t = many_light_room(true);
  EmbreeScene world(t.scene, t.state, one_frame_options());
  LightSet set(world);
  IncidentLightTree tree(world, set);
  const uint32_t n_lights = uint32_t(tree.lights().lights.size());
  ASSERT_EQ(n_lights, 64u * 2 + 2);  // the squares' triangles, the quad and the point light
  ASSERT_GT(tree.tree_share(), 0.5f);
  ASSERT_LT(tree.tree_share(), 1.f);
  Pcg32 rng(7, 3);
  int checked = 0;
  for (int s = 0; s < 200; ++s) {
    Receiver r = random_receiver(rng);
    // Shading points just off the surface, where a path tracer's rays leave from.
    glm::vec3 origin = r.p + 1e-3f * r.n;
    double total = 1.0 - tree.tree_share();
    for (uint32_t i = 0; i < n_lights; ++i) total += tree.pick_probability(origin, r.n, i);
    EXPECT_LE(total, 1.0 + 1e-4) << "at " << r.p.x << " " << r.p.y << " " << r.p.z;
    for (int k = 0; k < 20; ++k) {
      IncidentSample is;
      if (!tree.sample_incident(origin, r.n, rng.next_float(), rng.next_2d(), is) || is.delta)
        continue;
      Hit hit;
      if (!world.intersect(origin, is.wi, kUnboundedRay, hit)) continue;
      if (glm::length(hit.position - is.point) > 1e-3f) continue;  // occluded on the way
      uint32_t light = tree.light_of(hit);
      ASSERT_NE(light, ~0u);
      float pick = tree.pick_probability(origin, r.n, light);
      const NeeLight& l = tree.lights().lights[light];
      float d2 = glm::dot(hit.position - origin, hit.position - origin);
      float cos_l = std::abs(glm::dot(hit.geometric_normal, hit.position - origin)) / std::sqrt(d2);
      float mis_pdf = tree.pdf_incident(origin, r.n, hit);
      EXPECT_NEAR(mis_pdf / (pick * d2 / (cos_l * l.area)), 1.0, 1e-4);
      // The same point as sample_incident's, up to the hit's rounding.
      EXPECT_NEAR(mis_pdf / is.pdf, 1.0, 2e-3) << "light " << light;
      ++checked;
    }
  }
  EXPECT_GT(checked, 1000);
  // The walk's picks against its probabilities (total variation distance), counted over a fine
  // grid of selection numbers at a fixed point on the lights.
  for (Receiver r :
       {Receiver{{0.3f, 0.001f, -0.4f}, {0, 1, 0}}, Receiver{{-3.999f, 0.7f, 1.f}, {1, 0, 0}},
        Receiver{{-2.f, 1.999f, 2.f}, {0, -1, 0}}}) {
    std::vector<double> count(n_lights, 0.0);
    const int draws = 100000;
    int directional = 0, none = 0;
    for (int k = 0; k < draws; ++k) {
      IncidentSample is;
      float u_select = (k + 0.5f) / draws;
      if (!tree.sample_incident(r.p, r.n, u_select, {0.5f, 0.5f}, is)) {
        ++none;  // no light here for this number, or the back of the chosen one
        continue;
      }
      if (std::isinf(is.distance)) {
        ++directional;
        continue;
      }
      for (uint32_t i = 0; i < n_lights; ++i) {
        const NeeLight& l = tree.lights().lights[i];
        glm::vec3 centre = l.area_light() ? area_point(l, {0.5f, 0.5f}) : l.origin;
        if (glm::length(centre - is.point) < 1e-5f) {
          count[i] += 1;
          break;
        }
      }
    }
    double tv = 0, total = 0;
    for (uint32_t i = 0; i < n_lights; ++i) {
      double p = tree.pick_probability(r.p, r.n, i);
      // A pick of a light whose front the point cannot see returns no sample.
      const NeeLight& l = tree.lights().lights[i];
      if (l.area_light() && glm::dot(l.normal, r.p - area_point(l, {0.5f, 0.5f})) <= 0) p = 0;
      tv += std::abs(count[i] / draws - p);
      total += p;
    }
    EXPECT_LT(0.5 * tv, 0.01) << "at " << r.p.x << " " << r.p.y << " " << r.p.z;
    EXPECT_NEAR(double(directional) / draws, 1.0 - tree.tree_share(), 1e-3);
    EXPECT_NEAR(double(none) / draws, tree.tree_share() - total, 0.01);
  }
}

ReferenceImage render_room(const TestScene& t, LightSelection selection, uint32_t samples,
                           uint32_t seed, uint32_t max_bounces) {
  ReferenceOptions o;
  o.estimator = Estimator::pt;
  o.light_selection = selection;
  o.samples = samples;
  o.seed = seed;
  o.max_bounces = max_bounces;
  return render_reference(t.scene, t.state, PathClass::combined, 32, 24, o);
}

// The two light choices estimate one image: per-pixel Z-test of the two means with their
// variances (Sidak-corrected, at least 99.75% of the pixel-channels passing) and a Z-test of the
// image sums, |z| < 4. The lamps are 0.5 m wide, so that BSDF sampling finds them often: a wrong
// MIS density for its emitter hits (power sampling's, measured) shifts the image sums by z = -40.
TEST(ReferenceLightTree, BvhAndPowerLightChoiceRenderTheSameImage) {
  TestScene t = many_light_room(true, 0.5f);
  ReferenceImage a = render_room(t, LightSelection::power, 256, 1, 2);
  ReferenceImage b = render_room(t, LightSelection::bvh, 256, 2, 2);
  const metrics::ZTestResult z = metrics::z_test(a.mean, a.variance, b.mean, b.variance);
  EXPECT_LE(z.rejected_share_with_variance(), 0.0025)
      << z.rejected << " of " << z.tested - z.exact << " beyond the Sidak level " << z.sidak_level;
  double sum_a = 0, sum_b = 0, var = 0;
  for (size_t i = 0; i < a.mean.pixels.size(); ++i) {
    sum_a += a.mean.pixels[i], sum_b += b.mean.pixels[i];
    var += double(a.variance.pixels[i]) + b.variance.pixels[i];
  }
  EXPECT_LT(std::abs(sum_a - sum_b) / std::sqrt(var), 4.0) << sum_a << " vs " << sum_b;
  EXPECT_GT(sum_a, 0.0);
}

// At equal samples, the walk's importance (distance, flux, orientation) beats power alone on lights
// of very different distance (lamps 0.3 to 0.8 m over the floor, radiances spanning 10x): the
// summed variance of the mean over the image is under half power sampling's (0.18 of it measured;
// a walk by flux alone, the importance dropped, measured 0.995).
TEST(ReferenceLightTree, BvhLightChoiceHasLowerVarianceThanPowerOnManyUnequalLights) {
  TestScene t = many_light_room(false, 0.15f, 0.3f, 1.f);
  ReferenceImage a = render_room(t, LightSelection::power, 128, 3, 1);
  ReferenceImage b = render_room(t, LightSelection::bvh, 128, 4, 1);
  double var_power = 0, var_bvh = 0;
  for (size_t i = 0; i < a.variance.pixels.size(); ++i)
    var_power += a.variance.pixels[i], var_bvh += b.variance.pixels[i];
  ASSERT_GT(var_power, 0.0);
  EXPECT_LT(var_bvh / var_power, 0.5) << var_bvh << " vs " << var_power;
}

}  // namespace reference_light_tree_test
}  // namespace pb::trace
