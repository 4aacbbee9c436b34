#include "cell/frame_context.h"

#include <fmt/format.h>

#include <array>

#include "photonbench/error.h"
#include "trace/camera_paths.h"

namespace pb::run {

FrameCommands::FrameCommands(gpu::Device& device) : device_(device) {
  pool_ = vk::raii::CommandPool(
      device.device(), {vk::CommandPoolCreateFlagBits::eResetCommandBuffer, device.queue_family()});
  fence_ = vk::raii::Fence(device.device(), vk::FenceCreateInfo{});
}

void FrameCommands::begin() {
  if (used_ == buffers_.size())
    buffers_.emplace_back(std::move(vk::raii::CommandBuffers(
        device_.device(), {*pool_, vk::CommandBufferLevel::ePrimary, 1})[0]));
  current_ = *buffers_[used_++];
  current_.begin(vk::CommandBufferBeginInfo{vk::CommandBufferUsageFlagBits::eOneTimeSubmit});
}

void FrameCommands::submit_and_wait() {
  current_.end();
  device_.queue().submit(vk::SubmitInfo{{}, {}, current_}, *fence_);
  if (device_.device().waitForFences(*fence_, VK_TRUE, UINT64_MAX) != vk::Result::eSuccess)
    throw Error("waiting for the frame's fence failed");
  device_.device().resetFences(*fence_);
  current_ = nullptr;
}

void FrameCommands::flush() {
  vk::MemoryBarrier to_host{vk::AccessFlagBits::eMemoryWrite, vk::AccessFlagBits::eHostRead};
  current_.pipelineBarrier(vk::PipelineStageFlagBits::eAllCommands,
                           vk::PipelineStageFlagBits::eHost, {}, to_host, {}, {});
  submit_and_wait();
  begin();
}

void FrameCommands::end_frame() {
  pool_.reset();
  used_ = 0;
}

void FrameContext::begin_frame(const FrameInfo& frame) {
  frame_ = frame;
  counters_.clear();
  warnings_.clear();
}

void FrameContext::declare_counters(std::span<const pb_counter_spec> counters) {
  declared_.clear();
  for (const pb_counter_spec& c : counters)
    declared_.try_emplace(c.name, CounterDeclaration{CounterKind(c.kind), c.unit ? c.unit : ""});
  // The shared passes' own counters (the many-light direct light's), for every technique.
  for (const pb_counter_spec& c : gpu::ScenePasses::kCounters)
    declared_.try_emplace(c.name, CounterDeclaration{CounterKind(c.kind), c.unit ? c.unit : ""});
}

void FrameContext::count(const Counter& counter, double value) {
  auto declared = declared_.find(counter.name);
  if (declared == declared_.end())
    throw Error(fmt::format(
        "counter '{}' ({}, {}) is not declared in the technique's descriptor (its counters)",
        counter.name, counter_kind_name(counter.kind), counter.unit));
  const CounterDeclaration& d = declared->second;
  if (d.kind != counter.kind || d.unit != counter.unit)
    throw Error(fmt::format("counter '{}' is declared as {} ({}) and counted as {} ({})",
                            counter.name, counter_kind_name(d.kind), d.unit,
                            counter_kind_name(counter.kind), counter.unit));
  std::string name(counter.name);
  declarations_.try_emplace(name, d);
  counters_.emplace_back(std::move(name), value);
}

void FrameContext::camera_paths(const trace::CameraPathSettings& settings,
                                trace::CameraPathBatch& out) {
  if (frame_.width == 0)
    throw Error("camera_paths: call it from render(), where the frame's camera is known");
  const CameraView& view = frame_.camera;
  const trace::CameraPathCamera camera{view.position, view.inverse_view_projection, view.fov_y,
                                       frame_.width, frame_.height};
  trace::trace_camera_paths(world_.embree_scene(), camera, frame_.index, world_.seed_scramble(),
                            settings, out);
}

const gpu::Image& FrameContext::class_output(std::string_view name) {
  const std::optional<trace::PathClass> path_class = trace::reference_class_of(name);
  if (!path_class || *path_class == trace::PathClass::combined) {
    std::string classes;
    for (trace::PathClass c : trace::all_path_classes())
      if (c != trace::PathClass::combined)
        classes += (classes.empty() ? "" : ", ") + std::string(trace::path_class_name(c));
    throw Error(fmt::format(
        "class_output: '{}' is not a path class a technique can hand back (one of {}; combined "
        "is the output shade() writes)",
        name, classes));
  }
  for (const ClassOutput& output : class_outputs_)
    if (output.path_class == *path_class) return *output.image;
  const vk::Extent2D extent = world_.passes().output().extent();
  auto image = std::make_unique<gpu::Image>(device_.create_image(
      fmt::format("class-output/{}", trace::path_class_name(*path_class)), extent,
      vk::Format::eR32G32B32A32Sfloat, vk::ImageUsageFlagBits::eStorage));
  device_.submit_and_wait([&](vk::CommandBuffer cmd) {
    cmd.clearColorImage(image->handle(), vk::ImageLayout::eGeneral,
                        vk::ClearColorValue(std::array<float, 4>{0.f, 0.f, 0.f, 0.f}),
                        vk::ImageSubresourceRange{vk::ImageAspectFlagBits::eColor, 0, 1, 0, 1});
  });
  class_outputs_.push_back({*path_class, std::move(image)});
  return *class_outputs_.back().image;
}

std::string_view counter_kind_name(CounterKind kind) {
  switch (kind) {
    case CounterKind::work:
      return "work";
    case CounterKind::size:
      return "size";
    case CounterKind::ratio:
      return "ratio";
  }
  return "?";
}

}  // namespace pb::run
