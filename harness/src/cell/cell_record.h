// A cell's record, cell.json: who the cell is, how it ended and what it measured. Both ends of a
// cell write it through write_cell_record (the child when it finishes, ok or failed; the parent for
// a child that crashed, hung or exited without one), so every cell.json has the same fields. A
// field the cell never reached (no device opened, nothing scored) is left out;
// tools/pbtools/rundata.py reads it.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "plan/plan.h"

namespace pb::run {

// Why a cell failed, and at which frame (none: during set-up or scoring). Thrown by the cell's
// stages, caught once by run_cell.
struct CellFailure {
  std::string reason;
  std::optional<int64_t> frame;
};

struct CellRecord {
  explicit CellRecord(const Cell& cell);

  void fail(const CellFailure& failure);
  // A technique's warning (ctx.warn) at `frame`, or the harness's about the cell (no frame).
  void warn(std::optional<uint32_t> frame, const std::string& message);

  Cell cell;
  // Parameters as the technique resolved them (an automatic value, -1 or 0, made concrete): each
  // counter named as a parameter, its last value. cell.json's params_resolved is the cell's params
  // with these in place.
  std::map<std::string, double> resolved_params;
  std::string status = "ok";  // "ok" or "failed"
  std::string reason;
  std::optional<int64_t> failed_frame;
  nlohmann::json warnings = nlohmann::json::array();  // [{"frame", "message"}]

  std::optional<std::string> path_class;  // the plugin's, once it loaded
  std::optional<std::string> device;      // once the device opened
  std::optional<std::string> timing;      // "fenced" or "timestamps"
  std::optional<nlohmann::json> metrics;  // per path class means (cell/scoring.h), once scored
  std::optional<nlohmann::json> metrics_bounce_matched;  // the same against bounce-matched refs
  std::optional<nlohmann::json> references;  // the references scored against (samples, error, ...)
  // Frame timings, counted over the measured frames so far (cell/frame_log.h).
  std::optional<uint64_t> frames_measured;
  std::optional<nlohmann::json> counters;  // each counter counted: name -> {"kind", "unit"}
  std::optional<nlohmann::json> summary;   // frame_ms, harness_overhead_ms/_pct, pass_ms_median
  std::optional<nlohmann::json> memory;    // peak_host_bytes, gpu_bytes_technique, gpu_bytes_total
  std::optional<bool> validation;          // Vulkan validation layers were on
  std::optional<std::string> log_tail;     // a child that ended without writing its record
  // Wall-clock ms of each stage of the cell process, in order: plan (reading the invocation and
  // planning the run again), startup (device, scene, world), setup (the technique's), frames (the
  // frame loop: timed passes, the harness's work between them, read-backs), scoring, teardown
  // (the technique's and the renderer's destruction). The harness's own cost beside the frames'.
  nlohmann::json stages_ms = nlohmann::json::object();
};

nlohmann::json to_json(const CellRecord& record);

// Writes DIR/cell.json atomically: a cell folder either has a whole record or none.
void write_cell_record(const std::filesystem::path& dir, const CellRecord& record);

}  // namespace pb::run
