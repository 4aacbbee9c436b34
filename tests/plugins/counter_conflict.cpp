// Counts a declared counter with another kind and unit than its declaration (a size in bytes for
// a work counter in photons): the cell must fail at the first frame naming both, not write a column
// of mixed units.
#include "direct_only.h"

namespace {
class CounterConflict final : public pb::testing::DirectOnly {
 public:
  void render(pb::Context& ctx) override {
    DirectOnly::render(ctx);
    ctx.count({"photons_splatted", pb::CounterKind::size, "bytes"}, 32);
  }
};
const pb_counter_spec kCounters[] = {
    {"photons_splatted", PB_COUNTER_WORK, "photons", "test: declared as work"}};
}  // namespace

PB_EXPORT_TECHNIQUE(CounterConflict, "counter_conflict", "direct",
                    "test: a counter counted unlike its declaration", pb::testing::kUnusedParams,
                    .counters = kCounters)
