// Disc area lights (every experiment of Paper II uses one) against closed forms: the
// equal-area emission mapping, the irradiance on the disc's axis, E = pi L r^2 / (h^2 + r^2), by
// both estimators of the reference renderer, the photon tracer's power delivered to a coaxial
// circle (the disc-to-disc configuration factor) and its total power pi L A, and the radiance a
// camera sees on the disc's two sides.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "photonbench/photons.h"
#include "reference/reference.h"
#include "test_scenes.h"
#include "trace/embree_scene.h"
#include "trace/lights.h"
#include "trace/photon_tracer.h"

namespace pb::trace {
namespace disc_light_test {

using namespace test_scenes;

const glm::vec3 kRadiance(120, 100, 80);
double luminance(glm::dvec3 c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }
const double kLuminance = luminance(glm::dvec3(kRadiance));

// A disc of radius r facing -y with its centre at height h above the origin, as the loader builds
// it (two orthogonal radii whose cross product is the normal).
scene::Light disc_light(float radius, float height, glm::vec3 radiance = kRadiance) {
  scene::Light l;
  l.type = scene::LightType::disc;
  l.position = {0, height, 0};
  l.edge_u = {radius, 0, 0};  // cross(+x, +z) = -y
  l.edge_v = {0, 0, radius};
  l.radiant = radiance;
  return l;
}

// Irradiance on the axis of a Lambertian disc of radiance L and radius r, at distance h, on a
// receiver facing it: E = pi L r^2 / (h^2 + r^2) (the disc's configuration factor to a
// differential element on its axis).
double axis_irradiance(double radiance, double r, double h) {
  return M_PI * radiance * r * r / (h * h + r * r);
}

// Configuration factor between coaxial parallel discs, from disc 1 (radius r1) to disc 2 (radius
// r2) at distance h (Howell's catalogue, "disk to parallel coaxial disk").
double disc_to_disc_factor(double r1, double r2, double h) {
  double a = r1 / h, b = r2 / h, x = 1 + (1 + b * b) / (a * a);
  return 0.5 * (x - std::sqrt(x * x - 4 * (b / a) * (b / a)));
}

TEST(DiscLight, ConfigurationFactorsAgree) {
  // Disc to a vanishing coaxial disc: the on-axis irradiance (A1 F12 / A2 = E / (pi L)).
  for (double h : {0.1, 1.0, 10.0}) {
    double small = 1e-4 * h;
    double f21 = disc_to_disc_factor(1.0, small, h) / (small * small);
    EXPECT_NEAR(f21 / (axis_irradiance(1.0, 1.0, h) / M_PI), 1.0, 1e-5) << h;
  }
}

// Uniform (u, v) is uniform on the disc: the fraction of the area inside radius rho R is u, every
// point lies in the disc's plane within its radius, and the derivatives match finite differences.
TEST(DiscLight, SurfacePointIsAnEqualAreaMapOfTheDisc) {
  scene::Light l = disc_light(0.5f, 2.f);
  l.position = {1, 2, 3};
  EXPECT_NEAR(l.area(), M_PI * 0.25, 1e-6);
  EXPECT_NEAR(l.normal().y, -1.f, 1e-6f);
  for (float u : {0.01f, 0.25f, 0.5f, 0.9f, 1.f})
    for (float v : {0.f, 0.1f, 0.3f, 0.7f}) {
      glm::vec3 du, dv;
      glm::vec3 p = l.surface_point({u, v}, &du, &dv);
      glm::vec3 d = p - l.position;
      EXPECT_NEAR(glm::dot(d, l.normal()), 0.f, 1e-6f);
      // Area inside the point's radius / disc area = (|d| / R)^2 = u.
      EXPECT_NEAR(glm::dot(d, d) / 0.25f, u, 1e-5f) << u << " " << v;
      const float e = 1e-3f;
      if (u + e <= 1.f) {
        glm::vec3 fd_u = (l.surface_point({u + e, v}) - l.surface_point({u - e, v})) / (2 * e);
        EXPECT_LT(glm::distance(fd_u, du), 2e-3f * glm::length(du) + 1e-4f) << u << " " << v;
      }
      glm::vec3 fd_v = (l.surface_point({u, v + e}) - l.surface_point({u, v - e})) / (2 * e);
      EXPECT_LT(glm::distance(fd_v, dv), 2e-3f * glm::length(dv) + 1e-4f) << u << " " << v;
      // The Jacobian |dp/du x dp/dv| is the disc's area everywhere (equal-area).
      EXPECT_NEAR(glm::length(glm::cross(du, dv)) / l.area(), 1.f, 1e-3f) << u << " " << v;
    }
}

// ---- the reference renderer
// -----------------------------------------------------------------------------------------------

constexpr int kPixels = 8;  // every pixel sees the receiver point (a 0.01 degree field of view)

// The disc above the origin and a small diffuse receiver (albedo a) at the origin facing it, seen
// by a one-pixel camera just in front of it: the pixel's direct class is a / pi E.
double receiver_luminance(float radius, float height, Estimator estimator) {
  TestScene t;
  t.light(disc_light(radius, height));
  float half = 0.05f * height;
  t.object(quad_mesh({-half, 0, -half}, {0, 0, 2 * half}, {2 * half, 0, 0}),
           t.material(scene::MaterialType::diffuse, glm::vec3(0.7f)));
  t.camera({0, 0.25f * height, 0}, {0, 0, 0}, {1, 0, 0}, 0.01f);
  ReferenceOptions o;
  o.estimator = estimator;
  o.samples = 1 << 16;
  o.rel_error = 0.01f;
  o.min_samples = 64;
  ReferenceImage img = render_reference(t.scene, t.state, PathClass::direct, kPixels, kPixels, o);
  glm::dvec3 mean(0.0);
  size_t n = img.mean.pixel_count();
  for (size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) mean[c] += img.mean.pixels[i * 3 + c] / double(n);
  return luminance(mean);
}

// Both estimators, disc radius / distance from 0.1 to 10, within 1.5% of the closed form (the
// estimate stops at 1% relative error; rays leave the receiver ray_epsilon above it, which the
// expected value accounts for).
TEST(DiscLight, ReferenceIrradianceOnTheAxisMatchesTheClosedForm) {
  for (Estimator estimator : {Estimator::pt, Estimator::bdpt})
    for (float radius : {0.1f, 1.f})
      for (float ratio : {0.1f, 1.f, 10.f}) {
        float h = radius / ratio;
        double lift = EmbreeScene::ray_epsilon(glm::vec3(0.f));
        double expected = 0.7 / M_PI * axis_irradiance(kLuminance, radius, h - lift);
        EXPECT_NEAR(receiver_luminance(radius, h, estimator) / expected, 1.0, 0.015)
            << estimator_name(estimator) << ": radius " << radius << " m at " << h << " m";
      }
}

// A camera inside the disc's field sees its radiance L on the emitting side, and nothing on its
// back (one-sided, as the quad light), by both estimators.
TEST(DiscLight, CameraSeesTheRadianceOnTheFrontAndNothingBehind) {
  for (Estimator estimator : {Estimator::pt, Estimator::bdpt})
    for (bool front : {true, false}) {
      TestScene t;
      t.light(disc_light(0.5f, 1.f));
      t.camera({0, front ? 0.f : 2.f, 0}, {0, 1, 0}, {1, 0, 0}, 5.f);
      ReferenceOptions o;
      o.estimator = estimator;
      o.samples = 16;
      ReferenceImage img =
          render_reference(t.scene, t.state, PathClass::combined, kPixels, kPixels, o);
      for (size_t i = 0; i < img.mean.pixel_count(); ++i)
        for (int c = 0; c < 3; ++c)
          EXPECT_NEAR(img.mean.pixels[i * 3 + c], front ? kRadiance[c] : 0.f, 1e-3f * kRadiance[c])
              << estimator_name(estimator) << (front ? " front" : " back") << " pixel " << i;
    }
}

// ---- the photon tracer
// -----------------------------------------------------------------------------------------------

TraceSettings first_hits(uint32_t paths) {
  TraceSettings s;
  s.paths = paths;
  s.store = kDirectPhotons;
  s.max_bounces = 1;
  return s;
}

// Inside a closed box every photon lands on a wall at its first hit: the power they carry is the
// disc's power pi L A, one-sided.
TEST(DiscLight, PhotonTracerEmitsPiRadianceAreaOneSided) {
  TestScene t;
  t.object(box_mesh({-1, -1, -1}, {1, 1, 1}, true), t.material(scene::MaterialType::diffuse));
  t.light(disc_light(0.3f, 0.5f, glm::vec3(5.f)));
  EmbreeScene world(t.scene, t.state);
  EmbreePhotonTracer tracer(world);
  PhotonBatch batch;
  tracer.trace(first_hits(100000), batch);
  double expected = M_PI * 5.0 * M_PI * 0.09;
  glm::dvec3 total(0.0);
  size_t below = 0;
  for (const auto& p : batch.photons) {
    total += glm::dvec3(p.power);
    below += p.position.y < 0.5f;
  }
  EXPECT_NEAR(total.y / expected, 1.0, 0.005);
  EXPECT_NEAR(tracer.light_power(0).y / expected, 1.0, 1e-5);
  EXPECT_EQ(below, batch.photons.size());  // all of it leaves the front (-y) side
}

// On a plane at distance h below the disc, the power the photons deliver inside a circle of radius
// rho around the axis is pi L A1 F12(r, rho, h); as rho -> 0, power / (pi rho^2) is the axis
// irradiance E = pi L r^2 / (h^2 + r^2). Within 4 standard deviations of the binomial count.
TEST(DiscLight, PhotonTracerPowerOnACoaxialCircleMatchesTheConfigurationFactor) {
  const float r = 0.5f, h = 1.f;
  const double radiance = 3.0;
  TestScene t;
  t.object(quad_mesh({-50, 0, -50}, {0, 0, 100}, {100, 0, 0}),
           t.material(scene::MaterialType::diffuse));
  t.light(disc_light(r, h, glm::vec3(float(radiance))));
  EmbreeScene world(t.scene, t.state);
  EmbreePhotonTracer tracer(world);
  PhotonBatch batch;
  const uint32_t paths = 400000;
  tracer.trace(first_hits(paths), batch);
  const double power = M_PI * radiance * M_PI * r * r;
  for (double rho : {0.1, 0.3, 1.0}) {
    double inside = 0;
    for (const auto& p : batch.photons)
      if (glm::length(glm::vec2(p.position.x, p.position.z)) < rho) inside += p.power.x;
    double f = disc_to_disc_factor(r, rho, h);
    double sd = std::sqrt(f * (1 - f) / paths);
    EXPECT_LT(std::abs(inside / power - f), 4 * sd)
        << "rho " << rho << ": " << inside / power << " of the power, expected " << f;
  }
  // The smallest circle estimates the axis irradiance (its own size changes it by under 1%).
  double e = 0;
  for (const auto& p : batch.photons)
    if (glm::length(glm::vec2(p.position.x, p.position.z)) < 0.1) e += p.power.x;
  e /= M_PI * 0.01;
  EXPECT_NEAR(e / axis_irradiance(radiance, r, h), 1.0, 0.05);
}

// A sampled light point: next-event estimation picks points on the disc itself, and its density
// matches pdf_incident at the point a ray hits (what MIS weights against BSDF sampling).
TEST(DiscLight, IncidentSamplesLieOnTheDiscWithTheDensityOfAHit) {
  TestScene t;
  t.object(quad_mesh({-1, 0, -1}, {0, 0, 2}, {2, 0, 0}), t.material(scene::MaterialType::diffuse));
  t.light(disc_light(0.4f, 1.f));
  EmbreeScene world(t.scene, t.state);
  LightSet lights(world);
  ASSERT_EQ(lights.size(), 1u);
  ASSERT_TRUE(lights.has_area(0));
  glm::vec3 p(0.2f, 0.f, 0.1f);
  for (float u : {0.1f, 0.5f, 0.95f})
    for (float v : {0.2f, 0.6f}) {
      IncidentSample s;
      ASSERT_TRUE(lights.sample_incident(p, 0.5f, {u, v}, s));
      EXPECT_NEAR(s.point.y, 1.f, 1e-6f);
      EXPECT_LE(glm::length(glm::vec2(s.point.x, s.point.z)), 0.4f + 1e-5f);
      Hit hit;
      ASSERT_TRUE(world.intersect(p, s.wi, 10.f, hit));
      EXPECT_TRUE(world.is_light_object(hit.object));
      EXPECT_NEAR(hit.t, s.distance, 1e-4f);
      EXPECT_NEAR(lights.pdf_incident(p, hit) / s.pdf, 1.f, 1e-3f);
    }
  // A ray past the rim misses the disc (the exact circle, not a polygon around it).
  Hit hit;
  glm::vec3 rim = glm::normalize(glm::vec3(0.401f, 1.f, 0.f));
  EXPECT_FALSE(world.intersect({0, 0, 0}, rim, 10.f, hit) && world.is_light_object(hit.object));
  rim = glm::normalize(glm::vec3(0.399f, 1.f, 0.f));
  EXPECT_TRUE(world.intersect({0, 0, 0}, rim, 10.f, hit) && world.is_light_object(hit.object));
}

}  // namespace disc_light_test
}  // namespace pb::trace
