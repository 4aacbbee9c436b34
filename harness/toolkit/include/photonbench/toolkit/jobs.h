// (photon, node) jobs between a top splat pass and the per-node passes below it (Paper I §4.3; GPU
// side: harness/shaders/toolkit/jobs.glsl): an unordered list the producer emits into, the count
// and dispatch arguments (finish), a counting sort by node (regroup), and indirect dispatches of
// the consumers, each invocation taking a run of `jobs_per_thread` consecutive sorted jobs (Paper
// I's persistent threads loop until the list is empty; a bounded run keeps each invocation under
// llvmpipe's loop limit).
//
//   jobs.setup(gpu, capacity, jobs_per_thread, "cluster");  jobs.resize(gpu, scan, nodes);
//   per frame: jobs.clear(cmd); [producer]; jobs.finish(cmd); jobs.regroup(cmd, scan);
//              [consumer pipeline bound] jobs.dispatch_consumers(cmd);
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "photonbench/context.h"
#include "photonbench/gpu.h"
#include "photonbench/param_table.h"
#include "photonbench/plugin.h"
#include "photonbench/toolkit/gpu_scan.h"
#include "photonbench/toolkit/jobs_layout.h"

namespace pb::toolkit {

// The rows of every splatter with a top pass and jobs (cluster, directional).
// clang-format off
inline constexpr pb_param_spec kTopLevelsParam = pb::row<uint32_t>(
    "top_levels", 3, {0, 5}, "levels",
    "levels the top splat pass walks below the roots before it hands (photon, node) jobs to the "
    "per-node passes (Paper I §4.3: 3); larger values mean the level the splat stops at (cluster: "
    "the level above the leaves)");
inline constexpr pb_param_spec kMaxJobsParam = pb::row<uint32_t>(
    "max_jobs", 1 << 22, {1, 1 << 24}, "jobs",
    "capacity of the (photon, node) job list of the top pass; overflowing jobs are dropped and "
    "counted (job_overflows)");

// The counters JobQueue::report emits.
inline constexpr pb_counter_spec kJobsCounter = {
    "jobs", PB_COUNTER_WORK, "jobs", "(photon, node) jobs the top pass emitted"};
inline constexpr pb_counter_spec kJobOverflowsCounter = {
    "job_overflows", PB_COUNTER_WORK, "jobs",
    "jobs dropped for want of max_jobs (a warning when non-zero)"};
inline constexpr pb_counter_spec kBytesJobsCounter = {
    "bytes_jobs", PB_COUNTER_SIZE, "bytes", "both job lists and the sort's per-node counters"};
// clang-format on
inline constexpr std::array kJobQueueCounters = {kJobsCounter, kJobOverflowsCounter,
                                                 kBytesJobsCounter};
// Jobs one per-node invocation takes (Paper I's persistent threads loop until the list is empty;
// a bounded run keeps every invocation under llvmpipe's loop limit).
inline constexpr uint32_t kJobsPerThread = 16;

class JobQueue {
 public:
  static constexpr uint32_t kBindingCount = PB_JOBS_BINDING_COUNT;

  // `capacity` jobs of 8 bytes in each of the two lists.
  void setup(gpu::Device& gpu, uint32_t capacity, uint32_t jobs_per_thread, std::string name);
  // Per-node counters of the sort for `nodes` nodes (cids), and the scan reserved for them.
  void resize(gpu::Device& gpu, PrefixSum& scan, uint32_t nodes);
  void clear(vk::CommandBuffer cmd) const;
  // After the producer: jobs kept and the consumers' dispatch arguments.
  void finish(vk::CommandBuffer cmd) const;
  // After finish: the jobs sorted by node into the list the consumers read (pb_jobs).
  void regroup(vk::CommandBuffer cmd, const PrefixSum& scan) const;
  // One invocation (64 a group) per run of jobs_per_thread sorted jobs, of the bound pipeline.
  void dispatch_consumers(vk::CommandBuffer cmd) const;
  // Passes "top" and "regroup" (nested in the caller's scope): `produce` records the clears and the
  // producer's dispatch, then finish and regroup follow.
  void record_top(Context& ctx, const PrefixSum& scan,
                  const std::function<void(vk::CommandBuffer cmd)>& produce) const;
  void append_bindings(std::vector<gpu::Resource>& resources) const;

  // Counters "jobs" (emitted) and "job_overflows" (dropped), a warning naming `who` and max_jobs
  // when some were dropped; after ctx.flush().
  void report(Context& ctx, std::string_view who) const;
  uint64_t wanted() const;     // this frame's jobs emitted, after ctx.flush()
  uint64_t overflows() const;  // of those, dropped for want of capacity
  uint64_t bytes() const;      // both lists + the sort's counters
  uint32_t capacity() const { return capacity_; }

 private:
  std::string name_;
  uint32_t capacity_ = 0, jobs_per_thread_ = 16;
  gpu::Buffer emitted_, sorted_, stats_;
  gpu::Pipeline args_pipeline_;
  CountingSort sort_;
};

}  // namespace pb::toolkit
