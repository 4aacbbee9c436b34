// PhotonLists (photonbench/toolkit/photon_lists.h).
#include "photonbench/toolkit/photon_lists.h"

#include <fmt/format.h>

#include "photonbench/toolkit/technique.h"
#include "toolkit_shaders.h"

namespace pb::toolkit {

void PhotonLists::setup(gpu::Device& gpu, uint32_t capacity, std::string name) {
  gpu_ = &gpu;
  capacity_ = capacity;
  name_ = std::move(name);
  lists_ = storage_buffer(gpu, name_ + "/photon-lists", uint64_t(capacity) * 4);
  stats_ =
      storage_buffer(gpu, name_ + "/list-stats", PB_LIST_STAT_WORDS * 4, gpu::Memory::host_visible);
  check_pipeline_ = gpu.create_compute_pipeline(
      name_ + "/list-check", klists_check_comp_spv,
      std::vector<gpu::Binding>(kBindingCount, gpu::Binding::storage_buffer), 0);
}

void PhotonLists::resize(gpu::Device& gpu, PrefixSum& scan, uint32_t bins) {
  bins_ = bins;
  counts_ = storage_buffer(gpu, name_ + "/list-counts", uint64_t(bins) * 4);
  offsets_ = storage_buffer(gpu, name_ + "/list-offsets", uint64_t(bins) * 4);
  cursors_ = storage_buffer(gpu, name_ + "/list-cursors", uint64_t(bins) * 4);
  scan.reserve(bins);
}

void PhotonLists::clear(vk::CommandBuffer cmd) const {
  cmd.fillBuffer(counts_.handle(), 0, VK_WHOLE_SIZE, 0u);
  cmd.fillBuffer(cursors_.handle(), 0, VK_WHOLE_SIZE, 0u);
  cmd.fillBuffer(stats_.handle(), 0, VK_WHOLE_SIZE, 0u);
  cmd.fillBuffer(stats_.handle(), PB_LIST_STAT_CAPACITY * 4, 4, capacity_);
  cmd.fillBuffer(stats_.handle(), PB_LIST_STAT_BINS * 4, 4, bins_);
}

void PhotonLists::scan(vk::CommandBuffer cmd, const PrefixSum& scan) const {
  scan.record(cmd, counts_, offsets_, bins_, &stats_, PB_LIST_STAT_WANTED);
}

void PhotonLists::check(vk::CommandBuffer cmd) const {
  check_pipeline_.bind(cmd, {&counts_, &offsets_, &cursors_, &lists_, &stats_});
  cmd.dispatch(std::max<uint32_t>(1, gpu::groups_for(bins_, 64)), 1, 1);
}

void PhotonLists::record_runs(
    Context& ctx, const PrefixSum& prefix_sum,
    const std::function<void(vk::CommandBuffer cmd, bool insert)>& splat) const {
  // ctx.cmd() is fetched anew in every pass: with fenced timing (lavapipe) a pass scope submits and
  // continues in a fresh command buffer.
  {
    auto pass = ctx.pass("count");
    splat(ctx.cmd(), false);
  }
  gpu::full_barrier(ctx.cmd());
  {
    auto pass = ctx.pass("prefix-sum");
    scan(ctx.cmd(), prefix_sum);
  }
  gpu::full_barrier(ctx.cmd());
  {
    auto pass = ctx.pass("insert");
    splat(ctx.cmd(), true);
  }
  gpu::full_barrier(ctx.cmd());
  {
    auto pass = ctx.pass("check");
    check(ctx.cmd());
  }
}

void PhotonLists::append_bindings(std::vector<gpu::Resource>& resources) const {
  for (const gpu::Buffer* b : {&counts_, &offsets_, &cursors_, &lists_, &stats_})
    resources.push_back(b);
}

PhotonLists::Stats PhotonLists::stats() const {
  auto s = stats_.view<uint32_t>();
  Stats out;
  out.wanted = s[PB_LIST_STAT_WANTED];
  out.written = std::min<uint64_t>(out.wanted, capacity_);
  out.overflows = out.wanted - out.written;
  out.mismatched_bins = s[PB_LIST_STAT_MISMATCHED_BINS];
  out.mismatched_entries = s[PB_LIST_STAT_MISMATCHED_ENTRIES];
  return out;
}

void PhotonLists::report(Context& ctx, std::string_view who,
                         std::string_view capacity_param) const {
  Stats s = stats();
  pb::count(ctx, kListEntriesCounter, double(s.written));
  pb::count(ctx, kListOverflowsCounter, double(s.overflows));
  pb::count(ctx, kListMismatchesCounter, double(s.mismatched_bins));
  if (s.overflows > 0)
    ctx.warn(fmt::format(
        "{} overflowed: {} entries wanted, {} = {}; {} entries dropped (indirect light is "
        "underestimated in this frame)",
        who, s.wanted, capacity_param, capacity_, s.overflows));
  if (s.mismatched_bins > 0)
    ctx.warn(
        fmt::format("{}: the count and insert runs disagree on {} lists ({} entries); those lists "
                    "are read only "
                    "as far as both runs agree (indirect light is wrong there in this frame)",
                    who, s.mismatched_bins, s.mismatched_entries));
}

uint64_t PhotonLists::bytes() const {
  return lists_.size() + counts_.size() + offsets_.size() + cursors_.size();
}

}  // namespace pb::toolkit
