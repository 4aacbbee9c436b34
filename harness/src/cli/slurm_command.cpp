// `photonbench slurm CONFIG --out DIR`: writes a sweep's Slurm job array and merge job
// (run/slurm.h) and, with --submit, submits them and prints their job ids.
#include <fmt/format.h>

#include <cstdio>
#include <filesystem>

#include "cli/command.h"
#include "run/shard.h"
#include "run/slurm.h"

namespace {

void add_slurm(CLI::App& app, int& exit_code) {
  auto options = std::make_shared<pb::run::SlurmOptions>();
  auto submit = std::make_shared<bool>(false);
  auto plugin_dirs = std::make_shared<std::vector<std::string>>();
  auto* cmd = app.add_subcommand(
      "slurm",
      "write (and with --submit, submit) a sweep as a Slurm job array, one task per "
      "shard, and a job that merges the shards when they end");
  cmd->add_option("config", options->config_file, "the YAML config")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--out", options->out_dir,
                  "the sweep's folder, on a filesystem every node sees: scripts, shard runs, the "
                  "merged run (DIR/run) and the shared reference cache")
      ->required();
  cmd->add_option("--shards", options->shards, "number of shards (default: one per cell)")
      ->check(CLI::Range(1u, 100000u));
  cmd->add_option("--partition", options->partition, "#SBATCH --partition");
  cmd->add_option("--time", options->time, "#SBATCH --time, per task (e.g. 2:00:00)");
  cmd->add_option("--gpus-per-task", options->gpus_per_task, "#SBATCH --gpus-per-task")
      ->check(CLI::Range(1u, 64u));
  cmd->add_option("--cpus-per-task", options->cpus_per_task, "#SBATCH --cpus-per-task")
      ->check(CLI::Range(1u, 4096u));
  cmd->add_option("--device", options->device, "each shard's --device");
  cmd->add_option("--set", options->overrides, "each shard's --set (repeatable)");
  cmd->add_option("--plugin-dir", *plugin_dirs, "each shard's --plugin-dir (repeatable)")
      ->check(CLI::ExistingDirectory);
  cmd->add_flag("--submit", *submit, "submit the jobs with sbatch and print their ids");
  cmd->callback([options, submit, plugin_dirs, &exit_code] {
    for (const auto& dir : *plugin_dirs)
      options->overrides.push_back("plugin_dirs+=" + std::filesystem::absolute(dir).string());
    options->executable = std::filesystem::read_symlink("/proc/self/exe");
    const pb::run::RunPlan plan = pb::run::plan_run(options->config_file, options->overrides);
    if (plan.config.match)
      plan.config.match->node.fail(
          "a match run cannot be sharded into Slurm tasks: each probe's knob value comes from the "
          "probes before it; run it whole");
    const pb::run::SlurmJobs jobs = pb::run::write_slurm_jobs(*options, plan);
    // The split every task will compute, so that the user sees the balance before submitting.
    double largest = 0;
    for (uint32_t i = 1; i <= jobs.shards; ++i)
      largest = std::max(largest, pb::run::select_shard(plan, {i, jobs.shards}).share());
    std::printf(
        "slurm: %zu cells in %u shards; the largest holds %.1f%% of the estimated work (an "
        "even split: %.1f%%)\n",
        plan.cells.size(), jobs.shards, 100 * largest, 100.0 / jobs.shards);
    std::printf("slurm: wrote %s and %s\n", jobs.shards_script.c_str(), jobs.merge_script.c_str());
    if (!*submit) {
      std::printf(
          "slurm: submit with\n  jobid=$(sbatch --parsable %s) && sbatch "
          "--dependency=afterany:$jobid %s\n",
          jobs.shards_script.c_str(), jobs.merge_script.c_str());
      exit_code = 0;
      return;
    }
    const auto [array, merge] = pb::run::submit_slurm_jobs(jobs);
    std::printf("slurm: submitted the shards as job %s (array 1-%u) and the merge as job %s\n",
                array.c_str(), jobs.shards, merge.c_str());
    std::printf("shards_job=%s\nmerge_job=%s\n", array.c_str(), merge.c_str());
    exit_code = 0;
  });
}

pb::cli::CommandRegistration slurm_registration{"slurm", add_slurm};

}  // namespace
