// What a technique renders through. FrameCommands owns the cell's command buffers: one frame is
// recorded, submitted and waited for at a time, and a technique may flush mid-frame. FrameContext
// is pb::Context, the technique's whole view of the harness: the commands, pass scopes (the
// profiler), counters and warnings of the frame, the scene side (the World) and the images of path
// classes the technique hands back to be scored.
#pragma once

#include <cstddef>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "cell/profiler.h"
#include "cell/world.h"
#include "photonbench/context.h"
#include "photonbench/plugin.h"
#include "reference/path_class.h"

namespace pb::run {

class FrameCommands {
 public:
  explicit FrameCommands(gpu::Device& device);

  // Command buffers are reused frame after frame (allocation is measurable overhead on lavapipe).
  void begin();
  void submit_and_wait();
  // Every GPU write so far becomes visible to the host; submits, waits, and records on in a fresh
  // buffer.
  void flush();
  // After the frame's last submission: every buffer of the frame is free again.
  void end_frame();
  vk::CommandBuffer current() const { return current_; }

 private:
  gpu::Device& device_;
  vk::raii::CommandPool pool_{nullptr};
  vk::raii::Fence fence_{nullptr};
  std::vector<vk::raii::CommandBuffer> buffers_;
  size_t used_ = 0;
  vk::CommandBuffer current_ = nullptr;
};

class FrameContext final : public Context {
 public:
  FrameContext(gpu::Device& device, FrameCommands& commands, Profiler& profiler, World& world)
      : device_(device), commands_(commands), profiler_(profiler), world_(world) {}

  // A new frame: its info, no counters or warnings yet.
  void begin_frame(const FrameInfo& frame);
  const std::vector<std::pair<std::string, double>>& counters() const { return counters_; }
  const std::vector<std::string>& warnings() const { return warnings_; }
  struct CounterDeclaration {
    CounterKind kind;
    std::string unit;
  };
  // Every counter counted in this cell so far, by name (kept across frames).
  const std::map<std::string, CounterDeclaration>& counter_declarations() const {
    return declarations_;
  }
  // The counters the technique's descriptor declares: the only ones count() accepts.
  void declare_counters(std::span<const pb_counter_spec> counters);

  gpu::Device& gpu() override { return device_; }
  vk::CommandBuffer cmd() override { return commands_.current(); }
  void flush() override { commands_.flush(); }
  PassScope pass(std::string_view name) override {
    return PassScope(&profiler_, profiler_.begin_pass(name));
  }
  // Records the value and the counter's declaration; a name the descriptor does not declare, or
  // declares with another kind or unit, is pb::Error (the cell fails naming both).
  void count(const Counter& counter, double value) override;
  void warn(std::string_view message) override { warnings_.emplace_back(std::string(message)); }
  const FrameInfo& frame() const override { return frame_; }
  SharedPasses& shared() override { return world_.passes(); }
  trace::PhotonTracer& photon_tracer() override { return world_.photon_tracer(); }
  const gpu::Image& output() override { return world_.passes().output(); }
  void camera_paths(const trace::CameraPathSettings& settings,
                    trace::CameraPathBatch& out) override;
  const gpu::Image& class_output(std::string_view path_class) override;

  // The images the technique asked for through class_output, in the order it first asked.
  struct ClassOutput {
    trace::PathClass path_class;
    std::unique_ptr<gpu::Image> image;
  };
  const std::vector<ClassOutput>& class_outputs() const { return class_outputs_; }

 private:
  gpu::Device& device_;
  FrameCommands& commands_;
  Profiler& profiler_;
  World& world_;
  FrameInfo frame_{};
  std::vector<std::pair<std::string, double>> counters_;
  std::map<std::string, CounterDeclaration> declarations_;
  std::map<std::string, CounterDeclaration, std::less<>> declared_;  // by the descriptor
  std::vector<std::string> warnings_;
  std::vector<ClassOutput> class_outputs_;
};

std::string_view counter_kind_name(CounterKind kind);  // "work", "size", "ratio"

}  // namespace pb::run
