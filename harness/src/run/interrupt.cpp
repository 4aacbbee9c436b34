#include "run/interrupt.h"

#include <signal.h>
#include <unistd.h>

#include <cstring>

namespace pb::run {

namespace {

volatile sig_atomic_t g_signal = 0;
volatile sig_atomic_t g_clean_stop = 0;
// Filled before the handlers are installed; the handler reads them with async-signal-safe calls
// only (write, unlink, raise).
std::string g_lock_file;
std::string g_message;
struct sigaction g_previous_int, g_previous_term;

void on_signal(int sig) {
  if (g_signal == 0) g_signal = sig;
  if (g_clean_stop) return;  // the cell loop sees the flag (a poll it interrupts returns early)
  (void)!write(STDERR_FILENO, g_message.data(), g_message.size());
  unlink(g_lock_file.c_str());
  signal(sig, SIG_DFL);
  raise(sig);
}

}  // namespace

InterruptGuard::InterruptGuard(const std::filesystem::path& lock_file,
                               const std::string& resume_command) {
  g_signal = 0;
  g_clean_stop = 0;
  g_lock_file = lock_file.string();
  g_message =
      "\nphotonbench: interrupted before the first cell; resume with:\n  " + resume_command + "\n";
  struct sigaction action {};
  action.sa_handler = on_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = 0;  // no SA_RESTART: a poll or wait the signal interrupts returns
  sigaction(SIGINT, &action, &g_previous_int);
  sigaction(SIGTERM, &action, &g_previous_term);
}

InterruptGuard::~InterruptGuard() {
  sigaction(SIGINT, &g_previous_int, nullptr);
  sigaction(SIGTERM, &g_previous_term, nullptr);
  g_clean_stop = 0;
}

void InterruptGuard::stop_cleanly_from_now() { g_clean_stop = 1; }

int interrupt_signal() { return g_signal; }

bool interrupted() { return g_signal != 0; }

namespace {

// `text` as one shell word: unchanged when it holds only characters no shell reads specially.
std::string shell_word(const std::string& text) {
  if (!text.empty() && text.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz"
                                              "0123456789_/.,:=+-@%") == std::string::npos)
    return text;
  std::string quoted = "'";
  for (char c : text) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

}  // namespace

std::string resume_command(const std::filesystem::path& run_dir, const std::string& device,
                           bool validation, const std::string& shard) {
  std::error_code ec;
  std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  std::string command = shell_word(ec ? std::string("photonbench") : self.string()) +
                        " run --resume --out " + shell_word(run_dir.string());
  if (!device.empty()) command += " --device " + shell_word(device);
  if (validation) command += " --validation";
  if (!shard.empty()) command += " --shard " + shell_word(shard);
  return command;
}

}  // namespace pb::run
