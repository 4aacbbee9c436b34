// A technique whose cost and error are known functions of its budget knob, for the match tests:
// each frame spins on the CPU, outside any pass, for `samples` x `sample_us` microseconds (on the
// steady clock, so the frame's wall time is the same however loaded the machine), and hands shade()
// an indirect image of the constant -`error_scale` / sqrt(samples), an error that falls as a Monte
// Carlo estimate's does. Frame time = base + samples x sample_us. Direct light alone is below the
// reference everywhere (it lacks the indirect light), so taking the constant off adds it to the
// error: the mean absolute error is about that of direct light plus error_scale / sqrt(samples).
#include <chrono>
#include <cmath>

#include "photonbench/context.h"
#include "photonbench/plugin.h"

namespace {
const pb_param_spec kParams[] = {
    {"samples", PB_PARAM_INT, 16, 1, 100000, nullptr, "samples",
     "the budget knob: CPU work and error both follow it; default 16"},
    {"sample_us", PB_PARAM_FLOAT, 200, 0, 1e5, nullptr, "us",
     "CPU time spun per sample, outside any pass; default 200"},
    {"error_scale", PB_PARAM_FLOAT, 1, 0, 100, nullptr, "",
     "the radiance taken off, times 1 / sqrt(samples); default 1"},
};
const pb_budget_knob kBudget[] = {{"samples", PB_COST_GROWS, PB_ERROR_FALLS, PB_SCALE_LOG},
                                  {"sample_us", PB_COST_GROWS, PB_ERROR_MIXED, PB_SCALE_LINEAR}};

class BudgetKnob final : public pb::Technique {
 public:
  void setup(pb::Context& ctx, const pb::Params& params) override {
    samples_ = params.integer("samples");
    sample_us_ = params.number("sample_us");
    offset_ = -float(params.number("error_scale") / std::sqrt(double(samples_)));
    indirect_ =
        ctx.gpu().create_image("budget_knob/indirect", ctx.output().extent(),
                               vk::Format::eR32G32B32A32Sfloat, vk::ImageUsageFlagBits::eStorage);
  }
  void render(pb::Context& ctx) override {
    ctx.shared().gbuffer();
    ctx.shared().direct_light();
    // The work the match must count: no pass is open here.
    const auto end = std::chrono::steady_clock::now() +
                     std::chrono::duration<double, std::micro>(double(samples_) * sample_us_);
    while (std::chrono::steady_clock::now() < end) {
    }
    {
      auto scope = ctx.pass("offset");
      ctx.cmd().clearColorImage(
          indirect_.handle(), vk::ImageLayout::eGeneral,
          vk::ClearColorValue(std::array<float, 4>{offset_, offset_, offset_, 0.f}),
          vk::ImageSubresourceRange{vk::ImageAspectFlagBits::eColor, 0, 1, 0, 1});
    }
    ctx.shared().shade(&indirect_);
  }

 private:
  int64_t samples_ = 16;
  double sample_us_ = 200;
  float offset_ = 0;
  pb::gpu::Image indirect_;
};
}  // namespace
PB_EXPORT_TECHNIQUE(BudgetKnob, "budget_knob", "C L | C D L",
                    "test: cost and error known functions of its budget knob", kParams,
                    .budget = kBudget)
