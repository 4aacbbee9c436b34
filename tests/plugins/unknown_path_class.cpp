// Declares a path class no reference has ("C D D L" is neither a class name nor one's light path
// expression): loading must fail its cells naming the plugin, instead of scoring it on `combined`
// alone.
#include "photonbench/context.h"
#include "photonbench/plugin.h"

namespace {
const pb_param_spec kParams[] = {{"unused", PB_PARAM_INT, 0, 0, 1, nullptr, "", "unused"}};
class UnknownPathClass final : public pb::Technique {
 public:
  void setup(pb::Context&, const pb::Params&) override {}
  void render(pb::Context& ctx) override {
    ctx.shared().gbuffer();
    ctx.shared().direct_light();
    ctx.shared().shade(nullptr);
  }
};
}  // namespace
PB_EXPORT_TECHNIQUE(UnknownPathClass, "unknown_path_class", "C D D L",
                    "test: a path class no reference has", kParams)
