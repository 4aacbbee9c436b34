// A match run (`match:` in a config): the comparison rendering papers make by hand, at equal time
// or equal quality. For each match of the plan (plan/match_plan.h) the search (match_search.h)
// probes the budget knob, each probe a real cell of the run with its frames and scores; then every
// found cell runs at the config's other seeds (`seeds` > 1), and each scene's found cells and
// baselines are re-measured `rounds` times in alternating order (forward, then backward, ...), so
// that a machine's drift while the search ran lands on every technique alike. Writes
// RUN_DIR/match.csv (one row per match and baseline) and RUN_DIR/match_probes.csv (one row per cell
// the matches ran).
#pragma once

#include <filesystem>

#include "plan/match_plan.h"
#include "run/cell_runs.h"

namespace pb::run {

struct MatchOutcome {
  CellTally tally;
  int unmatched = 0;  // matches whose status is not `matched`
};

// The most cells run_matches may start (every search at max_probes): the progress lines' count.
size_t match_cell_bound(const config::Config& config, const MatchPlan& matches);

MatchOutcome run_matches(const RunPlan& plan, const MatchPlan& matches, CellRuns& runs);

}  // namespace pb::run
