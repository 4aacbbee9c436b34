// `photonbench slurm CONFIG --out DIR`: a sweep as Slurm jobs. Two batch scripts in DIR/slurm/:
//   shards.sbatch  a job array, task I running `run CONFIG --shard I/N --out DIR/shards/I` (a task
//                  that is requeued or submitted again resumes its shard's run);
//   merge.sbatch   `merge DIR/run DIR/shards/1 .. N`, submitted to start after every task has
//                  ended (afterany: a failed cell fails its task, and merge still reports it).
// Every job works in DIR (#SBATCH --chdir), so a relative reference.cache_dir (the default
// results/reference-cache) is one cache in DIR that the shards share (reference.h: entries
// are content-addressed, written atomically, and rendered once under a lock). DIR, the config and
// the photonbench executable must be on a filesystem every node sees.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "plan/plan.h"

namespace pb::run {

struct SlurmOptions {
  std::filesystem::path config_file;
  std::vector<std::string> overrides;  // --set and --plugin-dir, passed to every shard
  std::filesystem::path out_dir;
  std::filesystem::path executable;  // the photonbench the jobs run (absolute)
  std::string device;                // --device, passed to every shard
  std::string partition, time;       // #SBATCH --partition, --time when given
  uint32_t gpus_per_task = 0;        // #SBATCH --gpus-per-task when > 0
  uint32_t cpus_per_task = 0;        // #SBATCH --cpus-per-task when > 0
  uint32_t shards = 0;               // 0: one per cell
};

struct SlurmJobs {
  std::filesystem::path shards_script, merge_script;
  uint32_t shards = 0;
};

// Writes the two scripts for `plan` (made from options.config_file and overrides). Throws
// pb::InputError for a path an #SBATCH line cannot hold or more shards than cells.
SlurmJobs write_slurm_jobs(const SlurmOptions& options, const RunPlan& plan);

// Submits the array, then the merge job depending on it; returns their job ids. pb::Error when
// sbatch is missing or refuses (its own message is on stderr).
std::pair<std::string, std::string> submit_slurm_jobs(const SlurmJobs& jobs);

// `text` quoted for a POSIX shell, always in single quotes.
std::string shell_quote(const std::string& text);

}  // namespace pb::run
