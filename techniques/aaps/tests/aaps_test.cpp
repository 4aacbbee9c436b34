// aaps: the task buffer's quadtree walk against the tracer's emission order, the density update,
// the tracer's AAPS rules and energy on cornell-glass, and end to end through `photonbench run`
// (with Vulkan validation) the screen-summed caustics against the caustics reference per msaa mode
// and the adaptivity of the density texture.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "../task_buffer.h"
#include "io/image.h"
#include "photonbench/error.h"
#include "photonbench/photons.h"
#include "run_fixture.h"
#include "scene/scene.h"
#include "trace/embree_scene.h"
#include "trace/photon_tracer.h"
#include "trace/reference.h"

namespace fs = std::filesystem;

namespace {

using namespace pb::testing;

// Densities with every case the leaf rule meets: 0 and below 1 (no photons), non-squares (floored
// to a square), exact squares, large values.
std::vector<float> mixed_density(uint32_t side, uint32_t seed) {
  std::mt19937 rng(seed);
  const float values[] = {0.f, 0.5f, 1.f, 3.9f, 4.f, 8.f, 9.f, 17.5f, 100.f};
  std::vector<float> d(size_t(side) * side);
  for (float& v : d) v = values[rng() % 9];
  return d;
}

// §1.4: the thesis's traversal (each task id walks the sum quadtree to its leaf, then its grid
// cell) visits exactly the (texel, cell) pairs the tracer emits, task by task.
TEST(AapsTaskBuffer, QuadtreeWalkIsTheTracersEmissionOrder) {
  for (uint32_t side : {1u, 2u, 16u}) {
    SCOPED_TRACE(side);
    pb::trace::EmissionDensity counts;
    counts.width = counts.height = int(side);
    counts.texels = mixed_density(side, side);
    aaps::SumQuadtree tree;
    tree.build(counts.texels, side);
    pb::trace::GridEmission grid(counts);
    uint32_t expected_total = 0;
    for (float d : counts.texels) expected_total += aaps::grid_side(d) * aaps::grid_side(d);
    ASSERT_EQ(tree.root(), expected_total);
    ASSERT_EQ(grid.tasks(), expected_total);
    std::set<std::pair<uint32_t, uint32_t>> seen;
    for (uint32_t t = 0; t < grid.tasks(); ++t) {
      aaps::SumQuadtree::Leaf leaf = tree.walk(t);
      pb::trace::GridEmission::Task task = grid.locate(t);
      ASSERT_EQ(leaf.texel, task.texel) << "task " << t;
      ASSERT_EQ(leaf.cell, task.cell) << "task " << t;
      ASSERT_EQ(leaf.m, task.m);
      ASSERT_EQ(leaf.m, aaps::grid_side(counts.texels[leaf.texel]));
      ASSERT_LT(leaf.cell, leaf.m * leaf.m);
      seen.insert({leaf.texel, leaf.cell});
      // The cell centre lies inside its texel.
      uint32_t x = task.texel % side, y = task.texel / side;
      EXPECT_GE(task.uv.x * side, float(x));
      EXPECT_LT(task.uv.x * side, float(x + 1));
      EXPECT_GE(task.uv.y * side, float(y));
      EXPECT_LT(task.uv.y * side, float(y + 1));
    }
    EXPECT_EQ(seen.size(), expected_total);  // every (texel, cell) once
  }
}

// §1.10 b-c on a 2x2 texture, by hand: D' = D A / A_t + v g, then w_t D' + (1 - w_t) times the
// weighted mean of the texel's and its two in-range neighbours' previous values, floored.
TEST(AapsTaskBuffer, DensityUpdateFollowsTheFormula) {
  aaps::FeedbackParams p;
  p.target_area = 10, p.variance_gain = 4, p.temporal_weight = 0.25f, p.neighbour_weight = 0.5f;
  p.density_min = 4, p.density_max = 0;
  std::vector<float> d = {8, 16, 4, 4}, area = {20, 5, 0, 0}, var = {0, 0.5f, 0, 0};
  aaps::update_density(d, area, var, 2, p);
  // texel 0: D' = 8 * 2 = 16; neighbours 16 (right), 4 (below): mean (8 + 8 + 2) / 2 = 9.
  EXPECT_NEAR(d[0], 0.25f * 16 + 0.75f * 9, 1e-5);
  // texel 1: D' = 16 * 0.5 + 2 = 10; neighbours 8, 4: (16 + 4 + 2) / 2 = 11.
  EXPECT_NEAR(d[1], 0.25f * 10 + 0.75f * 11, 1e-5);
  // texel 2: D' = 0; neighbours 8, 4: (4 + 4 + 2) / 2 = 5 -> 3.75, floored to 4.
  EXPECT_NEAR(d[2], 4, 1e-5);
  p.density_max = 6;
  std::vector<float> high = {100, 100, 100, 100}, none(4, 0.f);
  aaps::update_density(high, std::vector<float>(4, 10.f), none, 2, p);
  EXPECT_EQ(high[0], 6);
}

struct CornellGlass {
  pb::scene::Scene scene = pb::scene::load_scene(PB_SOURCE_DIR "/scenes/cornell-glass.yaml");
  pb::scene::FrameState state = scene.at(0);
  pb::trace::EmbreeScene world{scene, state};
};

// §1.5 on cornell-glass with a uniform task buffer: every photon is a caustic photon (L S+ D) whose
// first hit was the sphere, and the grid emits exactly texels * floor(sqrt(D))^2 photons. Energy:
// the light reaching the sphere is Phi * Omega / (4 pi) (Omega its solid angle from the light);
// what is stored is that, less what escapes through the box's open front and the chained paths
// the rules drop (refraction after an internal reflection: about F (1 - F)^2 ~ 4% of it).
TEST(AapsTrace, RulesAndEnergyOnCornellGlass) {
  CornellGlass c;
  pb::trace::EmbreePhotonTracer tracer(c.world);
  ASSERT_EQ(tracer.light_count(), 1u);
  const uint32_t side = 64;
  pb::trace::EmissionDensity density;
  density.width = density.height = int(side);
  density.texels.assign(side * side, 17.f);  // floored to 16: a 4x4 grid per texel
  tracer.set_emission_density(0, &density);
  pb::trace::TraceSettings s;
  s.aaps = true;
  s.store = pb::trace::kCausticPhotons;
  s.max_bounces = 8;
  pb::trace::PhotonBatch batch;
  pb::trace::TraceStats stats = tracer.trace(s, batch);
  EXPECT_EQ(stats.paths, uint64_t(side) * side * 16);
  ASSERT_GT(batch.photons.size(), 1000u);
  uint32_t sphere = ~0u;
  for (uint32_t o = 0; o < c.scene.objects.size(); ++o)
    if (c.scene.objects[o].name == "sphere") sphere = o;
  double stored = 0;
  for (const auto& p : batch.photons) {
    ASSERT_EQ(pb::trace::photon_kind(p), pb::trace::kCausticPhotons);
    ASSERT_NE(p.object, sphere);
    ASSERT_LT(p.bounce, s.max_bounces);
    ASSERT_LT(p.path, stats.paths);
    stored += (p.power.x + p.power.y + p.power.z) / 3.0;
  }
  glm::vec3 power = tracer.light_power(0);
  glm::vec3 light = c.state.lights[0].position;
  double d = glm::length(light - glm::vec3(0.5f, 0.2f, 0.5f)), r = 0.2;
  double omega = 2 * M_PI * (1 - std::sqrt(1 - r * r / (d * d)));
  double expected = (power.x + power.y + power.z) / 3.0 * omega / (4 * M_PI);
  double ratio = stored / expected;
  std::printf("stored caustic power / power reaching the sphere = %.4f\n", ratio);
  EXPECT_GT(ratio, 0.89);  // measured 0.9097 (the grid emission is deterministic)
  EXPECT_LT(ratio, 0.93);
}

// The rules refuse what they cannot do, naming it.
TEST(AapsTrace, RefusesKeptPathsAndMissingDensities) {
  CornellGlass c;
  pb::trace::EmbreePhotonTracer tracer(c.world);
  pb::trace::TraceSettings s;
  s.aaps = true;
  s.store = pb::trace::kCausticPhotons;
  pb::trace::PhotonBatch batch;
  EXPECT_THROW(tracer.trace(s, batch), pb::InputError);  // no density set
  pb::trace::EmissionDensity odd{3, 3, std::vector<float>(9, 4.f)};
  tracer.set_emission_density(0, &odd);
  EXPECT_THROW(tracer.trace(s, batch), pb::InputError);  // not a power of two
  pb::trace::EmissionDensity ok{4, 4, std::vector<float>(16, 4.f)};
  tracer.set_emission_density(0, &ok);
  s.keep_paths = true;
  EXPECT_THROW(tracer.trace(s, batch), pb::InputError);
}

fs::path work_dir(const std::string& name) { return pb::testing::work_dir("aaps_test", name); }

constexpr int kWidth = 128, kHeight = 96;
constexpr uint32_t kReferenceSamples = 64;

std::string header(const fs::path& dir, int warmup, int count) {
  return "name: aaps-test\n"
         "resolution: [" +
         std::to_string(kWidth) + ", " + std::to_string(kHeight) +
         "]\n"
         "seed: 1\n"
         "scenes: [cornell-glass]\n"
         "limits: {cell_seconds: 300}\n"
         "frames: {warmup: " +
         std::to_string(warmup) + ", count: " + std::to_string(count) +
         ", metrics_every: " + std::to_string(count) +
         "}\n"
         "metrics: [psnr]\n"
         "reference: {samples: " +
         std::to_string(kReferenceSamples) + ", cache_dir: " + (dir / "refs").string() + "}\n";
}

double image_sum(const pb::io::Image& image) {
  double sum = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int ch = 0; ch < 3; ++ch) sum += image.at(x, y, ch);
  return sum;
}

// The thesis's energy finding (§5.1.1): once the task buffer has converged, the caustics summed
// over the screen match the caustics-only reference at the thesis's target area (19 px^2) without
// MSAA (measured 1.017 of the reference; at 2 px^2 it falls to 0.80, the no-AA energy loss of tiny
// splats); coverage-only MSAA (`all`) tests the ellipse at the pixel centre and keeps only the
// covered samples' share, and is dimmer. The per-sample modes are measured and printed, not
// bounded: on lavapipe they lose about half the energy (README, "Open problem").
TEST(Aaps, ScreenEnergyMatchesTheCausticsReference) {
  fs::path dir = work_dir("energy");
  const int warmup = 10;
  std::string common = "density_resolution: 32, target_area: 19";
  std::string yaml = header(dir, warmup, 1) + "techniques:\n";
  for (const char* mode : {"none", "all", "all_per_sample", "small_per_sample"})
    yaml += std::string("  - technique: aaps\n    params: {") + common + ", msaa: " + mode + "}\n";
  ASSERT_EQ(run_config(dir, yaml), 0) << "see " << (dir / "log.txt");

  CornellGlass c;
  pb::trace::ReferenceCache cache(dir / "refs");
  pb::trace::ReferenceOptions options;
  options.samples = kReferenceSamples;
  const uint32_t frame = uint32_t(warmup);
  pb::io::Image reference = cache.get_or_render(
      c.scene, c.scene.at(frame), pb::trace::PathClass::caustics, kWidth, kHeight, options);
  double reference_sum = image_sum(reference);
  ASSERT_GT(reference_sum, 0);
  std::map<std::string, double> ratio;
  for (const char* mode : {"none", "all", "all_per_sample", "small_per_sample"}) {
    fs::path cell = find_cell(dir, "aaps", {{"msaa", mode}});
    ASSERT_FALSE(cell.empty()) << mode;
    auto record = read_json(cell / "cell.json");
    EXPECT_EQ(record["status"], "ok") << record.dump();
    EXPECT_EQ(record["validation"], true);
    ratio[mode] = image_sum(frame_image(cell, int(frame), "caustics")) / reference_sum;
    std::printf("msaa %-16s screen caustics / reference = %.4f\n", mode, ratio[mode]);
  }
  EXPECT_NEAR(ratio["none"], 1.0, 0.05);
  EXPECT_LT(ratio["all"], ratio["none"] - 0.05);
}

// Per-frame values of one counter, in frame order.
std::vector<double> counter_series(const fs::path& cell, const std::string& name) {
  std::vector<double> values;
  std::ifstream in(cell / "counters.csv");
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    std::stringstream row(line);
    std::string frame, counter, value;
    std::getline(row, frame, ',');
    std::getline(row, counter, ',');
    std::getline(row, value, ',');
    if (counter == name) values.push_back(std::stod(value));
  }
  return values;
}

// §1.4 / §1.10: the sphere covers under 2% of the point light's directions, so a uniform task
// buffer records few of its photons; the feedback moves density onto the texels whose photons land
// on screen, and the recorded share of emitted photons rises over the first frames and stays up.
TEST(Aaps, DensityConcentratesOnTheCaustic) {
  fs::path dir = work_dir("adaptivity");
  std::string yaml = header(dir, 0, 12) +
                     "techniques:\n"
                     "  - technique: aaps\n"
                     "    params: {density_resolution: 16, target_area: 1}\n";
  ASSERT_EQ(run_config(dir, yaml), 0) << "see " << (dir / "log.txt");
  fs::path cell = find_cell(dir, "aaps");
  ASSERT_FALSE(cell.empty());
  std::vector<double> share = counter_series(cell, "recorded_share");
  ASSERT_EQ(share.size(), 12u);
  for (double s : share) std::printf("%.4f ", s);
  std::printf("\n");
  for (size_t f = 6; f < share.size(); ++f) EXPECT_GT(share[f], 3 * share[0]) << "frame " << f;
}

}  // namespace
