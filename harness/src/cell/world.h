// The scene side of a cell: the scene, its state at the current frame, the scene on the GPU
// (camera, lights, geometry and the shared passes that draw it) and, for techniques that trace
// photons, the Embree scene. advance_to() moves all of them to a frame at once, once per frame,
// inside the "scene-update" pass; nothing else changes the scene during a frame.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>

#include "gpu/shared_passes.h"
#include "photonbench/context.h"
#include "scene/scene.h"
#include "trace/embree_scene.h"
#include "trace/photon_tracer.h"

namespace pb::run {

class World {
 public:
  // Starts at frame 0 (so that a technique's setup sees the first frame's scene); the GPU scene is
  // first uploaded by the first advance_to(). `recorder` opens the shared passes' scopes, `cmd`
  // returns the frame's command buffer.
  World(gpu::Device& device, scene::Scene scene, uint32_t width, uint32_t height,
        PassRecorder& recorder, std::function<vk::CommandBuffer()> cmd);
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  void advance_to(uint32_t frame);

  const scene::Scene& scene() const { return scene_; }
  const scene::FrameState& state() const { return state_; }
  gpu::ScenePasses& passes() { return passes_; }
  // The Embree scene and its photon tracer are built on first use, at the current frame; techniques
  // that never trace photons pay nothing for them.
  trace::PhotonTracer& photon_tracer();
  const trace::EmbreeScene& embree_scene();
  // What a seed axis' cell hashes into every trace's seed (set_seed); none for index 0.
  std::optional<uint32_t> seed_scramble() const;
  // A seed axis' cell (plan/plan.h, Cell::seed_index > 0): every trace the techniques ask for is
  // scrambled with `seed` besides their own seed, so each seed gives independent photons. Index 0
  // leaves the technique's sequence as it is (the cell a run without a seed axis makes).
  void set_seed(uint64_t seed, uint32_t seed_index);

 private:
  scene::Scene scene_;  // first: passes_ holds a reference to it
  scene::FrameState state_;
  gpu::ScenePasses passes_;
  std::unique_ptr<trace::EmbreeScene> embree_;
  std::unique_ptr<trace::PhotonTracer> tracer_;
  uint64_t seed_ = 1;
  uint32_t seed_index_ = 0;
};

}  // namespace pb::run
