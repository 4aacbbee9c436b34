#include "cell/world.h"

#include <optional>
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

const trace::EmbreeScene& World::embree_scene() {
  if (!embree_) embree_ = std::make_unique<trace::EmbreeScene>(scene_, state_);
  return *embree_;
}

std::optional<uint32_t> World::seed_scramble() const {
  return seed_index_ > 0 ? std::optional(uint32_t(seed_ ^ (seed_ >> 32))) : std::nullopt;
}

trace::PhotonTracer& World::photon_tracer() {
  // A seed axis' cell mixes its seed into every trace's (the re-validation of kept paths included,
  // so a re-traced path continues the sequence it was first traced with).
  if (!tracer_) tracer_ = trace::make_photon_tracer(embree_scene(), seed_scramble());
  return *tracer_;
}

void World::set_seed(uint64_t seed, uint32_t seed_index) {
  seed_ = seed;
  seed_index_ = seed_index;
}

}  // namespace pb::run
