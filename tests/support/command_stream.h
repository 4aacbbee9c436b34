// The command recording the runner does for a frame, for tests that drive a pb::gpu::Device and a
// run::Profiler without the runner: a fresh primary command buffer per begin(), and submit() that
// ends it, submits it and waits on a fence (the profiler's fenced-timing flush is submit + begin).
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <utility>
#include <vector>

#include "photonbench/gpu.h"

namespace pb::testing {

class CommandStream {
 public:
  explicit CommandStream(gpu::Device& device)
      : device_(device),
        pool_(device.device(),
              {vk::CommandPoolCreateFlagBits::eResetCommandBuffer, device.queue_family()}),
        fence_(device.device(), vk::FenceCreateInfo{}) {}

  void begin() {
    buffers_.push_back(std::move(vk::raii::CommandBuffers(
        device_.device(), {*pool_, vk::CommandBufferLevel::ePrimary, 1})[0]));
    cmd_ = *buffers_.back();
    cmd_.begin(vk::CommandBufferBeginInfo{});
  }
  void submit() {
    cmd_.end();
    device_.queue().submit(vk::SubmitInfo{{}, {}, cmd_}, *fence_);
    EXPECT_EQ(device_.device().waitForFences(*fence_, VK_TRUE, UINT64_MAX), vk::Result::eSuccess);
    device_.device().resetFences(*fence_);
  }
  // The buffer being recorded (what the profiler's and the passes' command getters return).
  vk::CommandBuffer cmd() const { return cmd_; }

 private:
  gpu::Device& device_;
  vk::raii::CommandPool pool_;
  vk::raii::Fence fence_;
  std::vector<vk::raii::CommandBuffer> buffers_;  // kept until the test ends: submitted work
  vk::CommandBuffer cmd_;
};

}  // namespace pb::testing
