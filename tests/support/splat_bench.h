// A Paper I splatter (pb::toolkit::Splatter) driven in-process, as render_photon_frame drives it
// inside a technique, on a synthetic frame: a grey floor (the plane y = 0) filling the view of a
// camera 1.5 m above it looking straight down, its G-buffer written in closed form, and photons
// lying on the floor. For the splatters' tests that need no scene, tracer or reference (list
// capacities, the count / insert consistency check, loop budgets, an estimate that must not depend
// on the photon count): a function call each, where `photonbench run` needed a process, a scene
// and a cell folder. Vulkan validation as validation_on() says (validation_errors()).
#pragma once

#include <glm/glm.hpp>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "gpu_context.h"
#include "photonbench/photons.h"
#include "photonbench/scene_layout.h"
#include "photonbench/toolkit/technique.h"
#include "plan_scratch.h"
#include "run_fixture.h"

namespace pb::testing {

class SplatBench {
 public:
  static constexpr float kCameraHeight = 1.5f;
  static constexpr float kFovY = 1.04719755f;  // 60 degrees
  static constexpr float kAlbedo = 0.5f;

  SplatBench(uint32_t width, uint32_t height)
      : gpu_(gpu::Device::Options{"", validation_on()}),
        gbuffer_(gpu_, width, height),
        ctx_(gpu_, gbuffer_),
        width_(width),
        height_(height) {
    ctx_.set_camera(width, height, {0, kCameraHeight, 0}, {0, 0, 0}, kFovY, {0, 0, -1});
    std::vector<float> position(size_t(width) * height * 4), normal(position.size()),
        albedo(position.size()), depth(position.size());
    for (uint32_t y = 0; y < height; ++y)
      for (uint32_t x = 0; x < width; ++x) {
        const size_t at = (size_t(y) * width + x) * 4;
        const glm::vec3 p = floor_point(float(x) + 0.5f, float(y) + 0.5f);
        for (int c = 0; c < 3; ++c) {
          position[at + c] = p[c];
          normal[at + c] = c == 1 ? 1.0f : 0.0f;
          albedo[at + c] = kAlbedo;
        }
        position[at + 3] = glm::length(p - ctx_.frame().camera.position);
        albedo[at + 3] = float(PB_MATERIAL_DIFFUSE);
        depth[at] = position[at + 3];
      }
    TestGBuffer::upload(gpu_, gbuffer_.position, position);
    TestGBuffer::upload(gpu_, gbuffer_.normal, normal);
    TestGBuffer::upload(gpu_, gbuffer_.albedo, albedo);
    TestGBuffer::upload(gpu_, gbuffer_.depth, depth);
  }

  // The floor point seen at pixel coordinates (px, py): the ray through the frame's own camera
  // matrices, so that the splat's projection of a photon lands on the pixels that see it.
  glm::vec3 floor_point(float px, float py) const {
    const CameraView& camera = ctx_.frame().camera;
    const glm::vec2 ndc(px / float(width_) * 2.0f - 1.0f, py / float(height_) * 2.0f - 1.0f);
    const glm::vec4 p = camera.inverse_view_projection * glm::vec4(ndc, 0.5f, 1.0f);
    const glm::vec3 direction = glm::vec3(p) / p.w - camera.position;
    return camera.position - direction * (camera.position.y / direction.y);
  }

  // `count` photons at uniformly random points of the floor in view (a fixed seed), arriving
  // straight down, sharing `power` (W, times `color` per channel) evenly.
  std::vector<trace::PhotonRecord> photons(uint32_t count, float power, uint32_t seed = 7,
                                           glm::vec3 color = glm::vec3(1)) const {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    const glm::vec3 lo = floor_point(0, 0), hi = floor_point(float(width_), float(height_));
    std::vector<trace::PhotonRecord> out(count);
    for (uint32_t i = 0; i < count; ++i) {
      trace::PhotonRecord& p = out[i];
      p = trace::PhotonRecord{};
      p.position =
          glm::vec3(lo.x + (hi.x - lo.x) * unit(rng), 0.0f, lo.z + (hi.z - lo.z) * unit(rng));
      p.power = color * (power / float(count));
      p.path = i;
      p.direction = glm::vec3(0, -1, 0);
      p.bounce = 1;
      p.normal = glm::vec3(0, 1, 0);
    }
    return out;
  }

  // A technique's parameters as the plan resolves them for a cell (every schema default filled
  // in), with `params` (the body of a YAML flow mapping) set.
  static Params params(const std::string& technique, const std::string& params) {
    PlanScratch scratch("splat_bench_" + technique);
    const run::RunPlan plan = scratch.plan(
        "name: splat-bench\nresolution: [64, 36]\nscenes: [cornell-box]\n"
        "frames: {warmup: 0, count: 1, metrics_every: 0}\n"
        "techniques:\n  - {technique: " +
        technique + ", params: {" + params + "}}\n");
    return Params(plan.cells.at(0).params);
  }

  // What the frames reported: each counter summed over them, every warning, and the last frame's
  // indirect radiance.
  struct Report {
    std::map<std::string, double> counters;
    std::vector<std::string> warnings;
    io::Image indirect;  // RGBA
    double counter(const std::string& name) const {
      auto it = counters.find(name);
      if (it == counters.end()) throw std::out_of_range("no counter '" + name + "'");
      return it->second;
    }
    bool warned(const std::string& text) const {
      for (const std::string& w : warnings)
        if (w.find(text) != std::string::npos) return true;
      return false;
    }
  };

  // Sets `splatter` up with `params` and renders `frames` frames of `photons` with it.
  Report run(toolkit::Splatter& splatter, const Params& params,
             const std::vector<trace::PhotonRecord>& photons, int frames = 1) {
    const toolkit::PhotonParams photon = toolkit::PhotonParams::read(params);
    splatter.setup(ctx_, params, photon);
    const uint64_t bytes = std::max<uint64_t>(photons.size(), 1) * sizeof(trace::PhotonRecord);
    gpu::Buffer buffer =
        toolkit::storage_buffer(gpu_, "test/photons", bytes, gpu::Memory::host_visible);
    std::memcpy(buffer.mapped(), photons.data(), photons.size() * sizeof(trace::PhotonRecord));
    const toolkit::PhotonSet set{&buffer, photons};
    Report report;
    for (int frame = 0; frame < frames; ++frame) {
      ctx_.counters.clear();
      ctx_.warnings.clear();
      const gpu::Image& indirect = splatter.render(ctx_, set);
      ctx_.flush();
      splatter.report(ctx_, set);
      for (const auto& [name, value] : ctx_.counters) report.counters[name] += value;
      report.warnings.insert(report.warnings.end(), ctx_.warnings.begin(), ctx_.warnings.end());
      if (frame + 1 == frames) {
        report.indirect = io::Image(int(width_), int(height_), 4);
        gpu_.read_image(indirect, report.indirect.pixels);
      }
    }
    return report;
  }

  uint64_t validation_errors() const { return gpu_.validation_errors(); }
  std::string first_validation_error() const { return gpu_.first_validation_error(); }

 private:
  gpu::Device gpu_;
  TestGBuffer gbuffer_;
  TestContext ctx_;
  uint32_t width_, height_;
};

// The loop-budget boundary of a hierarchy splatter S (run_fixture.h's BudgetBoundary, in-process):
// one photon under the middle of the view, `params` with `profile: true`, gives the most loop steps
// an invocation took, M (the largest `profile_*_steps_max`); then loop_budget M and M - 1. With M
// nothing is truncated (a walk whose last step takes the last unit is complete), with M - 1 some
// traversal is, counted and warned about.
template <class S>
BudgetBoundary budget_boundary(SplatBench& bench, const std::string& technique,
                               const std::string& params) {
  BudgetBoundary b;
  auto photon = bench.photons(1, 1.0f);
  photon[0].position = glm::vec3(0);  // the floor's point under the camera
  const std::string p = params + ", profile: true";
  S unlimited;
  auto report = bench.run(unlimited, SplatBench::params(technique, p), photon);
  b.photons = double(photon.size());
  b.truncated_unlimited = report.counter("truncated_traversals");
  for (const auto& [name, value] : report.counters)
    if (name.rfind("profile_", 0) == 0 && name.size() > 10 &&
        name.substr(name.size() - 10) == "_steps_max")
      b.most = std::max(b.most, int(value));
  for (int budget : {b.most, b.most - 1}) {
    if (budget < 1) return b;
    S splatter;
    auto r = bench.run(
        splatter, SplatBench::params(technique, p + ", loop_budget: " + std::to_string(budget)),
        photon);
    std::string warnings;
    for (const std::string& w : r.warnings) warnings += w + "\n";
    (budget == b.most ? b.truncated_at_most : b.truncated_below) =
        r.counter("truncated_traversals");
    (budget == b.most ? b.warnings_at_most : b.warnings_below) = warnings;
  }
  return b;
}

}  // namespace pb::testing
