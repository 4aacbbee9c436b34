// Area lights in the near field: the reference renderer's direct light from a quad light
// against closed forms at distance/size ratios 0.1..10 and light sizes 0.1..10 m, at the point
// below the light's centre and below a corner, on a receiver parallel to the light and on a tilted
// one; next-event estimation alone, BSDF sampling alone and their MIS combination on the same
// pixel; and an emissive mesh against the quad light it matches.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "metrics/z_test.h"
#include "reference/reference.h"
#include "test_scenes.h"
#include "trace/embree_scene.h"

namespace pb::trace {
namespace area_light_test {

using namespace test_scenes;

// ---- closed forms
// --------------------------------------------------------------------------------

// Form factor from a point to a parallel a x b rectangle at distance c whose corner lies on the
// point's normal (Howell's catalogue of configuration factors, "differential planar element to a
// parallel rectangle", one corner above the element).
double corner_form_factor(double a, double b, double c) {
  double x = a / c, y = b / c, sx = std::sqrt(1 + x * x), sy = std::sqrt(1 + y * y);
  return (x / sx * std::atan(y / sx) + y / sy * std::atan(x / sy)) / (2 * M_PI);
}

// Irradiance at p (normal n) from a Lambertian polygon of radiance L, by Lambert's contour
// integral: E = L/2 sum_i theta_i (n . g_i), with theta_i the angle p sees edge i under and g_i the
// unit normal of the plane through p and that edge. The polygon is first clipped to the half-space
// in front of the receiver (the part below its horizon sends nothing).
double polygon_irradiance(std::vector<glm::dvec3> poly, glm::dvec3 p, glm::dvec3 n,
                          double radiance) {
  std::vector<glm::dvec3> clipped;
  for (size_t i = 0; i < poly.size(); ++i) {
    glm::dvec3 a = poly[i], b = poly[(i + 1) % poly.size()];
    double da = glm::dot(a - p, n), db = glm::dot(b - p, n);
    if (da >= 0) clipped.push_back(a);
    if ((da >= 0) != (db >= 0)) clipped.push_back(a + (b - a) * (da / (da - db)));
  }
  double sum = 0;
  for (size_t i = 0; i < clipped.size(); ++i) {
    glm::dvec3 ra = glm::normalize(clipped[i] - p);
    glm::dvec3 rb = glm::normalize(clipped[(i + 1) % clipped.size()] - p);
    glm::dvec3 g = glm::cross(ra, rb);
    double len = glm::length(g);
    if (len <= 0) continue;
    sum += std::acos(std::clamp(glm::dot(ra, rb), -1.0, 1.0)) * glm::dot(n, g / len);
  }
  return 0.5 * radiance * std::abs(sum);
}

TEST(AreaLightClosedForms, ContourIntegralMatchesTheRectangleFormFactor) {
  for (double c : {0.01, 0.3, 1.0, 7.0}) {
    std::vector<glm::dvec3> rect = {{0, c, 0}, {0, c, 2}, {3, c, 2}, {3, c, 0}};
    double e = polygon_irradiance(rect, {0, 0, 0}, {0, 1, 0}, 1.0);
    EXPECT_NEAR(e / (M_PI * corner_form_factor(3, 2, c)), 1.0, 1e-9) << c;
  }
  // The case: 0.1 m square 3 cm away, F = 0.774 at its centre.
  EXPECT_NEAR(4 * corner_form_factor(0.05, 0.05, 0.03), 0.774, 5e-4);
}

// ---- the renderer against them ---------------------------------------------------------------

struct Receiver {
  glm::vec3 point, normal;
};

constexpr int kPixels = 8;  // every pixel sees the receiver point (a 0.01 degree field of view)

// A square quad light of side `size` facing -y at height `distance` above the plane y = 0 (shifted
// by `offset`), and a small diffuse receiver through `r` (albedo a) seen by a one-pixel camera just
// in front of it: the pixel's direct class is a / pi E(r).
ReferenceImage render_receiver(float size, float distance, Receiver r, glm::vec3 offset,
                               ReferenceOptions o, float albedo = 0.7f) {
  TestScene t;
  scene::Light light;
  light.type = scene::LightType::quad;
  light.position = offset + glm::vec3(-0.5f * size, distance, -0.5f * size);
  light.edge_u = {size, 0, 0};  // cross(edge_u, edge_v) = -y: facing the receiver
  light.edge_v = {0, 0, size};
  light.radiant = glm::vec3(120, 100, 80);
  t.light(light);
  glm::vec3 p = offset + r.point;
  glm::vec3 tu = glm::normalize(glm::cross(r.normal, glm::vec3(0, 0, 1)));
  glm::vec3 tv = glm::cross(tu, r.normal);
  float half = 0.05f * distance;
  t.object(quad_mesh(p - half * (tu + tv), 2 * half * tv, 2 * half * tu),
           t.material(scene::MaterialType::diffuse, glm::vec3(albedo)));
  glm::vec3 up = std::abs(r.normal.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 0, 1);
  t.camera(p + 0.25f * distance * r.normal, p, up, 0.01f);
  return render_reference(t.scene, t.state, PathClass::direct, kPixels, kPixels, o);
}

// The pixels' average (all see the same point) and the variance of that average, per channel.
struct Average {
  glm::dvec3 mean{0.0}, variance{0.0};
  double luminance() const { return 0.2126 * mean.x + 0.7152 * mean.y + 0.0722 * mean.z; }
};
Average average(const ReferenceImage& img) {
  Average a;
  size_t n = img.mean.pixel_count();
  for (size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) {
      a.mean[c] += img.mean.pixels[i * 3 + c] / double(n);
      a.variance[c] += img.variance.pixels[i * 3 + c] / double(n * n);
    }
  return a;
}

// Irradiance of the light render_receiver builds, at r lifted by `lift` along its normal
// (luminance of its radiance).
double closed_form_irradiance(float size, float distance, Receiver r, double lift = 0) {
  double s = size, d = distance;
  std::vector<glm::dvec3> quad = {
      {-s / 2, d, -s / 2}, {s / 2, d, -s / 2}, {s / 2, d, s / 2}, {-s / 2, d, s / 2}};
  double lum = 0.2126 * 120 + 0.7152 * 100 + 0.0722 * 80;
  glm::dvec3 n(r.normal);
  return polygon_irradiance(quad, glm::dvec3(r.point) + lift * n, n, lum);
}

ReferenceOptions tight() {
  ReferenceOptions o;
  o.samples = 1 << 18;
  // Per pixel; the average of the 64 pixels has an eighth of it, so 1% is 6 standard deviations.
  o.rel_error = 0.013f;
  o.min_samples = 64;
  return o;
}

// Every size, every distance/size ratio, both points and both receivers, inside 1%; and once with
// the whole scene moved to (3, 0, 3), where the ray offset (which scales with the coordinates) is
// three times larger.
TEST(AreaLight, DirectLightFromAQuadMatchesTheClosedFormWithinOnePercent) {
  const glm::vec3 tilted = glm::normalize(glm::vec3(0, std::cos(0.7f), std::sin(0.7f)));
  int checked = 0;
  for (float size : {0.1f, 1.f, 10.f})
    for (float ratio : {0.1f, 0.3f, 1.f, 3.f, 10.f})
      for (bool corner : {false, true})
        for (glm::vec3 normal : {glm::vec3(0, 1, 0), tilted}) {
          float d = ratio * size;
          Receiver r{corner ? glm::vec3(0.5f * size, 0, 0.5f * size) : glm::vec3(0.f), normal};
          bool shifted = size == 0.1f && ratio == 0.3f;
          ReferenceImage img =
              render_receiver(size, d, r, shifted ? glm::vec3(3, 0, 3) : glm::vec3(0.f), tight());
          // Every ray leaving the receiver (shadow rays and BSDF samples alike) starts
          // ray_epsilon off it, so the renderer estimates the irradiance there: at 1 cm from the
          // light's corner, with most of the light below a tilted receiver's horizon, that lift
          // (1e-4 m) alone takes 1.4% off the irradiance at the surface (checked below:
          // under 1.5%).
          double lift =
              EmbreeScene::ray_epsilon(r.point + (shifted ? glm::vec3(3, 0, 3) : glm::vec3(0.f)));
          double expected = 0.7 / M_PI * closed_form_irradiance(size, d, r, lift);
          ASSERT_GT(expected, 0.0);
          EXPECT_NEAR(closed_form_irradiance(size, d, r, lift) / closed_form_irradiance(size, d, r),
                      1.0, 0.015);
          EXPECT_NEAR(average(img).luminance() / expected, 1.0, 0.01)
              << "size " << size << " m, d/s " << ratio << (corner ? ", corner" : ", centre")
              << (normal.y < 1 ? ", tilted" : ", parallel") << (shifted ? ", at (3, 0, 3)" : "")
              << " (" << img.samples << " samples)";
          ++checked;
        }
  EXPECT_EQ(checked, 60);
}

// The same pixel by next-event estimation alone, by BSDF sampling alone, and by MIS: three unbiased
// estimates of one value, which must agree within their standard deviations (|z| < 4, for 3 pairs
// and 3 channels in 6 configurations). A shadow ray shadowed by its own emitter loses only the NEE
// estimate.
TEST(AreaLight, NextEventAloneBsdfAloneAndMisAgreeWithinTheirVariances) {
  for (float d : {0.003f, 0.01f, 0.03f, 0.3f})
    for (glm::vec3 offset : {glm::vec3(0.f), glm::vec3(3, 0, 3)}) {
      // Rays leave 1e-4 max(1, |p|) off the surface, so BSDF sampling sees the light from 3e-4 m
      // closer at (3, 0, 3): at 3 mm that is 10% of the distance and a visible bias of its own.
      if ((d == 0.003f || d == 0.3f) && offset.x > 0) continue;
      Receiver r{glm::vec3(0.f), glm::vec3(0, 1, 0)};
      Average by[3];
      const LightStrategies strategies[3] = {LightStrategies::mis, LightStrategies::nee_only,
                                             LightStrategies::bsdf_only};
      for (int k = 0; k < 3; ++k) {
        ReferenceOptions o;
        o.estimator = Estimator::pt;  // the strategies are path tracing's
        o.samples = 1000;
        o.light_strategies = strategies[k];
        by[k] = average(render_receiver(0.1f, d, r, offset, o));
      }
      for (int a = 0; a < 3; ++a)
        for (int b = a + 1; b < 3; ++b)
          for (int ch = 0; ch < 3; ++ch) {
            double diff = by[a].mean[ch] - by[b].mean[ch];
            double sd = std::sqrt(by[a].variance[ch] + by[b].variance[ch]);
            ASSERT_GT(sd, 0.0);
            EXPECT_LT(std::abs(diff) / sd, 4.0)
                << "d " << d << " offset " << offset.x << ": strategies " << a << " vs " << b
                << " channel " << ch << ": " << by[a].mean[ch] << " vs " << by[b].mean[ch];
          }
    }
}

// An emissive mesh (two triangles, no reflection) renders the same image as the quad light with
// its geometry and radiance: per-pixel Z-test of the two means with their variances, Sidak-
// corrected for the number of pixel-channels, passing for at least 99.75% of them, and a Z-test of
// the image averages.
TEST(AreaLight, EmissiveMeshMatchesTheQuadLightItCopies) {
  auto build = [](bool mesh) {
    TestScene t;
    uint32_t white = t.material(scene::MaterialType::diffuse, glm::vec3(0.71f));
    t.object(box_mesh({0, 0, 0}, {1, 1, 1}, true), white);
    glm::vec3 corner{0.45f, 0.97f, 0.45f}, eu{0.1f, 0, 0}, ev{0, 0, 0.1f};  // facing up, 3 cm
    if (mesh) {
      t.object(quad_mesh(corner, ev, eu),
               t.material(scene::MaterialType::emissive, glm::vec3(0.f), glm::vec3(120, 100, 80)));
    } else {
      scene::Light light;
      light.type = scene::LightType::quad;
      light.position = corner;
      light.edge_u = ev;
      light.edge_v = eu;
      light.radiant = glm::vec3(120, 100, 80);
      t.light(light);
    }
    t.camera({0.5f, 0.5f, 0.5f}, {0.5f, 1.f, 0.5f}, {0, 0, 1}, 70.f);
    return t;
  };
  ReferenceOptions o;
  o.samples = 512;
  TestScene quad = build(false), mesh = build(true);
  ReferenceImage a = render_reference(quad.scene, quad.state, PathClass::combined, 24, 18, o);
  o.seed = 2;
  ReferenceImage b = render_reference(mesh.scene, mesh.state, PathClass::combined, 24, 18, o);
  const metrics::ZTestResult z = metrics::z_test(a.mean, a.variance, b.mean, b.variance);
  EXPECT_LE(z.rejected_share_with_variance(), 0.0025)
      << z.rejected << " of " << z.tested - z.exact << " beyond the Sidak level " << z.sidak_level;
  EXPECT_EQ(z.exact_mismatches, 0u);
  // And the image averages, a far more sensitive test of a systematic difference: |z| < 4.
  double sum_a = 0, sum_b = 0, var = 0;
  for (size_t i = 0; i < a.mean.pixels.size(); ++i) {
    sum_a += a.mean.pixels[i], sum_b += b.mean.pixels[i];
    var += double(a.variance.pixels[i]) + b.variance.pixels[i];
  }
  EXPECT_LT(std::abs(sum_a - sum_b) / std::sqrt(var), 4.0) << sum_a << " vs " << sum_b;
  // The ceiling's hotspot is in view around the light's black back (0.71 L F = 55 at its centre,
  // which the light hides; about 13 at the pixels beside it).
  EXPECT_GT(*std::max_element(a.mean.pixels.begin(), a.mean.pixels.end()), 5.f);
}

}  // namespace area_light_test
}  // namespace pb::trace
