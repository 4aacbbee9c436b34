// Hands shade() an indirect image cleared to NaN from frame `nan_frame` on: the runner must fail
// the cell at that frame because the output holds NaN.
#include <cmath>
#include <limits>

#include "photonbench/context.h"
#include "photonbench/plugin.h"

namespace {
const pb_param_spec kParams[] = {
    {"nan_frame", PB_PARAM_INT, 2, 0, 1000, nullptr, "frame",
     "first frame with NaN output; default 2"},
};
class NanOutput final : public pb::Technique {
 public:
  void setup(pb::Context& ctx, const pb::Params& params) override {
    nan_frame_ = params.integer("nan_frame");
    auto extent = ctx.output().extent();
    indirect_ =
        ctx.gpu().create_image("nan_output/indirect", extent, vk::Format::eR32G32B32A32Sfloat,
                               vk::ImageUsageFlagBits::eStorage);
  }
  void render(pb::Context& ctx) override {
    ctx.shared().gbuffer();
    ctx.shared().direct_light();
    float value =
        ctx.frame().index >= uint32_t(nan_frame_) ? std::numeric_limits<float>::quiet_NaN() : 0.f;
    {
      auto scope = ctx.pass("fill");
      ctx.cmd().clearColorImage(
          indirect_.handle(), vk::ImageLayout::eGeneral,
          vk::ClearColorValue(std::array<float, 4>{value, value, value, 0.f}),
          vk::ImageSubresourceRange{vk::ImageAspectFlagBits::eColor, 0, 1, 0, 1});
    }
    ctx.shared().shade(&indirect_);
  }
  int64_t nan_frame_ = 2;
  pb::gpu::Image indirect_;
};
}  // namespace
PB_EXPORT_TECHNIQUE(NanOutput, "nan_output", "C L | C D L",
                    "test: NaN in the output from one frame on", kParams)
