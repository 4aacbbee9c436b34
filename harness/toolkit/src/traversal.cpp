// report_truncated and PassProfile (photonbench/toolkit/traversal.h).
#include "photonbench/toolkit/traversal.h"

#include <fmt/format.h>

#include "photonbench/toolkit/technique.h"

namespace pb::toolkit {

void report_truncated(Context& ctx, std::string_view who, uint64_t truncated, uint32_t budget) {
  pb::count(ctx, kTruncatedTraversalsCounter, double(truncated));
  if (truncated > 0)
    ctx.warn(fmt::format(
        "{}: {} hierarchy traversals ran out of their loop budget ({} steps per invocation, kept "
        "under llvmpipe's loop limit) and were cut short; their photons' remaining contributions "
        "were dropped in this frame",
        who, truncated, budget));
}

void PassProfile::setup(gpu::Device& gpu, std::vector<std::string> passes, bool enabled) {
  passes_ = std::move(passes);
  enabled_ = enabled;
  buffer_ = storage_buffer(gpu, "profile", uint64_t(passes_.size()) * kSlotWords * 4,
                           gpu::Memory::host_visible);
}

void PassProfile::clear(vk::CommandBuffer cmd) const {
  cmd.fillBuffer(buffer_.handle(), 0, VK_WHOLE_SIZE, 0u);
}

void PassProfile::report(Context& ctx) const {
  if (!enabled_) return;
  auto s = buffer_.view<uint32_t>();
  for (size_t i = 0; i < passes_.size(); ++i) {
    const uint32_t* slot = s.data() + i * kSlotWords;
    auto wide = [&](int at) { return double(uint64_t(slot[at]) | (uint64_t(slot[at + 1]) << 32)); };
    const std::string prefix = "profile_" + passes_[i] + "_";
    ctx.count({prefix + "steps", CounterKind::work, "steps"}, wide(0));
    ctx.count({prefix + "visits", CounterKind::work, "nodes"}, wide(2));
    ctx.count({prefix + "atomics", CounterKind::work, "atomics"}, wide(4));
    double active = wide(6), lanes = wide(8);
    ctx.count({prefix + "lanes_idle", CounterKind::ratio, "fraction"},
              lanes > 0 ? 1.0 - active / lanes : 0.0);
    ctx.count({prefix + "steps_max", CounterKind::size, "steps"}, double(slot[10]));
  }
}

}  // namespace pb::toolkit
