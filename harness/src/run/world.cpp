#include "run/world.h"

#include <utility>

namespace pb::run {

World::World(gpu::Device& device, scene::Scene scene, uint32_t width, uint32_t height,
             PassRecorder& recorder, std::function<vk::CommandBuffer()> cmd)
    : scene_(std::move(scene)),
      state_(scene_.at(0)),
      passes_(device, scene_, width, height, {}, recorder, std::move(cmd)) {}

void World::advance_to(uint32_t frame) {
  state_ = scene_.at(frame);
  passes_.update(state_);
  if (embree_) embree_->update(state_);
}

trace::PhotonTracer& World::photon_tracer() {
  if (!tracer_) {
    embree_ = std::make_unique<trace::EmbreeScene>(scene_, state_);
    tracer_ = trace::make_photon_tracer(*embree_);
  }
  return *tracer_;
}

}  // namespace pb::run
