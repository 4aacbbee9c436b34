// A run's record, run.json: the tool and commit, the config as run (its canonical text and hash),
// the device, driver, CPU and OS, how passes are timed, the cell count and the start and end times.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "plan/plan.h"

namespace pb::run {

// A score is resolved from the reference's noise when it lies at least this many times its noise
// floor (as a distance from the reference; tools/pbtools/floors.py says why 4: the noise then
// inflates a norm by at most a quarter). One constant for the harness (a match's quality target)
// and the tools, which read it from run.json ("resolve_factor").
inline constexpr double kResolveFactor = 4.0;

// UTC now, ISO 8601 ("2026-01-31T12:00:00Z").
std::string now_iso();

// run.json as the run starts ("end" null), for `plan` made from `config_file` and `overrides`.
// The device (`device_filter`, as --device) is opened once here, to record it and to reject a bad
// --device before any cell runs. A resumed run keeps its first start and notes when it was resumed.
nlohmann::json describe_run(const std::filesystem::path& config_file,
                            const std::vector<std::string>& overrides,
                            const std::string& device_filter, const RunPlan& plan,
                            const std::filesystem::path& run_dir);

}  // namespace pb::run
