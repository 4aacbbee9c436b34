// Counts one name as two different counters (work in photons, then a size in bytes): the cell must
// fail at the first frame naming both declarations, not write a column of mixed units.
#include "direct_only.h"

namespace {
class CounterConflict final : public pb::testing::DirectOnly {
 public:
  void render(pb::Context& ctx) override {
    DirectOnly::render(ctx);
    ctx.count({"photons_splatted", pb::CounterKind::work, "photons"}, 1);
    ctx.count({"photons_splatted", pb::CounterKind::size, "bytes"}, 32);
  }
};
}  // namespace

PB_EXPORT_TECHNIQUE(CounterConflict, "counter_conflict", "direct",
                    "test: one counter name declared two ways", pb::testing::kUnusedParams)
