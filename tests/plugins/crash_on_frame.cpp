// Renders like `direct`, then dereferences null on frame `crash_frame` (default 2, the cell's
// second warm-up-free frame when warmup is 0): the runner must record a crash at that frame and go
// on. With `crash_in_teardown` it renders every frame and aborts in its destructor instead, after
// a line on stderr, as a failed assertion does: the runner must say the crash was at teardown and
// show that line.
#include <csignal>
#include <cstdio>

#include "photonbench/context.h"
#include "photonbench/plugin.h"

namespace {
const pb_param_spec kParams[] = {
    {"crash_frame", PB_PARAM_INT, 1, 0, 1000, nullptr, "frame",
     "frame index that segfaults; default 1"},
    {"crash_in_teardown", PB_PARAM_BOOL, 0, 0, 1, nullptr, "",
     "abort in the destructor instead, after every frame rendered"},
};
class CrashOnFrame final : public pb::Technique {
 public:
  ~CrashOnFrame() override {
    if (!crash_in_teardown_) return;
    std::fprintf(stderr, "test: assertion failed in ~CrashOnFrame\n");
    std::fflush(stderr);
    std::raise(SIGABRT);
  }
  void setup(pb::Context&, const pb::Params& params) override {
    crash_frame_ = params.integer("crash_frame");
    crash_in_teardown_ = params.flag("crash_in_teardown");
  }
  void render(pb::Context& ctx) override {
    if (!crash_in_teardown_ && ctx.frame().index == uint32_t(crash_frame_)) std::raise(SIGSEGV);
    ctx.shared().gbuffer();
    ctx.shared().direct_light();
    ctx.shared().shade(nullptr);
  }
  int64_t crash_frame_ = 1;
  bool crash_in_teardown_ = false;
};
}  // namespace
PB_EXPORT_TECHNIQUE(CrashOnFrame, "crash_on_frame", "C L | C D L", "test: segfaults on one frame",
                    kParams)
