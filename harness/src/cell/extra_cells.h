// Cells a run adds to its plan as it goes: a match run's probes, the found cells' other seeds and
// their re-measurement rounds (run/match.h). Their values come from measurements, so no config
// expands to them; they are kept in RUN_DIR/match/cells.json, which the parent rewrites (whole,
// atomically) before it starts each one, so that the cell's child process finds its cell by id
// there when the plan has none of that id, and a --resume finds the same cells.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "plan/plan.h"

namespace pb::run {

struct ExtraCell {
  Cell cell;
  std::string role;  // "probe", "seed" or "round"
};

std::vector<ExtraCell> read_extra_cells(const std::filesystem::path& run_dir);
// Adds `cell` (a cell of the same id already there is kept as it is).
void add_extra_cell(const std::filesystem::path& run_dir, const Cell& cell,
                    const std::string& role);
std::optional<Cell> find_extra_cell(const std::filesystem::path& run_dir, const std::string& id);

}  // namespace pb::run
