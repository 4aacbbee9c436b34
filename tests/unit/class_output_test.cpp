// An estimate per path class (Context::class_output): a technique run in-process writes a known
// image into one class; the frame loop writes it beside the metric frame, and scoring scores it
// against that class's reference (metrics.csv rows with path_class = the class), while the combined
// output is still scored against the combined reference.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cell/cell_record.h"
#include "cell/frame_log.h"
#include "cell/frame_loop.h"
#include "cell/scoring.h"
#include "config/config.h"
#include "io/image.h"
#include "io/results.h"
#include "metrics/metrics.h"
#include "photonbench/error.h"
#include "plan/plan.h"
#include "reference/reference.h"
#include "scene/scene.h"

namespace pb::run {
namespace class_output_test {

namespace fs = std::filesystem;

constexpr std::array<float, 4> kCaustics = {0.25f, 0.5f, 0.75f, 0.f};

// The direct technique's passes, and a flat colour as its estimate of the caustics.
class FlatCausticsTechnique final : public Technique {
 public:
  void setup(Context& ctx, const Params&) override {
    try {
      ctx.class_output("combined");
    } catch (const Error& e) {
      refused_combined = e.what();
    }
    try {
      ctx.class_output("caustic");
    } catch (const Error& e) {
      refused_unknown = e.what();
    }
  }
  void render(Context& ctx) override {
    ctx.shared().gbuffer();
    ctx.shared().direct_light();
    const gpu::Image& caustics = ctx.class_output("C D S+ L");  // the class by its expression
    same_image = &caustics == &ctx.class_output("caustics");
    ctx.cmd().clearColorImage(
        caustics.handle(), vk::ImageLayout::eGeneral, vk::ClearColorValue(kCaustics),
        vk::ImageSubresourceRange{vk::ImageAspectFlagBits::eColor, 0, 1, 0, 1});
    gpu::full_barrier(ctx.cmd());
    ctx.shared().shade(nullptr);
  }
  std::string refused_combined, refused_unknown;
  bool same_image = false;
};

TEST(ClassOutput, ScoredAgainstItsClassReference) {
  const fs::path dir =
      fs::temp_directory_path() / ("pb_class_output_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "images");
  std::ofstream(dir / "floor.yaml")
      << "purpose: a lit floor\nfps: 1\nframes: 1\n"
         "camera: {position: [0, 3, 2], target: [0, 0, 0], fov_deg: 50}\n"
         "lights: [{type: point, position: [0, 2, 0], power: 40}]\n"
         "materials: {floor: {type: diffuse}}\n"
         "objects: [{shape: {type: quad, size: [8, 8]}, material: floor}]\n";
  std::ofstream(dir / "config.yaml")
      << "name: t\nresolution: [24, 16]\nscenes: [" << (dir / "floor.yaml").string()
      << "]\ntechniques: [{technique: direct}]\n"
         "frames: {warmup: 1, count: 1, metrics_every: 1}\n"
      << fmt::format("reference: {{samples: 8, cache_dir: {}}}\n", (dir / "cache").string());
  const config::Config config = config::load_config(dir / "config.yaml", {});
  const scene::Scene scene = scene::load_scene(dir / "floor.yaml");
  Renderer renderer({}, scene::load_scene(dir / "floor.yaml"), config.width, config.height);
  Cell cell;
  cell.id = "floor__flat__0";
  CellRecord record(cell);
  FrameLog log(dir);
  const std::string direct_class = "C L | C D L";
  FrameLoop loop(config, renderer, log, record, dir, trace::reference_class_of(direct_class), 0);
  FlatCausticsTechnique technique;
  technique.setup(renderer.ctx, Params({}));
  EXPECT_NE(technique.refused_combined.find("'combined' is not a path class"), std::string::npos)
      << technique.refused_combined;
  EXPECT_NE(technique.refused_unknown.find("indirect_caustics"), std::string::npos)
      << technique.refused_unknown;  // the message lists the classes
  std::vector<uint32_t> written;
  try {
    written = loop.run(technique);
  } catch (const CellFailure& failure) {
    FAIL() << "frame " << failure.frame.value_or(0) << ": " << failure.reason;
  }
  ASSERT_EQ(written, std::vector<uint32_t>{1});
  EXPECT_TRUE(technique.same_image);
  ASSERT_EQ(loop.class_outputs(), std::vector<trace::PathClass>{trace::PathClass::caustics});
  const io::Image caustics = io::read_image(dir / "images" / "frame_0001_caustics.exr");
  for (size_t i = 0; i < caustics.pixels.size(); ++i)
    ASSERT_EQ(caustics.pixels[i], i % 4 == 3 ? 1.f : kCaustics[i % 4]) << i;

  score_cell(config, cell, scene, written, direct_class, dir, loop.class_outputs());
  const auto csv = io::read_csv(dir / "metrics.csv");
  ASSERT_EQ(csv.size(), 4u);  // header, combined, direct, caustics
  const auto& header = csv[0];
  const size_t rmse = size_t(std::find(header.begin(), header.end(), "rmse") - header.begin());
  ASSERT_LT(rmse, header.size());
  EXPECT_EQ(csv[1][1], "combined");
  EXPECT_EQ(csv[2][1], "direct");
  ASSERT_EQ(csv[3][1], "caustics");
  // The row equals the metric computed here against the caustics reference (black on a lone floor),
  // and differs from the same image scored against the combined reference.
  trace::ReferenceCache cache(dir / "cache");
  const trace::ReferenceOptions options = reference_options(config);
  const auto own = cache.get_entry(scene, scene.at(1), trace::PathClass::caustics, 24, 16, options);
  const auto combined =
      cache.get_entry(scene, scene.at(1), trace::PathClass::combined, 24, 16, options);
  ASSERT_TRUE(own && combined);
  const double expected = metrics::evaluate(own->mean, caustics).rmse;
  const double against_combined = metrics::evaluate(combined->mean, caustics).rmse;
  EXPECT_NEAR(std::stod(csv[3][rmse]) / expected, 1.0, 1e-5);
  EXPECT_GT(std::abs(against_combined - expected), 0.05 * expected);
  fs::remove_all(dir);
}

}  // namespace class_output_test
}  // namespace pb::run
