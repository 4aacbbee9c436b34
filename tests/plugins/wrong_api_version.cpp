// A module of another day: built against plugin API version 42 (as if from a newer photonbench's
// headers), through the ordinary entry macro. The host must fail only its cells, naming both
// versions and both builds; the macro, seeing a host of another version, hands over no factory.
#define PB_PLUGIN_API_VERSION 42u
#include "photonbench/context.h"
#include "photonbench/plugin.h"

namespace {
const pb_param_spec kParams[] = {{"unused", PB_PARAM_INT, 0, 0, 1, nullptr, "", "unused"}};
class WrongApiVersion final : public pb::Technique {
 public:
  void setup(pb::Context&, const pb::Params&) override {}
  void render(pb::Context& ctx) override {
    ctx.shared().gbuffer();
    ctx.shared().direct_light();
    ctx.shared().shade(nullptr);
  }
};
}  // namespace
PB_EXPORT_TECHNIQUE(WrongApiVersion, "wrong_api_version", "C L | C D L",
                    "test: built for another plugin API", kParams)
