// What the boundary test plugins render around the one thing each gets wrong: the shared G-buffer,
// direct light and shade, with a placeholder parameter.
#pragma once

#include "photonbench/context.h"
#include "photonbench/plugin.h"

namespace pb::testing {

inline const pb_param_spec kUnusedParams[] = {
    {"unused", PB_PARAM_INT, 0, 0, 1, nullptr, "", "unused"}};

class DirectOnly : public Technique {
 public:
  void setup(Context&, const Params&) override {}
  void render(Context& ctx) override {
    ctx.shared().gbuffer();
    ctx.shared().direct_light();
    ctx.shared().shade(nullptr);
  }
};

}  // namespace pb::testing
