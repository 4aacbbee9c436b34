// The `direct` technique's shading of a disc light (harness/shaders/direct.comp, the disc as the
// 32-gon of its area in Lambert's contour integral) against closed forms, on the GPU (lavapipe): a
// diffuse floor under a disc of radiance L, seen straight down through the light (the G-buffer does
// not draw lights) at a point on the disc's axis, E = pi L r^2 / (h^2 + r^2), and at a point beyond
// its rim, against the contour integral of a 4096-gon.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <glm/glm.hpp>
#include <string>
#include <vector>

#include "run_fixture.h"

namespace pb::testing {
namespace disc_direct_test {

constexpr double kRadiance = 10, kRadius = 0.5, kHeight = 1, kAlbedo = 0.5;

// A scene with the floor's point (x, 0, 0) in the middle of a narrow view from 0.3 m above it.
std::string scene_text(double x) {
  return "purpose: the direct technique's disc light against the closed form\n"
         "frames: 1\n"
         "camera: {position: [" +
         std::to_string(x) + ", 0.3, 0], target: [" + std::to_string(x) +
         ", 0, 0], up: [1, 0, 0], fov_deg: 2}\n"
         "lights:\n"
         "  - {type: disc, position: [0, 1, 0], normal: [0, -1, 0], radius: 0.5, radiance: 10}\n"
         "materials: {floor: {type: diffuse, albedo: 0.5}}\n"
         "objects: [{shape: {type: quad, size: [20, 20]}, material: floor}]\n";
}

// Irradiance at p (normal +y) from the disc by Lambert's contour integral over a fine polygon.
double disc_irradiance(glm::dvec3 p) {
  const int sides = 4096;
  double sum = 0;
  for (int i = 0; i < sides; ++i) {
    double a0 = 2 * M_PI * i / sides, a1 = 2 * M_PI * (i + 1) / sides;
    glm::dvec3 ra =
        glm::normalize(glm::dvec3(kRadius * std::cos(a0), kHeight, kRadius * std::sin(a0)) - p);
    glm::dvec3 rb =
        glm::normalize(glm::dvec3(kRadius * std::cos(a1), kHeight, kRadius * std::sin(a1)) - p);
    glm::dvec3 g = glm::cross(ra, rb);
    sum += std::acos(std::clamp(glm::dot(ra, rb), -1.0, 1.0)) * glm::normalize(g).y;
  }
  return 0.5 * kRadiance * std::abs(sum);
}

TEST(DiscDirect, ShadesTheClosedFormOnTheAxisAndBeyondTheRim) {
  // The contour integral reproduces the axis formula first.
  EXPECT_NEAR(disc_irradiance({0, 0, 0}) /
                  (M_PI * kRadiance * kRadius * kRadius / (kHeight * kHeight + kRadius * kRadius)),
              1.0, 1e-5);
  fs::path dir = work_dir("disc_direct", "floor");
  const std::vector<double> points = {0.0, 0.8};
  std::string scenes;
  for (size_t k = 0; k < points.size(); ++k) {
    fs::path file = dir / ("disc-floor-" + std::to_string(k) + ".yaml");
    std::ofstream(file) << scene_text(points[k]);
    scenes += (k ? ", " : "") + file.string();
  }
  std::string yaml = "name: disc-direct\nresolution: [16, 16]\nseed: 1\nscenes: [" + scenes +
                     "]\nframes: {warmup: 0, count: 1, metrics_every: 1}\nmetrics: [psnr]\n"
                     "limits: {cell_seconds: 300}\nreference: {samples: 2, cache_dir: " +
                     (dir / "refs").string() + "}\ntechniques: [{technique: direct}]\n";
  ASSERT_EQ(run_config(dir, yaml), 0) << (dir / "log.txt");
  for (size_t k = 0; k < points.size(); ++k) {
    fs::path cell = cell_dir(dir, "disc-floor-" + std::to_string(k) + "__direct__");
    ASSERT_FALSE(cell.empty());
    // Diffuse: radiance = albedo / pi x E, the same in every channel (the light is white).
    double expected = kAlbedo / M_PI * disc_irradiance({points[k], 0, 0});
    double ratio = mean_rgb(frame_image(cell)) / expected;
    std::printf("floor point x = %.1f m: direct / closed form %.5f\n", points[k], ratio);
    EXPECT_NEAR(ratio, 1.0, 0.01) << "floor point x = " << points[k] << " m: expected " << expected;
  }
  fs::remove_all(dir);
}

}  // namespace disc_direct_test
}  // namespace pb::testing
