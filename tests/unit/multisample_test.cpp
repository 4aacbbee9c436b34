// Multisampled rendering through the GPU layer, as AAPS's MSAA modes use it (additive blending into
// a 4x RGBA32F target, resolved; sample-rate shading with inputs interpolated per sample): the
// resolved image is checked pixel by pixel against the coverage counted on the CPU.
#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "multisample_test_shaders.h"
#include "photonbench/gpu.h"
#include "validation.h"

namespace multisample_test {

using namespace pb;

gpu::Device& device() {
  static gpu::Device d({"", pb::testing::validation_on()});
  return d;
}

constexpr uint32_t kWidth = 48, kHeight = 32, kSamples = 4;
constexpr vk::Format kFloat4 = vk::Format::eR32G32B32A32Sfloat;
constexpr std::array<float, 4> kColour = {0.25f, 0.5f, 1.f, 2.f};

// Vulkan's standard locations for 4 samples, in pixel units (every driver we run on uses them;
// lavapipe reports standardSampleLocations).
constexpr float kSampleX[kSamples] = {0.375f, 0.875f, 0.125f, 0.625f};
constexpr float kSampleY[kSamples] = {0.125f, 0.375f, 0.625f, 0.875f};

// Whether a point of the viewport (pixel units) lies inside the ellipse inscribed in it, as the
// shader decides from the interpolated barycentrics.
bool inside(float x, float y) {
  float u = 2.f * x / float(kWidth) - 1.f, v = 2.f * y / float(kHeight) - 1.f;
  return u * u + v * v <= 1.f;
}

// Draws the ellipse `draws` times with additive blending into a target of `samples` samples,
// resolves it and returns the resolved RGBA32F texels.
std::vector<float> render(uint32_t samples, std::span<const uint32_t> fragment,
                          float min_sample_shading, int draws) {
  gpu::Device& gpu = device();
  using Usage = vk::ImageUsageFlagBits;
  gpu::Image target = gpu.create_image("multisample_test.target", {kWidth, kHeight}, kFloat4,
                                       Usage::eColorAttachment, vk::SampleCountFlagBits(samples));
  gpu::Image resolved = gpu.create_image("multisample_test.resolved", {kWidth, kHeight}, kFloat4,
                                         Usage::eColorAttachment);
  gpu::GraphicsPipelineDesc desc;
  desc.name = "multisample_test.ellipse";
  desc.vertex_spirv = kmultisample_test_ellipse_vert_spv;
  desc.fragment_spirv = fragment;
  desc.push_bytes = sizeof(kColour);
  desc.color_formats = {kFloat4};
  desc.samples = vk::SampleCountFlagBits(samples);
  desc.additive_blend = {true};
  desc.min_sample_shading = min_sample_shading;
  gpu::Pipeline pipeline = gpu.create_graphics_pipeline(desc);
  gpu.submit_and_wait([&](vk::CommandBuffer cmd) {
    vk::RenderingAttachmentInfo colour{target.view(),
                                       vk::ImageLayout::eGeneral,
                                       {},
                                       {},
                                       {},
                                       vk::AttachmentLoadOp::eClear,
                                       vk::AttachmentStoreOp::eStore,
                                       vk::ClearColorValue(std::array<float, 4>{0, 0, 0, 0})};
    vk::Rect2D area{{0, 0}, {kWidth, kHeight}};
    gpu.begin_rendering(cmd, vk::RenderingInfo{{}, area, 1, 0, colour});
    cmd.setViewport(0, vk::Viewport{0, 0, float(kWidth), float(kHeight), 0, 1});
    cmd.setScissor(0, area);
    pipeline.bind(cmd, std::span<const gpu::Resource>(), kColour);
    for (int i = 0; i < draws; ++i) cmd.draw(6, 1, 0, 0);
    gpu.end_rendering(cmd);
    gpu::full_barrier(cmd);
    vk::ImageSubresourceLayers layer{vk::ImageAspectFlagBits::eColor, 0, 0, 1};
    vk::Extent3D extent{kWidth, kHeight, 1};
    if (samples > 1)
      cmd.resolveImage(target.handle(), vk::ImageLayout::eGeneral, resolved.handle(),
                       vk::ImageLayout::eGeneral, vk::ImageResolve{layer, {}, layer, {}, extent});
    else
      cmd.copyImage(target.handle(), vk::ImageLayout::eGeneral, resolved.handle(),
                    vk::ImageLayout::eGeneral, vk::ImageCopy{layer, {}, layer, {}, extent});
    gpu::full_barrier(cmd);
  });
  std::vector<float> rgba;
  gpu.read_image(resolved, rgba);
  EXPECT_EQ(gpu.validation_errors(), 0u) << gpu.first_validation_error();
  return rgba;
}

// Pixels whose resolved value is not `draws` x colour x the expected share; a point exactly on the
// ellipse may fall either way in the GPU's interpolation, so a few are allowed by the callers.
template <class Share>
int mismatched_pixels(const std::vector<float>& rgba, int draws, Share share) {
  int wrong = 0;
  for (uint32_t y = 0; y < kHeight; ++y)
    for (uint32_t x = 0; x < kWidth; ++x) {
      float expected = float(draws) * share(x, y);
      bool ok = true;
      for (int c = 0; c < 4; ++c)
        ok = ok && std::abs(rgba[(size_t(y) * kWidth + x) * 4 + c] - expected * kColour[c]) <=
                       1e-5f * std::abs(float(draws) * kColour[c]);
      wrong += ok ? 0 : 1;
    }
  return wrong;
}

float centre_share(uint32_t x, uint32_t y) { return inside(x + 0.5f, y + 0.5f) ? 1.f : 0.f; }

float sample_share(uint32_t x, uint32_t y) {
  int n = 0;
  for (uint32_t s = 0; s < kSamples; ++s) n += inside(x + kSampleX[s], y + kSampleY[s]) ? 1 : 0;
  return float(n) / float(kSamples);
}

// Pixel rate: the ellipse is tested once, at the pixel centre, and the fragment lands on every
// sample the two triangles cover (all of them, the quad fills the viewport), so three additive
// draws resolve to exactly what a single-sample target holds: 3 x colour where the centre is
// inside.
TEST(Multisample, AdditiveBlendingResolvesToTheSumOfDraws) {
  ASSERT_GE(device().limits().max_color_samples, kSamples);
  const int draws = 3, allowed = 2;
  std::vector<float> single = render(1, kmultisample_test_ellipse_frag_spv, 0, draws);
  std::vector<float> multi = render(kSamples, kmultisample_test_ellipse_frag_spv, 0, draws);
  EXPECT_LE(mismatched_pixels(single, draws, centre_share), allowed);
  EXPECT_LE(mismatched_pixels(multi, draws, centre_share), allowed);
}

// Sample rate (sampleShadingEnable, minSampleShading 1, inputs qualified `sample`): the ellipse
// is tested at each of the 4 samples, so a pixel on its edge resolves to the share of its samples
// inside, not to all or nothing. The qualifier is what moves the interpolation: lavapipe runs one
// invocation per sample at minSampleShading 1 but interpolates unqualified inputs at the pixel
// centre (measured: every edge pixel then resolves as at pixel rate), so aaps_splat.glsl needs it.
TEST(Multisample, SampleRateShadingTestsEachSample) {
  ASSERT_GE(device().limits().max_color_samples, kSamples);
  const int draws = 2, allowed = 2;
  std::vector<float> rgba = render(kSamples, kmultisample_test_ellipse_sample_frag_spv, 1.f, draws);
  EXPECT_LE(mismatched_pixels(rgba, draws, sample_share), allowed);

  // The edge pixels' partial shares are what per-sample shading adds over pixel rate.
  int partial = 0;
  for (uint32_t y = 0; y < kHeight; ++y)
    for (uint32_t x = 0; x < kWidth; ++x) {
      float share = sample_share(x, y);
      partial += share > 0 && share < 1 ? 1 : 0;
    }
  EXPECT_GT(partial, int(kWidth));  // the fixture has edge pixels to tell the two apart
  EXPECT_GT(mismatched_pixels(rgba, draws, centre_share), partial / 2);
}

}  // namespace multisample_test
