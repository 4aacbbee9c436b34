#include "run/slurm.h"

#include <fmt/format.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "io/results.h"
#include "photonbench/error.h"

namespace pb::run {

namespace {

// sbatch reads an #SBATCH line as words split at blanks, without shell quoting.
std::string sbatch_path(const std::filesystem::path& path, const std::string& what) {
  const std::string text = path.string();
  if (text.find_first_of(" \t\n'\"\\") != std::string::npos)
    throw InputError(
        fmt::format("{} '{}': a path in an #SBATCH line cannot hold blanks, quotes or "
                    "backslashes; choose another",
                    what, text));
  return text;
}

// The #SBATCH lines both jobs share: partition and time limit when given, one task, the folder.
std::string common_directives(const SlurmOptions& options, const std::string& dir) {
  std::string text = fmt::format("#SBATCH --ntasks=1\n#SBATCH --chdir={}\n", dir);
  if (!options.partition.empty())
    text += fmt::format("#SBATCH --partition={}\n", options.partition);
  if (!options.time.empty()) text += fmt::format("#SBATCH --time={}\n", options.time);
  return text;
}

// Runs argv (no shell), returns its stdout; its stderr goes to ours. pb::Error if it cannot start
// or exits non-zero.
std::string capture_output(const std::vector<std::string>& argv) {
  std::fflush(stdout);  // the child inherits our buffers otherwise
  std::fflush(stderr);
  int fds[2];
  if (pipe(fds) != 0) throw Error(fmt::format("pipe: {}", std::strerror(errno)));
  const pid_t pid = fork();
  if (pid < 0) throw Error(fmt::format("fork: {}", std::strerror(errno)));
  if (pid == 0) {
    dup2(fds[1], STDOUT_FILENO);
    close(fds[0]);
    close(fds[1]);
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    execvp(args[0], args.data());
    std::fprintf(stderr, "cannot run %s: %s\n", args[0], std::strerror(errno));
    _exit(127);
  }
  close(fds[1]);
  std::string out;
  char buffer[4096];
  for (ssize_t n; (n = read(fds[0], buffer, sizeof buffer)) != 0;) {
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) break;
    out.append(buffer, size_t(n));
  }
  close(fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw Error(fmt::format(
        "{} failed ({}){}", fmt::join(argv, " "),
        WIFEXITED(status) ? fmt::format("exit {}", WEXITSTATUS(status)) : std::string("killed"),
        WIFEXITED(status) && WEXITSTATUS(status) == 127
            ? ": is this a Slurm submit host (sbatch on PATH)?"
            : ""));
  return out;
}

// `sbatch --parsable` prints "ID" or "ID;CLUSTER".
std::string job_id(const std::string& parsable) {
  std::string id = parsable.substr(0, parsable.find_first_of(";\n"));
  if (id.empty() || !std::all_of(id.begin(), id.end(), [](char c) { return c >= '0' && c <= '9'; }))
    throw Error(fmt::format("sbatch printed '{}', not a job id", parsable));
  return id;
}

}  // namespace

std::string shell_quote(const std::string& text) {
  std::string quoted = "'";
  for (char c : text) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

// The merge job's script: it merges the shards' runs into DIR/run and reports.
std::string merge_script(const SlurmOptions& options, const RunPlan& plan,
                         const std::filesystem::path& dir, uint32_t shards) {
  const std::string dir_text = sbatch_path(dir, "--out");
  const std::string job = "pb-" + plan.config.name;
  std::string merge = fmt::format(
      "#!/bin/bash\n"
      "# photonbench sweep '{name}': merges the {n} shards into {dir}/run and reports (written by\n"
      "# `photonbench slurm`; submitted to start after the array). Outside Slurm:\n"
      "#   bash {file}\n"
      "#SBATCH --job-name={job}-merge\n"
      "#SBATCH --output={dir}/slurm/merge.log\n"
      "{common}"
      "set -euo pipefail\n"
      "cd {qdir}\n"
      "# Merged again (the sweep resubmitted after a failure): the earlier merge is kept beside "
      "it.\n"
      "if [ -e {out}/run.json ]; then mv {out} {out}.\"$(date +%Y%m%d-%H%M%S)\"; fi\n"
      "exec {pb} merge {out}",
      fmt::arg("name", plan.config.name), fmt::arg("n", shards), fmt::arg("dir", dir_text),
      fmt::arg("qdir", shell_quote(dir.string())),
      fmt::arg("file", (dir / "slurm" / "merge.sbatch").string()), fmt::arg("job", job),
      fmt::arg("common", common_directives(options, dir_text)),
      fmt::arg("pb", shell_quote(options.executable.string())),
      fmt::arg("out", shell_quote((dir / "run").string())));
  for (uint32_t i = 1; i <= shards; ++i)
    merge += fmt::format(" {}", shell_quote((dir / "shards" / std::to_string(i)).string()));
  merge += "\n";
  return merge;
}

SlurmJobs write_slurm_jobs(const SlurmOptions& options, const RunPlan& plan) {
  const uint32_t cells = uint32_t(plan.cells.size());
  const uint32_t shards = options.shards ? options.shards : cells;
  if (cells == 0)
    throw InputError(fmt::format("{}: the config has no cells", options.config_file.string()));
  if (shards > cells)
    throw InputError(fmt::format("--shards {}: the config has only {} cells", shards, cells));
  const std::filesystem::path dir =
      std::filesystem::weakly_canonical(std::filesystem::absolute(options.out_dir));
  const std::string dir_text = sbatch_path(dir, "--out");
  std::filesystem::create_directories(dir / "slurm");
  const std::string job = "pb-" + plan.config.name;

  // One shard's command line; the task index comes from Slurm.
  std::string run =
      fmt::format("{} run {} --shard \"$shard\" --out \"$out\" \"${{resume[@]}}\"",
                  shell_quote(options.executable.string()),
                  shell_quote(std::filesystem::absolute(options.config_file).string()));
  for (const auto& o : options.overrides) run += fmt::format(" --set {}", shell_quote(o));
  if (!options.device.empty()) run += fmt::format(" --device {}", shell_quote(options.device));

  std::string array = fmt::format(
      "#!/bin/bash\n"
      "# photonbench sweep '{name}': {cells} cells in {n} shards, one array task each (written by\n"
      "# `photonbench slurm`). Outside Slurm, shard I runs with\n"
      "#   SLURM_ARRAY_TASK_ID=I bash {file}\n"
      "#SBATCH --job-name={job}\n"
      "#SBATCH --array=1-{n}\n"
      "#SBATCH --output={dir}/slurm/shard-%a.log\n"
      "{common}",
      fmt::arg("name", plan.config.name), fmt::arg("cells", cells), fmt::arg("n", shards),
      fmt::arg("file", (dir / "slurm" / "shards.sbatch").string()), fmt::arg("job", job),
      fmt::arg("dir", dir_text), fmt::arg("common", common_directives(options, dir_text)));
  if (options.gpus_per_task)
    array += fmt::format("#SBATCH --gpus-per-task={}\n", options.gpus_per_task);
  if (options.cpus_per_task)
    array += fmt::format("#SBATCH --cpus-per-task={}\n", options.cpus_per_task);
  array += fmt::format(
      "set -euo pipefail\n"
      "cd {dir}  # as --chdir: a relative reference.cache_dir is the sweep's shared cache\n"
      "shard=\"${{SLURM_ARRAY_TASK_ID:?run as a Slurm array task}}/{n}\"\n"
      "out={shards}/\"$SLURM_ARRAY_TASK_ID\"\n"
      "# A requeued or resubmitted task continues its shard's run instead of starting over.\n"
      "resume=()\n"
      "if [ -e \"$out/invocation.json\" ]; then resume=(--resume); fi\n"
      "echo \"photonbench shard $shard on $(hostname), job ${{SLURM_JOB_ID:-none}}\"\n"
      "exec {run}\n",
      fmt::arg("n", shards), fmt::arg("dir", shell_quote(dir.string())),
      fmt::arg("shards", shell_quote((dir / "shards").string())), fmt::arg("run", run));

  const std::string merge = merge_script(options, plan, dir, shards);

  SlurmJobs jobs{dir / "slurm" / "shards.sbatch", dir / "slurm" / "merge.sbatch", shards};
  io::write_text_atomic(jobs.shards_script, array);
  io::write_text_atomic(jobs.merge_script, merge);
  for (const auto& file : {jobs.shards_script, jobs.merge_script})
    std::filesystem::permissions(file, std::filesystem::perms::owner_exec,
                                 std::filesystem::perm_options::add);
  return jobs;
}

std::pair<std::string, std::string> submit_slurm_jobs(const SlurmJobs& jobs) {
  const std::string array =
      job_id(capture_output({"sbatch", "--parsable", jobs.shards_script.string()}));
  const std::string dependency = "--dependency=afterany:" + array;
  try {
    return {
        array,
        job_id(capture_output({"sbatch", "--parsable", dependency, jobs.merge_script.string()}))};
  } catch (const Error& e) {
    throw Error(
        fmt::format("{}; the shards are submitted (job {}): submit the merge by hand, "
                    "sbatch {} {}",
                    e.what(), array, dependency, jobs.merge_script.string()));
  }
}

}  // namespace pb::run
