// Counts a counter its descriptor does not declare: the cell must fail at the first frame naming
// it, not write a column nothing documents.
#include "direct_only.h"

namespace {
class UndeclaredCounter final : public pb::testing::DirectOnly {
 public:
  void render(pb::Context& ctx) override {
    DirectOnly::render(ctx);
    ctx.count({"photons_hidden", pb::CounterKind::work, "photons"}, 1);
  }
};
}  // namespace

PB_EXPORT_TECHNIQUE(UndeclaredCounter, "undeclared_counter", "direct",
                    "test: counts a counter it does not declare", pb::testing::kUnusedParams)
