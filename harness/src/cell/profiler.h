// Named, nestable pass timing (docs/architecture.md, "Timing"): each pass takes a pair of timestamp
// queries from a per-frame pool, bracketed by full barriers (the spec lets later commands overlap a
// timestamp write), plus a CPU monotonic clock and the process's CPU time. Results are read as
// 64-bit values after the frame's fence and converted with timestampPeriod.
#pragma once

#include <chrono>
#include <functional>
#include <string>
#include <vector>

#include "photonbench/context.h"
#include "photonbench/gpu.h"

namespace pb::run {

// CPU time consumed so far by this process, all threads together (CLOCK_PROCESS_CPUTIME_ID), in ms.
double process_cpu_ms();

struct PassSample {
  std::string name;  // "outer/inner" for nested passes
  int depth = 0;     // 0 for top-level passes
  double gpu_ms = 0, cpu_ms = 0;
  // CPU time the whole process consumed while the pass was open (every thread: the recording thread
  // and, on lavapipe, llvmpipe's worker threads that execute the "GPU" work). With fenced timing
  // the pass's work is done inside its boundaries, so this is the work the pass cost, without the
  // time spent waiting for a core on a loaded machine (frames.csv `process_cpu_ms`;
  // tools/pbtools/compare.py uses it on fenced runs). With timestamps it is only the CPU side
  // (recording, CPU passes).
  double process_cpu_ms = 0;
  double ms() const { return gpu_ms > cpu_ms ? gpu_ms : cpu_ms; }  // the pass's time: where it ran
};

class Profiler : public PassRecorder {
 public:
  Profiler(gpu::Device& device, std::function<vk::CommandBuffer()> cmd, uint32_t max_passes = 256);
  void begin_frame();                   // host-resets the queries, clears the samples
  std::vector<PassSample> end_frame();  // after the frame's fence: reads the timestamps

  int begin_pass(std::string_view name) override;
  void end_pass(int pass) override;
  // Testing hook (config `testing.slow_pass`): the named pass is made `factor` times slower by
  // spinning at its end. With fenced timing (lavapipe) the spin lasts until the process has
  // consumed (factor - 1) x the pass's process CPU time so far, so process_cpu_ms, the clock
  // compare reads there, grows by exactly `factor`; the spin's wall time is added to the pass's
  // dominant clock (at least factor - 1 of its work; more where the spin waits for a core). With
  // timestamps only the CPU clock can be stretched: the spin lasts (factor - 1) x the pass's
  // cpu_ms.
  void slow_down(std::string pass, double factor) {
    slow_pass_ = std::move(pass), slow_factor_ = factor;
  }

  // Fenced timing, for devices whose timestamps miss raster work (lavapipe bins rasterisation and
  // runs it after the closing timestamp: tests/unit/timing_test.cpp). Every pass boundary then
  // submits what is recorded and waits; a pass's GPU time is the fenced wall time of the
  // submissions made while it was open, and its CPU time excludes those waits. `flush` submits,
  // waits, and returns the wall ms.
  void use_fenced_timing(std::function<double()> flush) { flush_ = std::move(flush); }
  bool fenced() const { return bool(flush_); }

 private:
  gpu::Device& device_;
  std::function<vk::CommandBuffer()> cmd_;
  vk::raii::QueryPool pool_{nullptr};
  uint32_t max_passes_;
  struct Open {
    std::string name;
    int depth;
    uint32_t query;
    std::chrono::steady_clock::time_point cpu_start;
    double cpu_ms = 0;
    double process_cpu_start = 0, process_cpu_ms = 0;
    double fenced_gpu_ms = 0;
    double waited_ms = 0;  // time this pass's CPU clock spent waiting on fences
    bool closed = false;
  };
  void fence_boundary();
  std::function<double()> flush_;
  std::string slow_pass_;
  double slow_factor_ = 1.0;
  std::vector<Open> passes_;
  std::vector<int> stack_;
};

}  // namespace pb::run
