// Counts one name as two different counters (work in photons, then a size in bytes): the cell must
// fail at the first frame naming both declarations, not write a column of mixed units.
#include "photonbench/context.h"
#include "photonbench/plugin.h"

namespace {
const pb_param_spec kParams[] = {{"unused", PB_PARAM_INT, 0, 0, 1, nullptr, "", "unused"}};
class CounterConflict final : public pb::Technique {
 public:
  void setup(pb::Context&, const pb::Params&) override {}
  void render(pb::Context& ctx) override {
    ctx.shared().gbuffer();
    ctx.shared().direct_light();
    ctx.shared().shade(nullptr);
    ctx.count({"photons_splatted", pb::CounterKind::work, "photons"}, 1);
    ctx.count({"photons_splatted", pb::CounterKind::size, "bytes"}, 32);
  }
};
}  // namespace
PB_EXPORT_TECHNIQUE(CounterConflict, "counter_conflict", "direct",
                    "test: one counter name declared two ways", kParams)
