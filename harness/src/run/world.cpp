#include "run/world.h"

#include <utility>

#include "trace/sampling.h"

namespace pb::run {

namespace {

// The scene's photon tracer with the cell's seed mixed into every request's (trace and
// retrace_invalid alike, so a re-validated path continues the sequence it was first traced with).
class SeededPhotonTracer final : public trace::PhotonTracer {
 public:
  SeededPhotonTracer(std::unique_ptr<trace::PhotonTracer> inner, uint32_t seed)
      : inner_(std::move(inner)), seed_(seed) {}
  uint32_t light_count() const override { return inner_->light_count(); }
  glm::vec3 light_power(uint32_t light) const override { return inner_->light_power(light); }
  void set_emission_density(uint32_t light, const trace::EmissionDensity* density) override {
    inner_->set_emission_density(light, density);
  }
  trace::TraceStats trace(const trace::TraceSettings& settings, trace::PhotonBatch& out) override {
    return inner_->trace(seeded(settings), out);
  }
  trace::TraceStats retrace_invalid(const trace::TraceSettings& settings,
                                    trace::PhotonBatch& batch) override {
    return inner_->retrace_invalid(seeded(settings), batch);
  }
  trace::TraceStats verify_paths(const trace::TraceSettings& settings,
                                 const trace::ReuseSettings& reuse,
                                 trace::PhotonBatch& batch) override {
    return inner_->verify_paths(seeded(settings), reuse, batch);
  }
  trace::TraceStats update_origins(const trace::TraceSettings& settings,
                                   const trace::ReuseSettings& reuse,
                                   trace::PhotonBatch& batch) override {
    return inner_->update_origins(seeded(settings), reuse, batch);
  }
  trace::TraceStats retrace_marked(const trace::TraceSettings& settings,
                                   trace::PhotonBatch& batch) override {
    return inner_->retrace_marked(seeded(settings), batch);
  }

 private:
  trace::TraceSettings seeded(trace::TraceSettings settings) const {
    settings.seed = trace::hash_combine(settings.seed, seed_);
    return settings;
  }
  std::unique_ptr<trace::PhotonTracer> inner_;
  uint32_t seed_;
};

}  // namespace

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
    if (seed_index_ > 0)
      tracer_ =
          std::make_unique<SeededPhotonTracer>(std::move(tracer_), uint32_t(seed_ ^ (seed_ >> 32)));
  }
  return *tracer_;
}

void World::set_seed(uint64_t seed, uint32_t seed_index) {
  seed_ = seed;
  seed_index_ = seed_index;
}

}  // namespace pb::run
