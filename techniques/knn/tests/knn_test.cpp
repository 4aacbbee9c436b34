// knn technique: the GPU k-nearest search against a brute-force CPU search on random photons (the
// same k photons, the same radius, the same estimate; KnnGrid driven directly on a device, as the
// plugin drives it), a uniformly lit plane against its closed-form irradiance, the static mode's
// single build and its image against every_frame's on a static scene, and bad parameters refused
// with their file, line and key (through `photonbench run` and the plan).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "../knn_grid.h"
#include "gpu_context.h"
#include "io/image.h"
#include "photonbench/error.h"
#include "photonbench/scene_layout.h"
#include "photonbench/toolkit/technique.h"
#include "plan_scratch.h"
#include "run_fixture.h"

namespace fs = std::filesystem;

namespace knn_test {

using namespace pb::testing;
using pb::trace::PhotonRecord;

constexpr double kPi = 3.14159265358979;

// ---- The GPU k nearest against brute force ----

struct Case {
  uint32_t k;
  float r_max, cell_size;  // cell_size 0: automatic
  uint32_t kernel, sparse;
  uint32_t search = KNN_SEARCH_GRID, heap = KNN_HEAP_PRIVATE;
};

std::ostream& operator<<(std::ostream& out, const Case& c) {
  return out << "k " << c.k << ", r_max " << c.r_max << ", cell " << c.cell_size << ", kernel "
             << c.kernel << ", sparse " << c.sparse << ", search " << c.search << ", heap "
             << c.heap;
}

class KnnGridSearch : public ::testing::TestWithParam<Case> {};

// 20,000 photons at random points of the unit cube with random directions and powers, and 32 x 16
// queries at random points of a slightly larger cube (some outside the grid) with random normals.
// For each query the CPU takes, among the photons within r_max arriving from above the query's
// tangent plane, the k nearest; the GPU must find the same photons (a swap at the k-th place is
// allowed only between photons whose distances tie to 1e-5), the same radius, and the same
// radiance.
TEST_P(KnnGridSearch, FindsTheBruteForceNearestPhotons) {
  const Case c = GetParam();
  constexpr uint32_t kW = 32, kH = 16, kPhotons = 20000;
  pb::gpu::Device gpu({});
  TestGBuffer gbuffer(gpu, kW, kH);
  TestContext ctx(gpu, gbuffer);

  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  auto direction = [&] {
    glm::vec3 d;
    do d = glm::vec3(unit(rng), unit(rng), unit(rng)) * 2.0f - 1.0f;
    while (glm::dot(d, d) > 1.0f || glm::dot(d, d) < 1e-4f);
    return glm::normalize(d);
  };
  std::vector<PhotonRecord> photons(kPhotons);
  for (auto& p : photons) {
    p = PhotonRecord{};
    p.position = glm::vec3(unit(rng), unit(rng), unit(rng));
    p.direction = direction();
    p.power = glm::vec3(unit(rng), unit(rng), unit(rng)) * 1e-3f;
  }
  std::vector<float> position(kW * kH * 4), normal(kW * kH * 4), albedo(kW * kH * 4);
  for (uint32_t q = 0; q < kW * kH; ++q) {
    glm::vec3 x = glm::vec3(unit(rng), unit(rng), unit(rng)) * 1.2f - 0.1f, n = direction();
    for (int a = 0; a < 3; ++a) {
      position[q * 4 + a] = x[a];
      normal[q * 4 + a] = n[a];
      albedo[q * 4 + a] = 0.5f + 0.1f * a;
    }
    position[q * 4 + 3] = 1.0f;  // distance to the camera: not background
    albedo[q * 4 + 3] = float(PB_MATERIAL_DIFFUSE);
  }
  TestGBuffer::upload(gpu, gbuffer.position, position);
  TestGBuffer::upload(gpu, gbuffer.normal, normal);
  TestGBuffer::upload(gpu, gbuffer.albedo, albedo);

  pb::gpu::Buffer buffer = pb::toolkit::storage_buffer(
      gpu, "test/photons", photons.size() * sizeof(PhotonRecord), pb::gpu::Memory::host_visible);
  std::memcpy(buffer.mapped(), photons.data(), photons.size() * sizeof(PhotonRecord));
  pb::gpu::Image indirect =
      gpu.create_image("test/indirect", {kW, kH}, vk::Format::eR32G32B32A32Sfloat,
                       vk::ImageUsageFlagBits::eStorage | vk::ImageUsageFlagBits::eTransferSrc);

  knn::Settings settings;
  settings.k = c.k;
  settings.r_max = c.r_max;
  settings.cell_size = c.cell_size;
  settings.kernel = c.kernel;
  settings.sparse = c.sparse;
  settings.search = c.search;
  settings.heap = c.heap;
  knn::KnnGrid grid;
  grid.setup(gpu, settings);
  grid.build(ctx.cmd(), gpu, buffer, photons);
  pb::gpu::full_barrier(ctx.cmd());
  grid.gather(ctx.cmd(), gpu, gbuffer.gbuffer_images(), kW, kH, indirect, /* debug */ true);
  ctx.submit();
  const knn::Stats stats = grid.read_stats();
  ASSERT_EQ(stats.truncated, 0u) << "a query ran out of its loop budget";
  EXPECT_EQ(stats.queries, kW * kH);
  auto queries = grid.debug_queries(gpu);
  std::vector<float> image;
  gpu.read_image(indirect, image);

  uint32_t short_queries = 0, swaps = 0;
  uint64_t found = 0;
  for (uint32_t q = 0; q < kW * kH; ++q) {
    SCOPED_TRACE("query " + std::to_string(q));
    const glm::vec3 x(position[q * 4], position[q * 4 + 1], position[q * 4 + 2]);
    const glm::vec3 n(normal[q * 4], normal[q * 4 + 1], normal[q * 4 + 2]);
    std::vector<std::pair<float, uint32_t>> candidates;
    for (uint32_t i = 0; i < kPhotons; ++i) {
      glm::vec3 d = photons[i].position - x;
      float d2 = glm::dot(d, d);
      if (d2 <= c.r_max * c.r_max && glm::dot(n, photons[i].direction) < 0.0f)
        candidates.push_back({d2, i});
    }
    std::sort(candidates.begin(), candidates.end());
    const uint32_t m = std::min<uint32_t>(c.k, uint32_t(candidates.size()));
    const auto& got = queries[q];
    ASSERT_EQ(got.found, m);
    found += m;
    if (m < c.k) ++short_queries;
    if (m == 0) {
      EXPECT_EQ(image[q * 4], 0.0f);
      continue;
    }
    // The same photons, up to ties at the k-th distance.
    const float kth = candidates[m - 1].first;
    std::set<uint32_t> expected, gpu_set(got.photons.begin(), got.photons.end());
    for (uint32_t j = 0; j < m; ++j) expected.insert(candidates[j].second);
    ASSERT_EQ(gpu_set.size(), m) << "a photon found twice";
    for (uint32_t i : gpu_set)
      if (!expected.count(i)) {
        glm::vec3 d = photons[i].position - x;
        EXPECT_NEAR(glm::dot(d, d), kth, 1e-5f * kth) << "photon " << i << " is not among the k";
        ++swaps;
      }
    // The radius: the k-th distance, or r_max / the farthest found when fewer than k.
    const float r2 = (m == c.k || c.sparse == KNN_SPARSE_FARTHEST) ? kth : c.r_max * c.r_max;
    EXPECT_NEAR(got.radius, std::sqrt(r2), 1e-5f * std::sqrt(r2));
    // The estimate: L = albedo / pi * sum(Phi K).
    for (int ch = 0; ch < 3; ++ch) {
      double flux = 0;
      for (uint32_t j = 0; j < m; ++j) {
        const auto& p = photons[candidates[j].second];
        double w =
            c.kernel == KNN_KERNEL_EPANECHNIKOV ? 2.0 * (1.0 - candidates[j].first / r2) : 1.0;
        flux += p.power[ch] * w;
      }
      double expected_l = albedo[q * 4 + ch] / kPi * flux / (kPi * r2);
      EXPECT_NEAR(image[q * 4 + ch], expected_l, 1e-4 * expected_l + 1e-12) << "channel " << ch;
    }
  }
  EXPECT_EQ(stats.short_queries, short_queries);
  EXPECT_EQ(stats.found, found);
  EXPECT_LE(swaps, kW * kH / 100) << "ties should be rare on random photons";
  uint32_t histogram = 0;
  for (uint32_t b : stats.histogram) histogram += b;
  EXPECT_EQ(histogram, kW * kH - std::count_if(queries.begin(), queries.end(),
                                               [](const auto& q) { return q.found == 0; }));
  if (c.search == KNN_SEARCH_GRID) {
    EXPECT_GT(stats.occupied, 0u);
    EXPECT_LE(stats.occupied, grid.layout().cells());
  }
  EXPECT_GT(stats.heap_entries, found);  // each found photon was written at least once
  std::printf("%s: %u queries short of k, %.0f photons visited per query, %u cells\n",
              ::testing::PrintToString(c).c_str(), short_queries, double(stats.visited) / (kW * kH),
              grid.layout().cells());
}

INSTANTIATE_TEST_SUITE_P(
    Cases, KnnGridSearch,
    ::testing::Values(Case{32, 0.15f, 0.0f, KNN_KERNEL_UNIFORM, KNN_SPARSE_RMAX},
                      Case{1, 0.3f, 0.02f, KNN_KERNEL_UNIFORM, KNN_SPARSE_RMAX},
                      Case{KNN_MAX_K, 0.4f, 0.05f, KNN_KERNEL_EPANECHNIKOV, KNN_SPARSE_FARTHEST},
                      Case{100, 0.08f, 0.3f, KNN_KERNEL_UNIFORM, KNN_SPARSE_FARTHEST},
                      // Seed 003's baseline: the kd-tree, its heap in a buffer or private.
                      Case{32, 0.15f, 0.0f, KNN_KERNEL_UNIFORM, KNN_SPARSE_RMAX, KNN_SEARCH_KDTREE,
                           KNN_HEAP_GLOBAL},
                      Case{KNN_MAX_K, 0.25f, 0.0f, KNN_KERNEL_EPANECHNIKOV, KNN_SPARSE_FARTHEST,
                           KNN_SEARCH_KDTREE, KNN_HEAP_PRIVATE},
                      Case{100, 0.08f, 0.3f, KNN_KERNEL_UNIFORM, KNN_SPARSE_FARTHEST,
                           KNN_SEARCH_GRID, KNN_HEAP_GLOBAL}));

// ---- Runs through photonbench ----

fs::path work_dir(const std::string& name) { return pb::testing::work_dir("knn_test", name); }

// One measured and scored frame at 128x128 of the scene file `scene` in `dir`, knn with `params`
// (a YAML mapping; a list sweeps), references of 2 iterations in `dir`: photonbench's exit status.
int run_one_frame(const fs::path& dir, const std::string& scene, const std::string& params) {
  return run_config(dir, "name: knn-one-frame\nresolution: [128, 128]\nseed: 1\nscenes: [" +
                             (dir / scene).string() +
                             "]\nframes: {warmup: 0, count: 1, metrics_every: 1}\n"
                             "metrics: [psnr]\nlimits: {cell_seconds: 300}\n"
                             "reference: {samples: 2, cache_dir: " +
                             (dir / "refs").string() +
                             "}\ntechniques:\n  - {technique: knn, params: " + params + "}\n");
}

// A directional light straight down on a 4 m square plane (irradiance E = 2 W/m^2), photons stored
// at the first hit (store_first_hit), seen head-on from 3 m: everywhere in view the irradiance is
// E, so the estimate is L = albedo / pi * E. Per 32x32-pixel block the mean must lie within 4
// standard deviations of its photon count (Poisson, 1 / sqrt(n); the tracer's Sobol points only
// lower it) plus the k-nearest estimate's own bias, at most 1 / (k - 1) (E[k / (pi r_k^2)] =
// k / (k - 1) times the density for Poisson points: the k-th photon lies on the disc's edge).
TEST(Knn, UniformlyLitPlaneMatchesTheClosedForm) {
  constexpr int kSize = 128, kBlock = 32, kK = 64;
  constexpr double kE = 2.0, kAlbedo = 0.5, kPlane = 4.0;
  fs::path dir = work_dir("plane");
  std::ofstream(dir / "lit-plane.yaml") << R"(purpose: a uniformly lit plane (techniques/knn/tests)
camera: {position: [0, 3, 0], target: [0, 0, 0], up: [0, 0, -1], fov_deg: 60}
lights:
  - {name: sun, type: directional, direction: [0, -1, 0], irradiance: 2}
materials:
  grey: {type: diffuse, albedo: [0.5, 0.5, 0.5]}
objects:
  - {name: floor, shape: {type: quad, size: [4, 4]}, material: grey}
)";
  ASSERT_EQ(run_one_frame(dir, "lit-plane.yaml",
                          "{photons: 200000, k: 64, r_max: 0.5, max_bounces: 2, "
                          "store_first_hit: true}"),
            0)
      << "see " << (dir / "log.txt");
  fs::path cell = find_cell(dir, "knn");
  ASSERT_FALSE(cell.empty());
  auto record = read_json(cell / "cell.json");
  EXPECT_EQ(record["status"], "ok") << record.dump();
  auto sums = counters(cell);
  EXPECT_EQ(sums["short_queries"], 0);
  EXPECT_EQ(sums["truncated_queries"], 0);
  EXPECT_NEAR(sums["mean_k"], kK, 1e-9);
  const double density = sums["photons_stored"] / (kPlane * kPlane);  // all on the plane
  auto image = frame_image(cell, 0, "indirect");
  const double pixel = 2 * std::tan(60.0 * kPi / 360.0) * 3.0 / kSize;
  const double expected = kAlbedo / kPi * kE;
  double worst = 0;
  for (int by = 0; by < kSize / kBlock; ++by)
    for (int bx = 0; bx < kSize / kBlock; ++bx) {
      double sum = 0;
      for (int j = by * kBlock; j < (by + 1) * kBlock; ++j)
        for (int i = bx * kBlock; i < (bx + 1) * kBlock; ++i) sum += image.at(i, j, 0);
      const double mean = sum / (kBlock * kBlock);
      const double photons = density * (kBlock * pixel) * (kBlock * pixel);
      const double tolerance = 4.0 / std::sqrt(photons) + 1.0 / (kK - 1) + 0.005;
      worst = std::max(worst, std::abs(mean / expected - 1.0));
      EXPECT_NEAR(mean / expected, 1.0, tolerance)
          << "block " << bx << "," << by << " (" << photons << " photons)";
    }
  std::printf("lit plane: worst block off by %.4f of E (%.0f photons / m^2)\n", worst, density);
  fs::remove_all(dir);
}

// caustics: true puts pure caustic photons (L S+ D) in the map. A directional light straight down
// (E = 2 W/m^2) meets a 1 m square mirror (specular 0.9) tilted 45 degrees, which sends it
// horizontally onto a wall 2 m away, met head-on: inside the reflected beam the wall's irradiance
// is 0.9 E, and it has no other light (the light grazes the wall; nothing else is in the scene).
// The camera stands in the beam and looks at the wall, whose central 64x64 pixels lie inside the
// lit 0.71 x 1 m rectangle. With caustics the estimate there is albedo / pi x 0.9 E within 4
// Poisson deviations plus the k-nearest bias; without, the map is empty (the photons' only diffuse
// hit follows a specular one) and so is the image.
TEST(Knn, CausticPhotonsJoinTheMapWhenAsked) {
  constexpr int kSize = 128, kBlock = 64, kK = 64;
  constexpr double kE = 2.0, kMirror = 0.9, kAlbedo = 0.5;
  fs::path dir = work_dir("caustics");
  std::ofstream(dir / "mirror-beam.yaml")
      << R"(purpose: a mirror-reflected beam (techniques/knn/tests)
camera: {position: [1, 0, 0], target: [2, 0, 0], fov_deg: 60}
lights:
  - {name: sun, type: directional, direction: [0, -1, 0], irradiance: 2}
materials:
  grey: {type: diffuse, albedo: [0.5, 0.5, 0.5]}
  mirror: {type: mirror, specular: 0.9}
objects:
  - {name: mirror, shape: {type: quad, size: [1, 1]}, material: mirror,
     transform: {rotate_deg: [0, 0, -45]}}
  - {name: wall, shape: {type: quad, size: [4, 4]}, material: grey,
     transform: {translate: [2, 0, 0], rotate_deg: [0, 0, 90]}}
)";
  ASSERT_EQ(run_one_frame(dir, "mirror-beam.yaml",
                          "{photons: 200000, k: 64, r_max: 0.5, max_bounces: 2, "
                          "caustics: [false, true]}"),
            0)
      << "see " << (dir / "log.txt");
  fs::path with = find_cell(dir, "knn", {{"caustics", "true"}});
  fs::path without = find_cell(dir, "knn", {{"caustics", "false"}});
  ASSERT_FALSE(with.empty());
  ASSERT_FALSE(without.empty());
  EXPECT_EQ(counters(without)["photons_stored"], 0);
  auto sums = counters(with);
  EXPECT_EQ(sums["truncated_queries"], 0);
  // About 2% of the light's photons meet the mirror (its 0.71 m^2 of the disc over the scene's
  // bounds that a directional light covers); 3,768 here.
  ASSERT_GT(sums["photons_stored"], 2000);
  // Every stored photon lies in the lit rectangle: 0.71 m (the mirror's height) x 1 m.
  const double density = sums["photons_stored"] / (std::sqrt(0.5) * 1.0);
  const double pixel = 2 * std::tan(60.0 * kPi / 360.0) * 1.0 / kSize;
  const double photons = density * (kBlock * pixel) * (kBlock * pixel);
  const double tolerance = 4.0 / std::sqrt(photons) + 1.0 / (kK - 1) + 0.005;
  const double expected = kAlbedo / kPi * kMirror * kE;
  const int first = (kSize - kBlock) / 2;
  for (const auto& [cell, share] : {std::pair{with, 1.0}, std::pair{without, 0.0}}) {
    auto image = frame_image(cell, 0, "indirect");
    double sum = 0;
    for (int j = first; j < first + kBlock; ++j)
      for (int i = first; i < first + kBlock; ++i) sum += image.at(i, j, 0);
    const double mean = sum / (kBlock * kBlock);
    EXPECT_NEAR(mean / expected, share, share > 0 ? tolerance : 1e-9)
        << cell.filename() << " (" << photons << " photons in the block)";
    std::printf("mirror beam, caustics %s: %.4f of the closed form (tolerance %.4f)\n",
                share > 0 ? "on" : "off", mean / expected, tolerance);
  }
  fs::remove_all(dir);
}

// On cornell-box (light and geometry still; only the camera sways) with the same photons every
// frame, rebuild: static builds its grid once, in setup (setup_builds 1, grid_builds 0 in every
// frame, its cost in setup_build_ms), every_frame builds one per frame, and the two give the same
// indirect images (to float summation order: photons of one cell are sorted in no fixed order).
TEST(Knn, StaticModeBuildsOnceAndMatchesEveryFrame) {
  fs::path dir = work_dir("static");
  std::string yaml =
      "name: knn-static\nresolution: [96, 54]\nseed: 1\nscenes: [cornell-box]\n"
      "frames: {warmup: 1, count: 3, metrics_every: 1}\nmetrics: [psnr]\n"
      "limits: {cell_seconds: 300}\nreference: {samples: 2, cache_dir: " +
      (dir / "refs").string() +
      "}\ntechniques:\n"
      "  - technique: knn\n"
      "    params: {photons: 20000, k: 32, fresh_photons: false, rebuild: [every_frame, static]}\n";
  ASSERT_EQ(run_config(dir, yaml), 0) << "see " << (dir / "log.txt");
  fs::path every = find_cell(dir, "knn", {{"rebuild", "every_frame"}});
  fs::path once = find_cell(dir, "knn", {{"rebuild", "static"}});
  ASSERT_FALSE(every.empty());
  ASSERT_FALSE(once.empty());
  for (const fs::path& cell : {every, once}) {
    auto record = read_json(cell / "cell.json");
    EXPECT_EQ(record["status"], "ok") << record.dump();
    EXPECT_EQ(record["validation"], validation_on());
  }
  auto e = counters(every), s = counters(once);
  EXPECT_EQ(e["grid_builds"], 3);
  EXPECT_EQ(e["setup_builds"], 0);
  EXPECT_EQ(s["grid_builds"], 0);
  for (double builds : counter_series(once, "setup_builds")) EXPECT_EQ(builds, 1);
  EXPECT_GT(s["setup_build_ms"], 0);
  EXPECT_GT(s["setup_trace_ms"], 0);
  EXPECT_EQ(e["photons_stored"], s["photons_stored"]);
  EXPECT_GT(e["photons_stored"], 0);
  for (int frame : {1, 2, 3}) {
    auto a = frame_image(every, frame, "indirect"), b = frame_image(once, frame, "indirect");
    ASSERT_EQ(a.pixels.size(), b.pixels.size());
    double peak = 0, diff = 0;
    for (size_t i = 0; i < a.pixels.size(); ++i) {
      peak = std::max<double>(peak, std::abs(a.pixels[i]));
      diff = std::max<double>(diff, std::abs(a.pixels[i] - b.pixels[i]));
    }
    EXPECT_GT(peak, 0) << "frame " << frame;
    EXPECT_LE(diff, 1e-5 * peak) << "frame " << frame;
  }
  fs::remove_all(dir);
}

// A k above the compiled cap is refused by the schema's range, and a kernel that cannot work with
// the k given by the technique's check: both before any work, at the config's file, line and key.
TEST(Knn, BadParametersAreRefusedWithTheirKey) {
  PlanScratch scratch("knn_test_check");
  auto error = [&](const std::string& params) -> std::string {
    try {
      scratch.plan("name: t\nscenes: [cornell-box]\ntechniques:\n  - technique: knn\n    params: " +
                   params + "\n");
    } catch (const pb::InputError& e) {
      return e.what();
    }
    return "";
  };
  std::string e = error("{k: 513}");
  EXPECT_NE(e.find("config.yaml:5:"), std::string::npos) << e;
  EXPECT_NE(e.find("techniques[0].params.k"), std::string::npos) << e;
  EXPECT_NE(e.find("512"), std::string::npos) << e;
  e = error("{k: 1, kernel: epanechnikov}");
  EXPECT_NE(e.find("config.yaml:5:"), std::string::npos) << e;
  EXPECT_NE(e.find("techniques[0].params.k: 1 with kernel epanechnikov"), std::string::npos) << e;
  EXPECT_EQ(error("{k: 2, kernel: epanechnikov}"), "");
  EXPECT_EQ(error("{k: 512, rebuild: static, r_max: 0.1}"), "");
}

}  // namespace knn_test
