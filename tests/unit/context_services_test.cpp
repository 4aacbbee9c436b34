// Two Context services run in-process through a cell's frame loop. An estimate per path class
// (Context::class_output): a technique writes a known image into one class; the frame loop writes
// it beside the metric frame, and scoring scores it against that class's reference (metrics.csv
// rows with path_class = the class), while the combined output is still scored against the combined
// reference. Camera paths (Context::camera_paths through trace_and_upload_camera_paths): the paths
// start where the G-buffer's camera looks, and the buffer holds them as traced.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
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
namespace context_services_test {

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

// A one-cell run of a lit floor: its folder, config, scene and renderer.
struct FloorCell {
  FloorCell(const std::string& name)
      : dir(fs::temp_directory_path() /
            ("pb_context_services_" + name + "_" + std::to_string(::getpid()))) {
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
    config = config::load_config(dir / "config.yaml", {});
    scene = scene::load_scene(dir / "floor.yaml");
    renderer = std::make_unique<Renderer>(
        gpu::Device::Options{}, scene::load_scene(dir / "floor.yaml"), config.width, config.height);
    cell.id = "floor__" + name + "__0";
  }
  ~FloorCell() { fs::remove_all(dir); }
  // Plays the cell's frames; the metric frames written.
  std::vector<uint32_t> run(Technique& technique, std::optional<trace::PathClass> own_class) {
    record = std::make_unique<CellRecord>(cell);
    log = std::make_unique<FrameLog>(dir);
    loop = std::make_unique<FrameLoop>(config, *renderer, *log, *record, dir, own_class, 0);
    return loop->run(technique);
  }
  fs::path dir;
  config::Config config;
  scene::Scene scene;
  std::unique_ptr<Renderer> renderer;
  Cell cell;
  std::unique_ptr<CellRecord> record;
  std::unique_ptr<FrameLog> log;
  std::unique_ptr<FrameLoop> loop;
};

TEST(ClassOutput, ScoredAgainstItsClassReference) {
  FloorCell floor("flat");
  const std::string direct_class = "C L | C D L";
  FlatCausticsTechnique technique;
  technique.setup(floor.renderer->ctx, Params({}));
  EXPECT_NE(technique.refused_combined.find("'combined' is not a path class"), std::string::npos)
      << technique.refused_combined;
  EXPECT_NE(technique.refused_unknown.find("indirect_caustics"), std::string::npos)
      << technique.refused_unknown;  // the message lists the classes
  std::vector<uint32_t> written;
  try {
    written = floor.run(technique, trace::reference_class_of(direct_class));
  } catch (const CellFailure& failure) {
    FAIL() << "frame " << failure.frame.value_or(0) << ": " << failure.reason;
  }
  ASSERT_EQ(written, std::vector<uint32_t>{1});
  EXPECT_TRUE(technique.same_image);
  ASSERT_EQ(floor.loop->class_outputs(), std::vector<trace::PathClass>{trace::PathClass::caustics});
  const io::Image caustics = io::read_image(floor.dir / "images" / "frame_0001_caustics.exr");
  for (size_t i = 0; i < caustics.pixels.size(); ++i)
    ASSERT_EQ(caustics.pixels[i], i % 4 == 3 ? 1.f : kCaustics[i % 4]) << i;

  score_cell(floor.config, floor.cell, floor.scene, written, direct_class, floor.dir,
             floor.loop->class_outputs());
  const auto csv = io::read_csv(floor.dir / "metrics.csv");
  ASSERT_EQ(csv.size(), 4u);  // header, combined, direct, caustics
  const auto& header = csv[0];
  const size_t rmse = size_t(std::find(header.begin(), header.end(), "rmse") - header.begin());
  ASSERT_LT(rmse, header.size());
  EXPECT_EQ(csv[1][1], "combined");
  EXPECT_EQ(csv[2][1], "direct");
  ASSERT_EQ(csv[3][1], "caustics");
  // The row equals the metric computed here against the caustics reference (black on a lone floor),
  // and differs from the same image scored against the combined reference.
  trace::ReferenceCache cache(floor.dir / "cache");
  const trace::ReferenceOptions options = reference_options(floor.config, 0);
  const scene::Scene& scene = floor.scene;
  const auto own = cache.get_entry(scene, scene.at(1), trace::PathClass::caustics, 24, 16, options);
  const auto combined =
      cache.get_entry(scene, scene.at(1), trace::PathClass::combined, 24, 16, options);
  ASSERT_TRUE(own && combined);
  const double expected = metrics::evaluate(own->mean, caustics).rmse;
  const double against_combined = metrics::evaluate(combined->mean, caustics).rmse;
  EXPECT_NEAR(std::stod(csv[3][rmse]) / expected, 1.0, 1e-5);
  EXPECT_GT(std::abs(against_combined - expected), 0.05 * expected);
}

// Traces and uploads camera paths at each frame, and keeps the last frame's G-buffer positions.
class CameraPathTechnique final : public Technique {
 public:
  void setup(Context&, const Params&) override {}
  void render(Context& ctx) override {
    ctx.shared().gbuffer();
    count = trace_and_upload_camera_paths(ctx, {}, batch, paths, "camera-paths");
    ctx.flush();
    uploaded.resize(batch.paths.size());
    std::memcpy(uploaded.data(), paths.mapped(), uploaded.size() * sizeof(trace::CameraPathRecord));
    ctx.gpu().read_image(*ctx.shared().gbuffer_images().position, gbuffer_position);
    ctx.shared().direct_light();
    ctx.shared().shade(nullptr);
  }
  trace::CameraPathBatch batch;
  gpu::Buffer paths;
  uint32_t count = 0;
  std::vector<trace::CameraPathRecord> uploaded;
  std::vector<float> gbuffer_position;
};

TEST(CameraPathService, StartsWhereTheGBufferLooksAndUploadsThePaths) {
  FloorCell floor("paths");
  CameraPathTechnique technique;
  try {
    floor.run(technique, std::nullopt);
  } catch (const CellFailure& failure) {
    FAIL() << "frame " << failure.frame.value_or(0) << ": " << failure.reason;
  }
  const uint32_t pixels = floor.config.width * floor.config.height;
  ASSERT_EQ(technique.count, pixels);
  ASSERT_EQ(technique.batch.paths.size(), size_t(pixels));
  EXPECT_EQ(std::memcmp(technique.uploaded.data(), technique.batch.paths.data(),
                        pixels * sizeof(trace::CameraPathRecord)),
            0);
  ASSERT_EQ(technique.gbuffer_position.size(), size_t(pixels) * 4);
  const glm::vec3 eye = floor.scene.at(1).camera.position;
  uint32_t surfaces = 0;
  for (uint32_t p = 0; p < pixels; ++p) {
    const trace::CameraPathRecord& path = technique.batch.paths[p];
    const float* g = &technique.gbuffer_position[size_t(p) * 4];
    if (g[3] <= 0.f) {  // background: the primary ray leaves the scene
      EXPECT_TRUE(path.flags & PB_CAMERA_PATH_ESCAPED) << p;
      continue;
    }
    ++surfaces;
    ASSERT_TRUE(trace::ends_diffuse(path)) << p;
    EXPECT_EQ(trace::specular_vertices(path), 0u) << p;
    // The rasterised and the traced first hit of the pixel's centre: the same point (within the
    // depth buffer's and the ray's float precision).
    EXPECT_NEAR(glm::distance(path.position, glm::vec3(g[0], g[1], g[2])), 0.f, 1e-3f) << p;
    EXPECT_NEAR(glm::distance(path.position, eye), g[3], 1e-3f) << p;
  }
  EXPECT_GT(surfaces, pixels / 2);
}

}  // namespace context_services_test
}  // namespace pb::run
