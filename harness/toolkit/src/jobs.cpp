// JobQueue (photonbench/toolkit/jobs.h).
#include "photonbench/toolkit/jobs.h"

#include <fmt/format.h>

#include "photonbench/toolkit/technique.h"
#include "toolkit_shaders.h"

namespace pb::toolkit {

void JobQueue::setup(gpu::Device& gpu, uint32_t capacity, uint32_t jobs_per_thread,
                     std::string name) {
  name_ = std::move(name);
  capacity_ = capacity;
  jobs_per_thread_ = jobs_per_thread;
  emitted_ = storage_buffer(gpu, name_ + "/jobs", uint64_t(capacity) * 8);
  sorted_ = storage_buffer(gpu, name_ + "/jobs-by-node", uint64_t(capacity) * 8);
  using U = vk::BufferUsageFlagBits;
  stats_ = gpu.create_buffer(name_ + "/job-stats", PB_JOB_STAT_WORDS * 4,
                             U::eStorageBuffer | U::eTransferDst | U::eIndirectBuffer,
                             gpu::Memory::host_visible);
  args_pipeline_ = gpu.create_compute_pipeline(
      name_ + "/job-args", kjobs_args_comp_spv,
      std::vector<gpu::Binding>(kBindingCount, gpu::Binding::storage_buffer), 0);
  sort_.setup(gpu);
}

void JobQueue::resize(gpu::Device& gpu, PrefixSum& scan, uint32_t nodes) {
  sort_.resize(gpu, scan, nodes, name_);
}

void JobQueue::clear(vk::CommandBuffer cmd) const {
  cmd.fillBuffer(stats_.handle(), 0, VK_WHOLE_SIZE, 0u);
  cmd.fillBuffer(stats_.handle(), PB_JOB_STAT_CAPACITY * 4, 4, capacity_);
  cmd.fillBuffer(stats_.handle(), PB_JOB_STAT_PER_THREAD * 4, 4, jobs_per_thread_);
}

void JobQueue::finish(vk::CommandBuffer cmd) const {
  args_pipeline_.bind(cmd, {&emitted_, &sorted_, &stats_});
  cmd.dispatch(1, 1, 1);
}

void JobQueue::regroup(vk::CommandBuffer cmd, const PrefixSum& scan) const {
  sort_.record(cmd, scan, emitted_, sorted_, stats_, PB_JOB_STAT_COUNT, PB_JOB_STAT_ITEM_ARGS * 4,
               ~PB_JOB_WHOLE);
}

void JobQueue::record_top(Context& ctx, const PrefixSum& scan,
                          const std::function<void(vk::CommandBuffer cmd)>& produce) const {
  {
    auto pass = ctx.pass("top");
    auto cmd = ctx.cmd();
    produce(cmd);
    gpu::full_barrier(cmd);
    finish(cmd);
  }
  gpu::full_barrier(ctx.cmd());
  {
    auto pass = ctx.pass("regroup");
    regroup(ctx.cmd(), scan);
  }
}

void JobQueue::dispatch_consumers(vk::CommandBuffer cmd) const {
  cmd.dispatchIndirect(stats_.handle(), PB_JOB_STAT_THREAD_ARGS * 4);
}

void JobQueue::append_bindings(std::vector<gpu::Resource>& resources) const {
  for (const gpu::Buffer* b : {&emitted_, &sorted_, &stats_}) resources.push_back(b);
}

void JobQueue::report(Context& ctx, std::string_view who) const {
  pb::count(ctx, kJobsCounter, double(wanted()));
  pb::count(ctx, kJobOverflowsCounter, double(overflows()));
  if (overflows() > 0)
    ctx.warn(fmt::format(
        "{}: the job list overflowed: the top pass emitted {} jobs, {} = {}; {} dropped (their "
        "photons' contributions below the top levels are missing in this frame)",
        who, wanted(), kMaxJobsParam.name, capacity_, overflows()));
}

uint64_t JobQueue::wanted() const { return stats_.view<uint32_t>()[PB_JOB_STAT_WANTED]; }
uint64_t JobQueue::overflows() const {
  uint64_t w = wanted();
  return w > capacity_ ? w - capacity_ : 0;
}
uint64_t JobQueue::bytes() const { return emitted_.size() + sorted_.size() + sort_.bytes(); }

}  // namespace pb::toolkit
