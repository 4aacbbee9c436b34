#include "cell/profiler.h"

#include <fmt/format.h>

#include <ctime>

#include "photonbench/error.h"

namespace pb::run {

double process_cpu_ms() {
  // The kernel's per-process CPU clock sums every thread's run time, so lavapipe's work on its
  // worker threads counts, and time spent runnable but waiting for a core does not
  // (clock_gettime(2)).
  timespec ts{};
  if (clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts) != 0)
    throw Error("clock_gettime(CLOCK_PROCESS_CPUTIME_ID) failed");
  return double(ts.tv_sec) * 1e3 + double(ts.tv_nsec) * 1e-6;
}

Profiler::Profiler(gpu::Device& device, std::function<vk::CommandBuffer()> cmd, uint32_t max_passes)
    : device_(device), cmd_(std::move(cmd)), max_passes_(max_passes) {
  pool_ = vk::raii::QueryPool(
      device.device(), vk::QueryPoolCreateInfo{{}, vk::QueryType::eTimestamp, 2 * max_passes});
}

void Profiler::begin_frame() {
  pool_.reset(0, 2 * max_passes_);  // host query reset (Vulkan 1.2)
  passes_.clear();
  stack_.clear();
}

void Profiler::fence_boundary() {
  if (!flush_) return;
  double ms = flush_();
  for (int open : stack_) passes_[open].fenced_gpu_ms += ms, passes_[open].waited_ms += ms;
}

int Profiler::begin_pass(std::string_view name) {
  fence_boundary();  // work recorded before this pass is not this pass's
  if (passes_.size() >= max_passes_)
    throw Error(fmt::format("more than {} passes in one frame", max_passes_));
  std::string full =
      stack_.empty() ? std::string(name) : passes_[stack_.back()].name + "/" + std::string(name);
  int index = int(passes_.size());
  passes_.push_back(
      {full, int(stack_.size()), uint32_t(2 * index), std::chrono::steady_clock::now()});
  passes_.back().process_cpu_start = process_cpu_ms();
  stack_.push_back(index);
  vk::CommandBuffer cmd = cmd_();
  gpu::full_barrier(cmd);
  cmd.writeTimestamp(vk::PipelineStageFlagBits::eTopOfPipe, *pool_, passes_[index].query);
  return index;
}

void Profiler::end_pass(int pass) {
  if (stack_.empty() || stack_.back() != pass)
    throw Error("pass scopes must end in reverse order of beginning");
  vk::CommandBuffer cmd = cmd_();
  gpu::full_barrier(cmd);
  cmd.writeTimestamp(vk::PipelineStageFlagBits::eBottomOfPipe, *pool_, passes_[pass].query + 1);
  fence_boundary();
  Open& open = passes_[pass];
  auto cpu_now = [&] {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() -
                                                     open.cpu_start)
               .count() -
           open.waited_ms;
  };
  open.cpu_ms = cpu_now();
  open.process_cpu_ms = process_cpu_ms() - open.process_cpu_start;
  if (open.name == slow_pass_ && slow_factor_ > 1.0) {
    bool gpu_dominates = flush_ && open.fenced_gpu_ms > open.cpu_ms;
    // Fenced (lavapipe): the pass's work is its process CPU time, which the spin stretches exactly;
    // its wall time grows by what the spin takes (more where it waits for a core). A wall-time
    // target there would add (factor - 1) x the pass's waiting too, so a loaded machine would make
    // the slowed pass more than `factor` times the work. With timestamps, the CPU clock that
    // dominates is stretched.
    double extra_process_ms = flush_ ? (slow_factor_ - 1.0) * open.process_cpu_ms : 0.0;
    double extra_wall_ms = flush_ ? 0.0 : (slow_factor_ - 1.0) * open.cpu_ms;
    auto start = std::chrono::steady_clock::now();
    double process_start = process_cpu_ms();
    auto spun_ms = [&] {
      return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
          .count();
    };
    while (spun_ms() < extra_wall_ms || process_cpu_ms() - process_start < extra_process_ms) {
    }
    double spun = spun_ms();
    // Like a fence wait, the spin is GPU time of every pass still open (this one and its parents).
    if (gpu_dominates)
      for (int o : stack_) passes_[o].fenced_gpu_ms += spun, passes_[o].waited_ms += spun;
    open.cpu_ms = cpu_now();
    open.process_cpu_ms = process_cpu_ms() - open.process_cpu_start;
  }
  open.closed = true;
  stack_.pop_back();
}

std::vector<PassSample> Profiler::end_frame() {
  std::vector<PassSample> samples;
  if (passes_.empty()) return samples;
  if (!stack_.empty())
    throw Error(fmt::format("pass '{}' was never ended", passes_[stack_.back()].name));
  std::vector<uint64_t> stamps(2 * passes_.size());
  auto result = pool_.getResults<uint64_t>(
      0, uint32_t(stamps.size()), stamps.size() * sizeof(uint64_t), sizeof(uint64_t),
      vk::QueryResultFlagBits::e64 | vk::QueryResultFlagBits::eWait);
  stamps = result.second;
  uint64_t mask =
      device_.timestamp_valid_bits() >= 64 ? ~0ull : ((1ull << device_.timestamp_valid_bits()) - 1);
  for (const Open& open : passes_) {
    uint64_t begin = stamps[open.query] & mask, end = stamps[open.query + 1] & mask;
    double gpu_ms = flush_ ? open.fenced_gpu_ms
                           : double((end - begin) & mask) * device_.timestamp_period_ns() * 1e-6;
    samples.push_back({open.name, open.depth, gpu_ms, open.cpu_ms, open.process_cpu_ms});
  }
  return samples;
}

}  // namespace pb::run
