// The scene's emissive surfaces as lights: each emissive triangle carries Phi = pi A L (zero-flux
// triangles culled; the photon tracer's emission of them is in trace_test.cpp); and the shared
// direct-light pass
// (GPU) lights a diffuse floor under an emissive quad and under a closed emissive box with the
// irradiance of Lambert's polygon formula, computed here in double precision at each pixel's
// G-buffer point.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <numeric>
#include <vector>

#include "cell/profiler.h"
#include "command_stream.h"
#include "gpu/shared_passes.h"
#include "scene/emissive_triangles.h"
#include "test_scenes.h"

namespace pb::trace {
namespace emissive_lights_test {

using namespace test_scenes;

TEST(EmissiveTriangles, CarryPiAreaRadianceAndCullZeroFlux) {
  TestScene t;
  uint32_t bright = t.material(scene::MaterialType::emissive, glm::vec3(0.f), glm::vec3(3, 2, 1));
  uint32_t dark = t.material(scene::MaterialType::emissive, glm::vec3(0.5f), glm::vec3(0.f));
  uint32_t white = t.material(scene::MaterialType::diffuse);
  scene::Mesh quad = quad_mesh({0, 1, 0}, {0.5f, 0, 0}, {0, 0, 2});  // 1 m^2, faces -y
  // Wound against its vertex normals: the normals decide the emitting side.
  for (glm::uvec3& t : quad.triangles) std::swap(t.y, t.z);
  quad.positions.push_back({5, 5, 5});  // a degenerate triangle
  quad.normals.push_back({0, -1, 0});
  quad.triangles.push_back({4, 4, 4});
  t.object(quad, bright, glm::translate(glm::mat4(1.f), glm::vec3(0, 2, 0)));
  t.object(quad_mesh({0, 0, 0}, {1, 0, 0}, {0, 0, 1}), dark);
  t.object(quad_mesh({0, 0, 0}, {1, 0, 0}, {0, 0, 1}), white);
  auto triangles = scene::emissive_triangles(t.scene, t.state);
  ASSERT_EQ(triangles.size(), 2u);  // the degenerate and the dark ones are culled
  glm::vec3 flux{0.f};
  for (const auto& e : triangles) {
    EXPECT_EQ(e.object, 0u);
    EXPECT_NEAR(e.area, 0.5f, 1e-6f);
    EXPECT_NEAR(glm::length(e.normal - glm::vec3(0, -1, 0)), 0.f, 1e-6f);
    EXPECT_NEAR(glm::dot(glm::cross(e.p[1] - e.p[0], e.p[2] - e.p[0]), e.normal), 2 * e.area,
                1e-5f);
    EXPECT_NEAR(e.p[0].y, 3.f, 1e-6f);  // at the object's transform
    flux += e.flux;
  }
  EXPECT_NEAR(flux.x, M_PI * 1.0 * 3, 1e-5);
  EXPECT_NEAR(flux.z, M_PI * 1.0 * 1, 1e-5);
}

// ---- the shared direct-light pass ---------------------------------------------------------------

struct Floor {
  std::vector<float> position, normal, direct;
  uint32_t width = 0, height = 0;
};

// Renders t's G-buffer and direct light (no scene lights: its emitters are its objects).
Floor render_direct(TestScene& t, uint32_t width, uint32_t height) {
  gpu::Device device({"", false});
  testing::CommandStream commands(device);
  auto cmd = [&] { return commands.cmd(); };
  run::Profiler profiler(device, cmd);
  gpu::ScenePasses passes(device, t.scene, width, height, {}, profiler, cmd);
  passes.update(t.state);
  commands.begin();
  passes.gbuffer();
  passes.direct_light();
  commands.submit();
  Floor f;
  f.width = width, f.height = height;
  device.read_image(*passes.gbuffer_images().position, f.position);
  device.read_image(*passes.gbuffer_images().normal, f.normal);
  device.read_image(passes.direct_image(), f.direct);
  EXPECT_EQ(device.validation_errors(), 0u) << device.first_validation_error();
  return f;
}

// Every floor pixel's direct radiance against albedo / pi times the sum of the emissive triangles'
// polygon irradiances at its G-buffer point, within `tolerance` of the larger of that value and a
// quarter of the brightest pixel's: the shader's float acos loses precision on the small angles
// under which far pixels see an edge (0.3% of the value 2 m from a 0.5 m quad); returns the number
// of floor pixels checked.
int check_floor(const Floor& f, uint32_t floor_material, double albedo,
                const std::vector<scene::EmissiveTriangle>& emitters, double tolerance) {
  std::vector<std::pair<size_t, double>> expected;
  double peak = 0;
  for (size_t i = 0; i < size_t(f.width) * f.height; ++i) {
    if (f.position[i * 4 + 3] <= 0 || uint32_t(f.normal[i * 4 + 3]) != floor_material) continue;
    glm::dvec3 p(f.position[i * 4], f.position[i * 4 + 1], f.position[i * 4 + 2]);
    double e = 0;
    for (const auto& t : emitters)
      e += polygon_irradiance({t.p[0], t.p[1], t.p[2]}, p, {0, 1, 0}, t.radiance.y);
    expected.push_back({i, e * albedo / M_PI});
    peak = std::max(peak, e * albedo / M_PI);
  }
  for (auto [i, e] : expected)
    EXPECT_NEAR(f.direct[i * 4 + 1], e, tolerance * std::max(e, 0.25 * peak))
        << "pixel " << i % f.width << ", " << i / f.width << " at " << f.position[i * 4] << ", "
        << f.position[i * 4 + 2];
  return int(expected.size());
}

// A 0.5 m square emissive quad 0.4 m above a diffuse floor: the irradiance of its two triangles.
TEST(EmissiveTriangles, DirectLightPassMatchesTheFormFactorUnderAnEmissiveQuad) {
  TestScene t;
  uint32_t floor = t.material(scene::MaterialType::diffuse, glm::vec3(0.6f));
  t.object(quad_mesh({-2, 0, 2}, {4, 0, 0}, {0, 0, -4}), floor);           // faces +y
  t.object(quad_mesh({-0.25f, 0.4f, -0.25f}, {0.5f, 0, 0}, {0, 0, 0.5f}),  // faces -y
           t.material(scene::MaterialType::emissive, glm::vec3(0.f), glm::vec3(7.f)));
  t.camera({0, 1.5f, 1.2f}, {0, 0, 0}, {0, 1, 0}, 60.f);
  Floor f = render_direct(t, 48, 32);
  auto emitters = scene::emissive_triangles(t.scene, t.state);
  ASSERT_EQ(emitters.size(), 2u);
  EXPECT_GT(check_floor(f, floor, 0.6, emitters, 2e-3), 48 * 32 / 2);
  // The point under the centre, by the closed form of the configuration factor: four corner
  // rectangles of 0.25 x 0.25 m at 0.4 m (Howell's catalogue), E = pi L F.
  double x = 0.25 / 0.4, sx = std::sqrt(1 + x * x);
  double corner = 2 * (x / sx * std::atan(x / sx)) / (2 * M_PI);
  std::vector<glm::dvec3> quad = {
      {-0.25, 0.4, -0.25}, {0.25, 0.4, -0.25}, {0.25, 0.4, 0.25}, {-0.25, 0.4, 0.25}};
  EXPECT_NEAR(polygon_irradiance(quad, {0, 0, 0}, {0, 1, 0}, 7.0) / (M_PI * 7.0 * 4 * corner), 1.0,
              1e-9);
}

// A closed emissive box above the floor: its own shadow cube sits inside it, so the pass must leave
// the box out of its cube (else the floor goes dark), and the faces seen from each floor point add.
// A slab between a second box and the floor shadows that box's light.
TEST(EmissiveTriangles, DirectLightPassLightsFromAClosedEmitterAndItsShadowsFall) {
  TestScene t;
  uint32_t floor = t.material(scene::MaterialType::diffuse, glm::vec3(0.5f));
  t.object(quad_mesh({-2, 0, 2}, {4, 0, 0}, {0, 0, -4}), floor);
  t.object(box_mesh({-0.2f, 0.5f, -0.2f}, {0.2f, 0.7f, 0.2f}, false),
           t.material(scene::MaterialType::emissive, glm::vec3(0.f), glm::vec3(3.f)));
  t.camera({0, 1.2f, 1.6f}, {0, 0, 0.3f}, {0, 1, 0}, 50.f);
  auto emitters = scene::emissive_triangles(t.scene, t.state);
  ASSERT_EQ(emitters.size(), 12u);
  Floor lit = render_direct(t, 48, 32);
  EXPECT_GT(check_floor(lit, floor, 0.5, emitters, 2e-3), 48 * 32 / 2);

  // A slab between the box and the floor: the floor under it is dark.
  t.object(quad_mesh({-0.25f, 0.35f, -0.25f}, {0, 0, 0.5f}, {0.5f, 0, 0}),
           t.material(scene::MaterialType::diffuse));
  Floor shadowed = render_direct(t, 48, 32);
  int dark = 0;
  for (size_t i = 0; i < 48 * 32; ++i) {
    if (shadowed.position[i * 4 + 3] <= 0 || uint32_t(shadowed.normal[i * 4 + 3]) != floor)
      continue;
    float x = shadowed.position[i * 4], z = shadowed.position[i * 4 + 2];
    if (std::abs(x) < 0.2f && std::abs(z) < 0.2f) {
      EXPECT_EQ(shadowed.direct[i * 4 + 1], 0.f) << x << ", " << z;
      EXPECT_GT(lit.direct[i * 4 + 1], 0.f);
      ++dark;
    }
  }
  EXPECT_GT(dark, 0);
}

}  // namespace emissive_lights_test
}  // namespace pb::trace
