#include "cell/frame_log.h"

#include <fmt/format.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>

#include "cell/stats.h"

namespace pb::run {

namespace {

std::string ms_text(double ms) { return fmt::format("{:.4f}", ms); }

// Resident memory now (the second field of /proc/self/statm, in pages); 0 where it cannot be read.
uint64_t current_host_bytes() {
  std::FILE* file = std::fopen("/proc/self/statm", "r");
  if (!file) return 0;
  unsigned long long size = 0, resident = 0;
  const int read = std::fscanf(file, "%llu %llu", &size, &resident);
  std::fclose(file);
  return read == 2 ? uint64_t(resident) * uint64_t(sysconf(_SC_PAGESIZE)) : 0;
}

// The kernel updates ru_maxrss lazily (the long run read it 0.4 MB below the resident memory of the
// same moment), so FrameLog also keeps the largest resident memory it saw after a frame.
uint64_t peak_host_bytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return uint64_t(usage.ru_maxrss) * 1024;  // Linux reports kilobytes
}

}  // namespace

FrameLog::FrameLog(const std::filesystem::path& cell_dir)
    : frames_csv_(cell_dir / "frames.csv", {"frame", "pass", "gpu_ms", "cpu_ms", "process_cpu_ms"}),
      counters_csv_(cell_dir / "counters.csv", {"frame", "name", "value"}) {}

void FrameLog::add(const FrameTiming& timing,
                   const std::vector<std::pair<std::string, double>>& counters) {
  // Harness overhead: the frame's wall time less what the passes themselves took, counting a pass's
  // CPU time (its recording, or its CPU work) and its GPU time (its execution) as its own. What is
  // left is the harness's: pass bookkeeping, submission and the fence. The frame's process CPU time
  // is split the same way.
  double passes_ms = 0, passes_process_ms = 0;
  for (const PassSample& s : timing.passes)
    if (s.depth == 0) passes_ms += s.cpu_ms + s.gpu_ms, passes_process_ms += s.process_cpu_ms;
  const double overhead = std::max(0.0, timing.wall_ms - passes_ms);
  const double overhead_process = std::max(0.0, timing.process_cpu_ms - passes_process_ms);

  const std::string frame = std::to_string(timing.frame);
  for (const PassSample& s : timing.passes) {
    frames_csv_.row(
        {frame, s.name, ms_text(s.gpu_ms), ms_text(s.cpu_ms), ms_text(s.process_cpu_ms)});
    pass_ms_[s.name].push_back(s.ms());
  }
  frames_csv_.row({frame, "harness-overhead", "", ms_text(overhead), ms_text(overhead_process)});
  frames_csv_.row({frame, "frame", "", ms_text(timing.wall_ms), ms_text(timing.process_cpu_ms)});
  frame_ms_.push_back(timing.wall_ms);
  overhead_ms_.push_back(overhead);
  for (const auto& [name, value] : counters)
    counters_csv_.row({frame, name, fmt::format("{}", value)});
}

void FrameLog::track_gpu_memory(uint64_t technique_bytes, uint64_t total_bytes) {
  gpu_bytes_technique_ = std::max(gpu_bytes_technique_, technique_bytes);
  gpu_bytes_total_ = std::max(gpu_bytes_total_, total_bytes);
  // A long run's memory is flat when the whole run's peaks equal those of its first frames.
  const uint64_t resident = current_host_bytes();
  host_bytes_peak_ = std::max(host_bytes_peak_, resident);
  if (++frames_tracked_ == kEarlyFrames) {
    early_memory_ = {{"frames", kEarlyFrames},
                     {"peak_host_bytes", std::max(peak_host_bytes(), host_bytes_peak_)},
                     {"host_bytes", resident},
                     {"gpu_bytes_technique", gpu_bytes_technique_},
                     {"gpu_bytes_total", gpu_bytes_total_}};
  }
}

void FrameLog::describe(CellRecord& record) const {
  nlohmann::json pass_medians = nlohmann::json::object();
  for (const auto& [name, values] : pass_ms_) pass_medians[name] = percentile(values, 50);
  double overhead_pct = 0;
  if (!frame_ms_.empty())
    overhead_pct = 100.0 * percentile(overhead_ms_, 50) / std::max(percentile(frame_ms_, 50), 1e-9);
  record.frames_measured = frame_ms_.size();
  record.summary = {{"frame_ms", run::describe(frame_ms_)},
                    {"harness_overhead_ms", run::describe(overhead_ms_)},
                    {"pass_ms_median", pass_medians},
                    {"harness_overhead_pct", overhead_pct}};
  // The process's peak resident memory: the harness's and the technique's together.
  const uint64_t resident = current_host_bytes();
  record.memory = {{"peak_host_bytes", std::max({peak_host_bytes(), host_bytes_peak_, resident})},
                   {"gpu_bytes_technique", gpu_bytes_technique_},
                   {"gpu_bytes_total", gpu_bytes_total_},
                   {"host_bytes_end", resident},
                   {"first_100_frames", early_memory_}};
}

}  // namespace pb::run
