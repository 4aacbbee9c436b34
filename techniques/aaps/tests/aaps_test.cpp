// aaps: the task buffer's quadtree walk against the tracer's emission order, the density update,
// the tracer's AAPS rules and energy on cornell-glass, and end to end through `photonbench run`
// (with Vulkan validation) the screen-summed caustics against the caustics reference per msaa mode
// and the adaptivity of the density texture.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <numeric>
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

namespace aaps_test {

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

constexpr uint32_t kReferenceSamples = 64;
// AAPS's rules on cornell-glass (one convex dielectric): a photon that hits the sphere is reflected
// once (L S D) or refracted in and out (L S S D); the chained paths (an internal reflection, about
// a tenth of the caustic power here) are dropped by design (§1.5). The reference that holds exactly
// those paths is the caustics class truncated at 3 scattering vertices.
constexpr uint32_t kAapsPathVertices = 3;

struct Frames {
  int width, height, warmup, count, metrics_every;
  uint32_t reference_bounces = 0;  // 0: untruncated
};

// A config of cornell-glass and one aaps entry with `params` (a list sweeps), run in `dir`.
std::string aaps_config(const fs::path& dir, const Frames& f, const std::string& params) {
  return fmt::format(
      "name: aaps-test\n"
      "resolution: [{}, {}]\n"
      "seed: 1\n"
      "scenes: [cornell-glass]\n"
      "limits: {{cell_seconds: 300}}\n"
      "frames: {{warmup: {}, count: {}, metrics_every: {}}}\n"
      "metrics: [psnr]\n"
      "reference: {{samples: {}, max_bounces: {}, cache_dir: {}}}\n"
      "techniques:\n"
      "  - technique: aaps\n"
      "    params: {{{}}}\n",
      f.width, f.height, f.warmup, f.count, f.metrics_every, kReferenceSamples, f.reference_bounces,
      (dir / "refs").string(), params);
}

double image_sum(const pb::io::Image& image) {
  double sum = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int ch = 0; ch < 3; ++ch) sum += image.at(x, y, ch);
  return sum;
}

// The thesis's energy finding (§5.1.1) on the paths AAPS models: once the task buffer has
// converged, the caustics summed over the screen and over 8 frames match the reference's within 5%
// for the per-sample modes; `all` tests the ellipse at the pixel centre and keeps only the covered
// samples' share, and is dimmer. The caustic's focus is sub-pixel even at 256x192 (most of its
// energy lies in a few dozen pixels, drawn by splats far smaller than a pixel), so without MSAA a
// frame's energy depends on which pixel centres the tiny splats happen to cover: it swings by
// +-20% from frame to frame as the orbiting light moves the focus (measured 0.81-1.14), and its
// mean is bounded by three standard errors of its own frames (and never tighter than 5%).
TEST(Aaps, ScreenEnergyMatchesTheCausticsReference) {
  fs::path dir = work_dir("energy");
  const Frames frames{256, 192, 10, 8, 1, kAapsPathVertices};
  const char* modes[] = {"none", "all", "all_per_sample", "small_per_sample"};
  ASSERT_EQ(run_config(dir, aaps_config(dir, frames,
                                        "density_resolution: 32, target_area: 19, msaa: [none, "
                                        "all, all_per_sample, small_per_sample]")),
            0)
      << "see " << (dir / "log.txt");

  CornellGlass c;
  pb::trace::ReferenceCache cache(dir / "refs");
  pb::trace::ReferenceOptions options;
  options.samples = kReferenceSamples;
  options.max_bounces = kAapsPathVertices;
  std::vector<double> reference;
  for (int f = frames.warmup; f < frames.warmup + frames.count; ++f)
    reference.push_back(image_sum(cache.get_or_render(c.scene, c.scene.at(uint32_t(f)),
                                                      pb::trace::PathClass::caustics, frames.width,
                                                      frames.height, options)));
  const double reference_sum = std::accumulate(reference.begin(), reference.end(), 0.0);
  ASSERT_GT(reference_sum, 0);
  std::map<std::string, double> ratio, standard_error;
  for (const char* mode : modes) {
    fs::path cell = find_cell(dir, "aaps", {{"msaa", mode}});
    ASSERT_FALSE(cell.empty()) << mode;
    auto record = read_json(cell / "cell.json");
    EXPECT_EQ(record["status"], "ok") << record.dump();
    EXPECT_EQ(record["validation"], true);
    double sum = 0, square_sum = 0;
    std::string per_frame;
    for (int i = 0; i < frames.count; ++i) {
      double frame_sum = image_sum(frame_image(cell, frames.warmup + i, "caustics"));
      double r = frame_sum / reference[size_t(i)];
      sum += frame_sum, square_sum += r * r;
      per_frame += fmt::format(" {:.3f}", r);
    }
    ratio[mode] = sum / reference_sum;
    double mean_square = square_sum / frames.count;
    double frame_mean = ratio[mode];  // close to the mean of the per-frame ratios
    standard_error[mode] =
        std::sqrt(std::max(0.0, mean_square - frame_mean * frame_mean) / double(frames.count - 1));
    std::printf("msaa %-16s screen caustics / reference = %.4f (+- %.3f; frames%s)\n", mode,
                ratio[mode], standard_error[mode], per_frame.c_str());
  }
  EXPECT_NEAR(ratio["all_per_sample"], 1.0, 0.05);
  EXPECT_NEAR(ratio["small_per_sample"], 1.0, 0.05);
  EXPECT_NEAR(ratio["none"], 1.0, std::max(0.05, 3 * standard_error["none"]));
  EXPECT_LT(ratio["all"], ratio["none"] - 0.05);
}

// §5.1.2's per-sample depth test against the single-sample G-buffer: a sample off the pixel centre
// is compared with the receiver's tangent plane met along its own ray, not with the centre's
// distance, whose error (depth gradient x offset) exceeds the 1% margin on cornell-glass's floor at
// 128x96. So tightening the margin from 5% to 1% drops per sample about what it drops at pixel
// rate, what the sphere hides near its foot (measured: pixel rate keeps 0.968 of the energy, per
// sample 0.939; with the centre's distance per sample kept 0.576).
TEST(Aaps, PerSampleDepthTestFollowsTheReceiver) {
  fs::path dir = work_dir("depth");
  ASSERT_EQ(run_config(dir, aaps_config(dir, {128, 96, 10, 1, 0},
                                        "density_resolution: 32, msaa: [none, all_per_sample], "
                                        "depth_margin: [0.01, 0.05]")),
            0)
      << "see " << (dir / "log.txt");
  std::map<std::string, double> kept;
  for (const char* mode : {"none", "all_per_sample"}) {
    std::map<std::string, double> energy;
    for (const char* margin : {"0.01", "0.05"}) {
      fs::path cell = find_cell(dir, "aaps", {{"msaa", mode}, {"depth_margin", margin}});
      ASSERT_FALSE(cell.empty()) << mode << " " << margin;
      energy[margin] = counters(cell)["caustic_energy"];
    }
    ASSERT_GT(energy["0.05"], 0);
    kept[mode] = energy["0.01"] / energy["0.05"];
    std::printf("%s caustic energy, margin 1%% / 5%%: %.4f\n", mode, kept[mode]);
  }
  EXPECT_GT(kept["all_per_sample"], kept["none"] - 0.05);
}

// §3.3.5's culling, by a splat's solid angle from the light sized for one fixed sampling (the
// thesis's base 1/512 of the emission parameter): its thresholds cull a share that falls as they
// rise, from everything at a vanishing threshold to nothing at 1 sr, and the lowest it tested
// (0.0014 sr) culls the larger splats, not all (measured on frame 0, before any feedback: 46%,
// 0.01 sr 7%; sized at one unit of the parameter, 0.0014 sr culled all).
TEST(Aaps, CullingThresholdsMeanWhatTheThesisTested) {
  fs::path dir = work_dir("culling");
  ASSERT_EQ(run_config(dir, aaps_config(dir, {128, 96, 0, 1, 0},
                                        "density_resolution: 32, cull_solid_angle: [0, 1e-9, "
                                        "0.0014, 0.01, 1]")),
            0)
      << "see " << (dir / "log.txt");
  auto culled = [&](const char* threshold) {
    fs::path cell = find_cell(dir, "aaps", {{"cull_solid_angle", threshold}});
    EXPECT_FALSE(cell.empty()) << threshold;
    return counters(cell);
  };
  // Frame 0 emits the same photons in every cell: what cull_solid_angle 0 culls is the frustum's.
  const auto none = culled("0");
  const double frustum = none.at("photons_culled"), splats = none.at("photons_recorded") - frustum;
  ASSERT_GT(splats, 50);
  auto share = [&](const char* threshold) {
    return (culled(threshold).at("photons_culled") - frustum) / splats;
  };
  std::printf("culled share: 1e-9 sr %.3f, 0.0014 sr %.3f, 0.01 sr %.3f, 1 sr %.3f\n",
              share("1e-09"), share("0.0014"), share("0.01"), share("1"));
  EXPECT_EQ(share("1e-09"), 1.0);
  EXPECT_GT(share("0.0014"), share("0.01"));
  EXPECT_LT(share("0.0014"), 0.9);
  EXPECT_GT(share("0.01"), 0.0);
  EXPECT_LT(share("1"), 0.01);
}

// §1.4 / §1.10: the sphere covers under 2% of the point light's directions, so a uniform task
// buffer records few of its photons; the feedback moves density onto the texels whose photons land
// on screen, and the recorded share of emitted photons rises over the first frames and stays up.
TEST(Aaps, DensityConcentratesOnTheCaustic) {
  fs::path dir = work_dir("adaptivity");
  ASSERT_EQ(run_config(dir, aaps_config(dir, {128, 96, 0, 12, 12},
                                        "density_resolution: 16, target_area: 1")),
            0)
      << "see " << (dir / "log.txt");
  fs::path cell = find_cell(dir, "aaps");
  ASSERT_FALSE(cell.empty());
  std::vector<double> share = counter_series(cell, "recorded_share");
  ASSERT_EQ(share.size(), 12u);
  for (double s : share) std::printf("%.4f ", s);
  std::printf("\n");
  for (size_t f = 6; f < share.size(); ++f) EXPECT_GT(share[f], 3 * share[0]) << "frame " << f;
}

}  // namespace aaps_test
