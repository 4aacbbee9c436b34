// `photonbench stability`: every technique through every stress scenario, each cell classified ok,
// degraded or failed with its reason. A stability file (configs/stress/stability.yaml)
// is a benchmark config without `scenes`, plus `stability` (the rules and the baseline) and
// `scenarios` (each a scene entry with the weakness it aims at). It becomes one generated benchmark
// config, run by the ordinary run machinery into the run folder; the cells' records are then
// classified into stability.csv.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "config/yaml_view.h"

namespace pb::run {

// What the classifier reads of one cell (cell.json).
struct CellOutcome {
  std::string status;  // "ok" or "failed"
  std::string reason;  // the harness's reason when failed
  // Warnings a technique raised while rendering a frame (overflowed lists, cut traversals): the
  // frame and the message. Warnings outside frames (set-up, scoring) are not in here.
  std::vector<std::pair<uint32_t, std::string>> frame_warnings;
  std::optional<double> flip;        // mean FLIP against the combined full reference
  std::optional<double> flip_floor;  // its noise floor (the reference's own noise)
  // The hook for the temporal half of the stress suite (the `seeds` helper's flicker metric): when
  // a cell record carries metrics.combined.flicker, a value above StabilityRules::flicker_bound
  // makes the cell degraded. Nothing here computes it.
  std::optional<double> flicker;
};

struct StabilityRules {
  // Degraded: FLIP above this factor times the same technique's FLIP on the scenario's baseline.
  double degraded_factor = 2.0;
  // A FLIP under this many times its noise floor is not resolved from the reference's noise
  // (README, "Scores and their noise floors"), so it cannot be called degraded.
  double resolved_floor_factor = 4.0;
  std::optional<double> flicker_bound;  // degraded above it (see CellOutcome::flicker)
  // Degraded also when FLIP is above no_gi_factor (unset: degraded_factor) times this technique's
  // on the same scenario (`direct`: no indirect light at all), so that a technique adding wrong
  // light where there is almost none (a leak out of a closed box) shows even though its baseline
  // error is larger; 1: worse than no indirect light. Resolved when the difference is beyond the
  // two noise floors together.
  std::string no_gi_technique;
  std::optional<double> no_gi_factor;
};

enum class StabilityClass { ok, degraded, failed, unrated, skipped };
const char* stability_class_name(StabilityClass c);

struct Verdict {
  StabilityClass verdict = StabilityClass::ok;
  std::string reason;
  std::optional<double> ratio;  // FLIP / baseline FLIP, when both exist
};

// One cell against its baseline cell (null when the baseline is this very cell, or has no record)
// and against the no_gi_technique's cell on the same scenario (null when there is none, or it is
// this cell). Failed: the cell failed (crash, time-out, NaN/Inf, validation error, technique error)
// or warned during a frame. Unrated: it ran but cannot be compared (no score, or its baseline
// failed). Degraded: FLIP resolved and above degraded_factor x the baseline's or x the no-GI
// technique's, or flicker above its bound.
Verdict classify_cell(const CellOutcome& cell, const CellOutcome* baseline,
                      const StabilityRules& rules, const CellOutcome* no_gi = nullptr);

// The outcome of cells/<id>/cell.json.
CellOutcome read_cell_outcome(const std::filesystem::path& cell_json);

struct StabilityOptions {
  std::filesystem::path stability_file;
  std::vector<std::string> overrides;  // --set, applied to the generated benchmark config
  std::filesystem::path out_dir;       // empty: results/<name>-<time>
  std::string device;
  bool resume = false;
  bool validation = false;
  // --technique (repeatable): only these of the file's techniques run, with its no_gi_technique;
  // a scenario's params that only the others have are dropped. Empty: every built technique.
  std::vector<std::string> techniques;
};

// Runs the suite and writes OUT/benchmark.yaml (the generated config), the run's usual files and
// OUT/stability.csv; prints the matrix. Returns 0 when stability.csv was written (failed cells are
// results here, not errors); bad input throws pb::InputError.
int run_stability(const StabilityOptions& options);

}  // namespace pb::run
