#include "cell/cell_process.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <vector>

#include "cell/cell_record.h"
#include "cell/cell_runner.h"
#include "io/results.h"
#include "photonbench/error.h"

namespace pb::run {

using Clock = std::chrono::steady_clock;

Progress::Progress(size_t cells)
    : cells_(cells), tty_(isatty(STDERR_FILENO)), last_line_(Clock::now()) {}

void Progress::update(size_t cell, const std::string& id, uint32_t done, uint32_t total,
                      double elapsed_s) {
  if (tty_) {
    int width = 24, filled = total ? int(width * done / total) : 0;
    std::fprintf(stderr, "\r[cell %zu/%zu] %-44.44s [%s%s] frame %u/%u %5.0fs", cell + 1, cells_,
                 id.c_str(), std::string(filled, '#').c_str(),
                 std::string(width - filled, '.').c_str(), done, total, elapsed_s);
    std::fflush(stderr);
  } else if (Clock::now() - last_line_ > std::chrono::seconds(10)) {
    std::fprintf(stderr, "[cell %zu/%zu] %s: frame %u/%u, %.0f s\n", cell + 1, cells_, id.c_str(),
                 done, total, elapsed_s);
    last_line_ = Clock::now();
  }
}

void Progress::finish(size_t cell, const std::string& id, const std::string& outcome) {
  if (tty_) std::fprintf(stderr, "\r\033[K");
  std::fprintf(stderr, "[cell %zu/%zu] %s: %s\n", cell + 1, cells_, id.c_str(), outcome.c_str());
  last_line_ = Clock::now();
}

namespace {

std::filesystem::path log_file(const std::filesystem::path& run_dir, const Cell& cell) {
  return run_dir / "logs" / (cell.id + ".log");
}

// Forks and execs `photonbench __cell RUN_DIR CELL` with its stdout on the pipe and its stderr in
// the cell's log. Returns the child's pid.
pid_t spawn_cell(const std::filesystem::path& run_dir, const Cell& cell,
                 const CellProcessOptions& options, int pipe_fds[2]) {
  std::filesystem::create_directories(run_dir / "logs");
  const std::string log = log_file(run_dir, cell).string();
  std::vector<std::string> args = {"photonbench", "__cell", run_dir.string(), cell.id};
  if (!options.device.empty()) args.insert(args.end(), {"--device", options.device});
  if (options.validation) args.push_back("--validation");

  pid_t pid = fork();
  if (pid < 0) throw Error(fmt::format("fork failed: {}", std::strerror(errno)));
  if (pid == 0) {
    // The cell dies with the run: a killed `photonbench run` leaves no orphaned cell behind.
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    dup2(pipe_fds[1], STDOUT_FILENO);
    int log_fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (log_fd >= 0) dup2(log_fd, STDERR_FILENO);
    close(pipe_fds[0]);
    close(pipe_fds[1]);
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv("/proc/self/exe", argv.data());
    _exit(127);
  }
  return pid;
}

}  // namespace

ChildOutcome run_cell_process(const std::filesystem::path& run_dir, const Cell& cell,
                              const CellProcessOptions& options, Progress& progress, size_t index) {
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) throw Error(fmt::format("pipe failed: {}", std::strerror(errno)));
  const pid_t pid = spawn_cell(run_dir, cell, options, pipe_fds);
  close(pipe_fds[1]);
  ChildOutcome outcome;
  const auto start = Clock::now();
  std::string buffer;
  for (bool open_pipe = true; open_pipe;) {
    pollfd fd{pipe_fds[0], POLLIN, 0};
    const int ready = poll(&fd, 1, 200);
    const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
    if (ready > 0) {
      char chunk[4096];
      const ssize_t n = read(pipe_fds[0], chunk, sizeof chunk);
      open_pipe = n > 0;
      if (open_pipe) buffer.append(chunk, size_t(n));
      // The child prints "@frame <done> <total>" after each frame.
      for (size_t eol; (eol = buffer.find('\n')) != std::string::npos; buffer.erase(0, eol + 1)) {
        uint32_t done = 0, total = 0;
        char stage[32];
        if (std::sscanf(buffer.c_str(), "@stage %31s", stage) == 1) outcome.stage = stage;
        if (std::sscanf(buffer.c_str(), "@frame %u %u", &done, &total) == 2) {
          outcome.frames_done = done;
          progress.update(index, cell.id, done, total, elapsed);
        }
      }
    }
    if (elapsed > options.limit_s) {
      kill(pid, SIGKILL);
      outcome.timed_out = true;
      break;
    }
    if (options.stop && options.stop()) {
      kill(pid, SIGKILL);
      outcome.stopped = true;
      break;
    }
  }
  close(pipe_fds[0]);
  while (waitpid(pid, &outcome.exit_status, 0) < 0 && errno == EINTR) {
  }
  return outcome;
}

bool wrote_record(const std::filesystem::path& run_dir, const Cell& cell,
                  const ChildOutcome& outcome) {
  return std::filesystem::exists(cell_dir(run_dir, cell.id) / "cell.json") && !outcome.timed_out &&
         WIFEXITED(outcome.exit_status) && WEXITSTATUS(outcome.exit_status) == 0;
}

void record_abnormal_end(const std::filesystem::path& run_dir, const Cell& cell,
                         const ChildOutcome& outcome, double limit_s) {
  const std::filesystem::path partial = partial_cell_dir(run_dir, cell.id);
  const std::filesystem::path dir = cell_dir(run_dir, cell.id);
  std::filesystem::remove_all(dir);
  if (std::filesystem::exists(partial))
    std::filesystem::rename(partial, dir);
  else
    std::filesystem::create_directories(dir);
  // frames_done counts frames finished; the one that failed is the next (index frames_done), or
  // set-up.
  std::optional<int64_t> failed_frame;
  if (outcome.frames_done > 0 || outcome.timed_out) failed_frame = outcome.frames_done;
  // After the last frame the child names its stage: scoring, then teardown (the technique's and
  // the device's destructors).
  const std::string where = !outcome.stage.empty()
                                ? fmt::format("during {}, after its last frame", outcome.stage)
                            : failed_frame ? fmt::format("at frame {}", outcome.frames_done)
                                           : "during set-up";
  if (!outcome.stage.empty()) failed_frame.reset();
  std::string reason;
  if (outcome.timed_out) {
    reason = fmt::format("exceeded limits.cell_seconds = {} s {}", limit_s, where);
  } else if (WIFSIGNALED(outcome.exit_status)) {
    const int sig = WTERMSIG(outcome.exit_status);
    reason = fmt::format("crashed with signal {} ({}) {}", sig, strsignal(sig), where);
  } else {
    reason = fmt::format("exited with status {} {}", WEXITSTATUS(outcome.exit_status), where);
  }
  CellRecord record(cell);
  record.fail({reason, failed_frame});
  record.log_tail = "";
  if (std::filesystem::exists(log_file(run_dir, cell))) {
    const std::string text = io::read_text(log_file(run_dir, cell));
    record.log_tail = text.size() > 2000 ? text.substr(text.size() - 2000) : text;
  }
  write_cell_record(dir, record);
}

}  // namespace pb::run
