// What the hierarchy traversals share on the C++ side (GPU side: harness/shaders/toolkit/
// traverse.glsl, profile.glsl): the loop budget and the report of traversals that ran out of it,
// and the per-pass work profile, reported as counters "profile_<pass>_steps", "_visits",
// "_atomics", "_steps_max" and "_lanes_idle" (the share of SIMD lanes idle in the loop steps, 0 to
// 1), for finding where a splat pass's time goes.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "photonbench/context.h"
#include "photonbench/gpu.h"
#include "photonbench/param_table.h"
#include "photonbench/plugin.h"
#include "photonbench/toolkit/limits.h"

namespace pb::toolkit {

// clang-format off
inline constexpr pb_param_spec kProfileParam = pb::row<bool>(
    "profile", false,
    "count loop steps, nodes visited, atomics and idle SIMD lanes per splat pass (counters "
    "profile_*; slower)");
// clang-format on

// The `loop_budget` test hook: iterations a traversal may take per invocation (the default is
// llvmpipe's loop limit less room for other loops); lower, it makes traversals run out, to check
// that they are counted (truncated_traversals) and warned about.
// clang-format off
inline constexpr pb_param_spec kLoopBudgetParam = pb::row<uint32_t>(
    "loop_budget", PB_LOOP_BUDGET, {1, PB_LOOP_BUDGET}, "steps",
    "test hook: loop steps one splat invocation may take (llvmpipe's limit is 65535); traversals "
    "that run out are counted (truncated_traversals) and warned about");
// clang-format on

// Counter "truncated_traversals" (walks that ran out of `budget` steps), with a warning when
// non-zero; `who` names the technique.
// clang-format off
inline constexpr pb_counter_spec kTruncatedTraversalsCounter = {
    "truncated_traversals", PB_COUNTER_WORK, "traversals",
    "hierarchy walks cut short by the loop budget (a warning when non-zero)"};
// clang-format on
void report_truncated(Context& ctx, std::string_view who, uint64_t truncated, uint32_t budget);

// The counters PassProfile::report emits for one pass (profile: true), in its order.
#define PB_TOOLKIT_PROFILE_COUNTERS(pass)                                                          \
  std::array<pb_counter_spec, 5> {                                                                 \
    {                                                                                              \
      {"profile_" pass "_steps", PB_COUNTER_WORK, "steps", "loop steps of the " pass " pass"},     \
          {"profile_" pass "_visits", PB_COUNTER_WORK, "nodes", "nodes the " pass " pass tested"}, \
          {"profile_" pass "_atomics", PB_COUNTER_WORK, "atomics",                                 \
           "global atomics the " pass " pass issued"},                                             \
          {"profile_" pass "_lanes_idle", PB_COUNTER_RATIO, "fraction",                            \
           "share of SIMD lanes idle over the " pass " pass's loop steps"},                        \
      {                                                                                            \
        "profile_" pass "_steps_max", PB_COUNTER_SIZE, "steps",                                    \
            "the most loop steps one invocation of the " pass " pass took"                         \
      }                                                                                            \
    }                                                                                              \
  }

class PassProfile {
 public:
  static constexpr uint32_t kSlotWords = 16;  // PB_PROFILE_SLOT_WORDS
  // Slot i of the GPU buffer is pass `passes[i]`.
  void setup(gpu::Device& gpu, std::vector<std::string> passes, bool enabled);
  void clear(vk::CommandBuffer cmd) const;
  const gpu::Buffer& buffer() const { return buffer_; }
  bool enabled() const { return enabled_; }
  // After ctx.flush(), when enabled.
  void report(Context& ctx) const;

 private:
  std::vector<std::string> passes_;
  bool enabled_ = false;
  gpu::Buffer buffer_;
};

}  // namespace pb::toolkit
