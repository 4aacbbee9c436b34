// The profiler's process CPU clock (frames.csv process_cpu_ms) and its testing hook
// (testing.slow_pass) under fenced timing, the lavapipe path. No timed assertions: only lower
// bounds that hold on any machine, however loaded. Threads that consumed X ms of CPU while a pass
// was open make the process consume at least X ms in it, and the hook must add at least (factor -
// 1) x that again.
#include "cell/profiler.h"

#include <gtest/gtest.h>

#include <ctime>
#include <thread>
#include <vector>

#include "command_stream.h"

namespace pb {
namespace profiler_test {

double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) * 1e3 + double(ts.tv_nsec) * 1e-6;
}

// Consumes `ms` of this thread's CPU time (not wall time: a preempted thread keeps going).
void burn_cpu_ms(double ms) {
  const double end = thread_cpu_ms() + ms;
  volatile unsigned x = 1;
  while (thread_cpu_ms() < end) x = x * 1664525u + 1013904223u;
}

// One frame with a pass "outer" holding a pass "work" in which `threads` threads each burn `ms` of
// CPU time at once, as llvmpipe's workers execute a pass. Fenced timing, with the runner's flush:
// submit what is recorded, wait, begin a new command buffer.
std::vector<run::PassSample> one_frame(int threads, double ms, const std::string& slow_pass,
                                       double factor) {
  gpu::Device device({"", false});
  testing::CommandStream commands(device);
  auto begin = [&] { commands.begin(); };
  auto submit = [&] { commands.submit(); };
  auto cmd = [&] { return commands.cmd(); };
  run::Profiler profiler(device, cmd);
  profiler.use_fenced_timing([&] {
    submit();
    begin();
    return 0.0;  // the wall time of the flush does not matter here
  });
  if (!slow_pass.empty()) profiler.slow_down(slow_pass, factor);
  profiler.begin_frame();
  begin();
  int outer = profiler.begin_pass("outer");
  int work = profiler.begin_pass("work");
  {
    std::vector<std::thread> pool_threads;
    for (int t = 0; t < threads; ++t) pool_threads.emplace_back([ms] { burn_cpu_ms(ms); });
    for (auto& t : pool_threads) t.join();
  }
  profiler.end_pass(work);
  profiler.end_pass(outer);
  submit();
  return profiler.end_frame();
}

TEST(Profiler, ProcessCpuTimeCountsEveryThreadsWork) {
  auto samples = one_frame(/*threads=*/2, /*ms=*/20, "", 1.0);
  ASSERT_EQ(samples.size(), 2u);
  EXPECT_EQ(samples[1].name, "outer/work");
  EXPECT_GE(samples[1].process_cpu_ms, 2 * 20.0);  // both threads' CPU time, not the wall time
  // a parent contains its children
  EXPECT_GE(samples[0].process_cpu_ms, samples[1].process_cpu_ms);
}

TEST(Profiler, SlowPassHookStretchesProcessCpuTimeByTheFactor) {
  // The work is 2 x 20 ms of CPU done in about 20 ms of wall time. Stretching process CPU time by
  // the factor needs at least (2 - 1) x 40 ms more; a hook that stretched the wall time would add
  // ~20 ms.
  auto samples = one_frame(/*threads=*/2, /*ms=*/20, "outer/work", 2.0);
  ASSERT_EQ(samples.size(), 2u);
  EXPECT_GE(samples[1].process_cpu_ms, 2.0 * 2 * 20.0);
  EXPECT_GE(samples[0].process_cpu_ms, samples[1].process_cpu_ms);  // the parent holds the spin too
  // No GPU work here, so the pass is a CPU pass: its CPU clock holds the work and the spin (one
  // thread spinning for 40 ms of CPU time takes at least 40 ms of wall time).
  EXPECT_GE(samples[1].cpu_ms, 20.0 + 2 * 20.0);
  EXPECT_GE(samples[0].cpu_ms, samples[1].cpu_ms);
}

}  // namespace profiler_test
}  // namespace pb
