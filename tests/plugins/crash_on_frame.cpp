// Renders like `direct`, then dereferences null on frame `crash_frame` (default 2, the cell's
// second warm-up-free frame when warmup is 0): the runner must record a crash at that frame and go
// on.
#include <csignal>

#include "photonbench/context.h"
#include "photonbench/plugin.h"

namespace {
const pb_param_spec kParams[] = {
    {"crash_frame", PB_PARAM_INT, 1, 0, 1000, nullptr, "frame",
     "frame index that segfaults; default 1"},
};
class CrashOnFrame final : public pb::Technique {
 public:
  void setup(pb::Context&, const pb::Params& params) override {
    crash_frame_ = params.integer("crash_frame");
  }
  void render(pb::Context& ctx) override {
    if (ctx.frame().index == uint32_t(crash_frame_)) std::raise(SIGSEGV);
    ctx.shared().gbuffer();
    ctx.shared().direct_light();
    ctx.shared().shade(nullptr);
  }
  int64_t crash_frame_ = 1;
};
}  // namespace
PB_EXPORT_TECHNIQUE(CrashOnFrame, "crash_on_frame", "C L | C D L", "test: segfaults on one frame",
                    kParams)
