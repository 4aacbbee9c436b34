// Throws from render() on frame `throw_frame`: the cell fails with the exception's message and
// frame.
#include <stdexcept>

#include "photonbench/context.h"
#include "photonbench/plugin.h"

namespace {
const pb_param_spec kParams[] = {
    {"throw_frame", PB_PARAM_INT, 1, 0, 1000, nullptr, "frame",
     "frame index that throws; default 1"},
};
class ThrowsOnFrame final : public pb::Technique {
 public:
  void setup(pb::Context&, const pb::Params& params) override {
    throw_frame_ = params.integer("throw_frame");
  }
  void render(pb::Context& ctx) override {
    if (ctx.frame().index == uint32_t(throw_frame_))
      throw std::runtime_error("splat list overflowed (test)");
    ctx.shared().gbuffer();
    ctx.shared().direct_light();
    ctx.shared().shade(nullptr);
  }
  int64_t throw_frame_ = 1;
};
}  // namespace
PB_EXPORT_TECHNIQUE(ThrowsOnFrame, "throws_on_frame", "C L | C D L", "test: throws on one frame",
                    kParams)
