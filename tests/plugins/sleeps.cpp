// Sleeps `sleep_ms` in every frame: with a small limits.cell_seconds the runner must kill the cell
// and record the time limit and the frame.
#include <chrono>
#include <thread>

#include "photonbench/context.h"
#include "photonbench/plugin.h"

namespace {
const pb_param_spec kParams[] = {
    {"sleep_ms", PB_PARAM_INT, 500, 0, 100000, nullptr, "ms", "sleep in every frame; default 500"},
};
class Sleeps final : public pb::Technique {
 public:
  void setup(pb::Context&, const pb::Params& params) override {
    sleep_ms_ = params.integer("sleep_ms");
  }
  void render(pb::Context& ctx) override {
    auto scope = ctx.pass("sleep");
    std::this_thread::sleep_for(std::chrono::milliseconds(sleep_ms_));
    scope.end();
    ctx.shared().gbuffer();
    ctx.shared().direct_light();
    ctx.shared().shade(nullptr);
  }
  int64_t sleep_ms_ = 500;
};
}  // namespace
PB_EXPORT_TECHNIQUE(Sleeps, "sleeps", "C L | C D L", "test: sleeps in every frame", kParams)
