// The measured frames' records: frames.csv (each pass's GPU, CPU and process CPU ms, then the
// harness's overhead and the whole frame) and counters.csv, rows appended as each frame finishes so
// that a cell that crashes keeps what it measured; and the order statistics of cell.json's
// `summary` and `memory`.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "cell/cell_record.h"
#include "cell/profiler.h"
#include "io/results.h"

namespace pb::run {

// One frame's timed region (scene-update, the technique's passes, submission and the fence).
struct FrameTiming {
  uint32_t frame = 0;
  std::vector<PassSample> passes;
  double wall_ms = 0;
  double process_cpu_ms = 0;  // CPU time of every thread of the process (profiler.h)
};

class FrameLog {
 public:
  explicit FrameLog(const std::filesystem::path& cell_dir);

  // A measured frame (warm-up frames are not logged): its rows in frames.csv and counters.csv.
  void add(const FrameTiming& timing, const std::vector<std::pair<std::string, double>>& counters);
  // GPU memory after a frame, warm-up frames included: the technique's (allocated since its set-up
  // began) and everything the device holds. The record keeps the peaks, and the same peaks (with
  // the host's) over the first kEarlyFrames frames, for a long run to show its memory flat.
  void track_gpu_memory(uint64_t technique_bytes, uint64_t total_bytes);
  static constexpr uint32_t kEarlyFrames = 100;
  // frames_measured, summary and memory, over the frames logged so far.
  void describe(CellRecord& record) const;

 private:
  io::CsvAppender frames_csv_, counters_csv_;
  std::vector<double> frame_ms_, overhead_ms_;
  std::map<std::string, std::vector<double>> pass_ms_;
  uint64_t gpu_bytes_technique_ = 0, gpu_bytes_total_ = 0;
  uint32_t frames_tracked_ = 0;
  uint64_t host_bytes_peak_ = 0;  // the largest resident memory after a frame
  nlohmann::json early_memory_;   // null until kEarlyFrames frames are done
};

}  // namespace pb::run
