// A pb::Context for unit tests that drive toolkit passes directly on a Device (no runner, no
// scene): one command buffer recorded between begin() and submit(), pass scopes that time nothing,
// counters and warnings kept in maps, a G-buffer the test fills itself, and a camera it sets.
// Shared passes other than gbuffer_images() and the tracer are not available (they throw).
#pragma once

#include <glm/gtc/matrix_transform.hpp>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "photonbench/context.h"
#include "photonbench/gpu.h"

namespace pb::testing {

class TestGBuffer final : public SharedPasses {
 public:
  TestGBuffer(gpu::Device& gpu, uint32_t width, uint32_t height) {
    auto usage = vk::ImageUsageFlagBits::eStorage | vk::ImageUsageFlagBits::eTransferDst |
                 vk::ImageUsageFlagBits::eTransferSrc;
    auto format = vk::Format::eR32G32B32A32Sfloat;
    position = gpu.create_image("test/position", {width, height}, format, usage);
    normal = gpu.create_image("test/normal", {width, height}, format, usage);
    albedo = gpu.create_image("test/albedo", {width, height}, format, usage);
    depth = gpu.create_image("test/depth", {width, height}, format, usage);
  }
  // Uploads RGBA32F texels (width * height * 4 floats) into one of the images.
  static void upload(gpu::Device& gpu, const gpu::Image& image, const std::vector<float>& rgba) {
    auto bytes = vk::DeviceSize(rgba.size() * sizeof(float));
    gpu::Buffer staging = gpu.create_buffer(
        "test/staging", bytes, vk::BufferUsageFlagBits::eTransferSrc, gpu::Memory::host_visible);
    std::memcpy(staging.mapped(), rgba.data(), bytes);
    gpu.submit_and_wait([&](vk::CommandBuffer cmd) {
      vk::BufferImageCopy region{0,         0,
                                 0,         {vk::ImageAspectFlagBits::eColor, 0, 0, 1},
                                 {0, 0, 0}, {image.extent().width, image.extent().height, 1}};
      cmd.copyBufferToImage(staging.handle(), image.handle(), vk::ImageLayout::eGeneral, region);
      gpu::full_barrier(cmd);
    });
  }

  void gbuffer() override { throw std::logic_error("test G-buffer: filled by the test"); }
  void direct_light() override { throw std::logic_error("test context: no direct light"); }
  void shade(const gpu::Image*) override { throw std::logic_error("test context: no shade"); }
  void configure_shadows(uint32_t, float, float) override {}
  void configure_direct_light(const DirectLightSettings&) override {}
  GBuffer gbuffer_images() const override { return {&position, &normal, &albedo, &depth}; }
  const gpu::Image& direct_image() const override { throw std::logic_error("no direct image"); }
  const gpu::Buffer& frame_buffer() const override { throw std::logic_error("no frame buffer"); }
  const gpu::Buffer& material_buffer() const override { throw std::logic_error("no materials"); }
  const gpu::Buffer& light_buffer() const override { throw std::logic_error("no lights"); }
  SceneTriangles scene_triangles() override { throw std::logic_error("test context: no scene"); }
  void draw_scene(const SceneTarget&, std::optional<glm::mat4>) override {
    throw std::logic_error("test context: no scene");
  }

  gpu::Image position, normal, albedo, depth;
};

class TestContext final : public Context {
 public:
  TestContext(gpu::Device& gpu, SharedPasses& shared) : gpu_(gpu), shared_(shared) {
    pool_ = vk::raii::CommandPool(
        gpu.device(), {vk::CommandPoolCreateFlagBits::eResetCommandBuffer, gpu.queue_family()});
    buffers_ =
        vk::raii::CommandBuffers(gpu.device(), {*pool_, vk::CommandBufferLevel::ePrimary, 1});
    begin();
  }
  ~TestContext() override {
    if (recording_) (*buffers_[0]).end();
  }
  // A camera at `eye` looking at `target` (up y), vertical fov in radians.
  void set_camera(uint32_t width, uint32_t height, glm::vec3 eye, glm::vec3 target, float fov_y,
                  glm::vec3 up = {0, 1, 0}) {
    frame_.index = 0;
    frame_.width = width;
    frame_.height = height;
    frame_.camera.view = glm::lookAt(eye, target, up);
    frame_.camera.projection = glm::perspective(fov_y, float(width) / float(height), 0.01f, 100.0f);
    frame_.camera.view_projection = frame_.camera.projection * frame_.camera.view;
    frame_.camera.inverse_view_projection = glm::inverse(frame_.camera.view_projection);
    frame_.camera.position = eye;
    frame_.camera.fov_y = fov_y;
  }
  // Submits what is recorded, waits, and starts a fresh recording.
  void submit() {
    vk::CommandBuffer cmd = *buffers_[0];
    gpu::full_barrier(cmd);
    vk::MemoryBarrier to_host{vk::AccessFlagBits::eMemoryWrite, vk::AccessFlagBits::eHostRead};
    cmd.pipelineBarrier(vk::PipelineStageFlagBits::eAllCommands, vk::PipelineStageFlagBits::eHost,
                        {}, to_host, {}, {});
    cmd.end();
    recording_ = false;
    vk::raii::Fence fence(gpu_.device(), vk::FenceCreateInfo{});
    gpu_.queue().submit(vk::SubmitInfo{{}, {}, cmd}, *fence);
    (void)gpu_.device().waitForFences(*fence, VK_TRUE, UINT64_MAX);
    begin();
  }

  gpu::Device& gpu() override { return gpu_; }
  vk::CommandBuffer cmd() override { return *buffers_[0]; }
  void flush() override { submit(); }
  PassScope pass(std::string_view) override { return PassScope(nullptr, 0); }
  void count(const Counter& counter, double value) override {
    counters[std::string(counter.name)] = value;
  }
  void warn(std::string_view message) override { warnings.emplace_back(message); }
  const FrameInfo& frame() const override { return frame_; }
  SharedPasses& shared() override { return shared_; }
  trace::PhotonTracer& photon_tracer() override {
    throw std::logic_error("test context: no tracer");
  }
  const gpu::Image& output() override { throw std::logic_error("test context: no output"); }
  void camera_paths(const trace::CameraPathSettings&, trace::CameraPathBatch&) override {
    throw std::logic_error("test context: no camera paths");
  }
  const gpu::Image& class_output(std::string_view) override {
    throw std::logic_error("test context: no class outputs");
  }

  std::map<std::string, double> counters;
  std::vector<std::string> warnings;

 private:
  void begin() {
    (*buffers_[0]).reset();
    (*buffers_[0])
        .begin(vk::CommandBufferBeginInfo{vk::CommandBufferUsageFlagBits::eOneTimeSubmit});
    recording_ = true;
  }
  gpu::Device& gpu_;
  SharedPasses& shared_;
  FrameInfo frame_{};
  vk::raii::CommandPool pool_{nullptr};
  vk::raii::CommandBuffers buffers_{nullptr};
  bool recording_ = false;
};

}  // namespace pb::testing
