// `photonbench report | compare | history | export | claims | video`: the results tools. They
// are Python (matplotlib is the field's plotting standard, and scipy has the statistics), so each
// sub-command only replaces this process with `/usr/bin/python3 <tools>/pbtool.py <command>
// ARGS...`: Python parses the arguments (including --help), and its exit status is photonbench's
// (0 ok, 1 regression/failed work, 2 bad input).
//
// Debian's interpreter is named explicitly, not the first python3 on PATH, because the tools need
// Debian's python3-matplotlib/-numpy/-scipy (scripts/setup.sh), which another interpreter may lack.
// Tools dir: $PHOTONBENCH_TOOLS_DIR when set (an installed package), else the source tree's tools/.
#include <fmt/format.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "cli/command.h"
#include "photonbench/error.h"

namespace {

std::string env_or(const char* name, const std::string& fallback) {
  const char* value = std::getenv(name);
  return value && *value ? std::string(value) : fallback;
}

[[noreturn]] void exec_tool(const std::string& command, const std::vector<std::string>& args) {
  const std::filesystem::path tools = env_or("PHOTONBENCH_TOOLS_DIR", PB_SOURCE_DIR "/tools");
  const std::filesystem::path script = tools / "pbtool.py";
  const std::string python = env_or("PHOTONBENCH_PYTHON", "/usr/bin/python3");
  if (!std::filesystem::is_regular_file(script))
    throw pb::Error(
        fmt::format("photonbench {}: the Python tools are not at {} (set PHOTONBENCH_TOOLS_DIR "
                    "to the folder holding pbtool.py)",
                    command, script.string()));
  std::vector<std::string> argv_text{python, script.string(), command};
  argv_text.insert(argv_text.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_text) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::fflush(stdout);
  std::fflush(stderr);
  execv(python.c_str(), argv.data());
  // Only reached when exec failed.
  throw pb::Error(
      fmt::format("photonbench {}: cannot run {}: {} (install python3 with scripts/setup.sh, "
                  "or set PHOTONBENCH_PYTHON)",
                  command, python, std::strerror(errno)));
}

// Registers a sub-command whose arguments, all of them, go to the Python tool.
void add_tool(CLI::App& app, const char* name, const char* description) {
  auto* cmd = app.add_subcommand(name, description);
  cmd->set_help_flag();   // no CLI11 --help here: argparse's help documents every option
  cmd->prefix_command();  // everything after the sub-command's name is passed through, unparsed
  cmd->allow_extras();
  std::string command = name;
  cmd->callback([cmd, command] { exec_tool(command, cmd->remaining()); });
}

void add_report(CLI::App& app, int&) {
  add_tool(
      app, "report",
      "RUN_DIR [--crop x,y,w,h] ...: write RUN_DIR/report/index.html, figures (SVG, PDF, PNG) and "
      "tables (CSV, LaTeX); --help for options");
}
void add_compare(CLI::App& app, int&) {
  add_tool(
      app, "compare",
      "BASE_RUN NEW_RUN [--threshold PCT]: per cell and pass, median change with a Mann-Whitney U "
      "test; markdown table; exit 1 on a significant regression");
}
void add_history(CLI::App& app, int&) {
  add_tool(
      app, "history",
      "append RUN_DIR [RUN_DIR...] [--file F] [--label L] | plot [--file F] [--out DIR]: "
      "performance history by label (default: commit and plugin builds) and device (several runs: "
      "replicates, one entry), trend plots with noise bands and change points");
}
void add_export(CLI::App& app, int&) {
  add_tool(
      app, "export",
      "RUN_DIR --format github-action-benchmark: medians and metric means as that tool's JSON");
}

void add_video(CLI::App& app, int&) {
  add_tool(app, "video",
           "RUN_DIR: encode the frames a run's `video:` block saved (ffmpeg): per scene a WebM per "
           "cell, one side by side, the metric frames beside reference and FLIP map, an animated "
           "PNG of the crop");
}

void add_scaling(CLI::App& app, int&) {
  add_tool(app, "scaling",
           "RUN_DIR [RUN_DIR...] [--out DIR]: each pass's time against its work (a swept numeric "
           "parameter, or the pixels of runs differing in resolution) on log-log axes, fitted "
           "slopes with 95% intervals, and the harness's own share of each cell");
}

void add_claims(CLI::App& app, int&) {
  add_tool(
      app, "claims",
      "RUN_DIR [--paper paper1]: a paper's headline claims (speed ratios, rejection rates, memory "
      "per structure, quality table) measured on a run of its config, beside the paper's numbers");
}

pb::cli::CommandRegistration report_registration{"report", add_report};
pb::cli::CommandRegistration compare_registration{"compare", add_compare};
pb::cli::CommandRegistration history_registration{"history", add_history};
pb::cli::CommandRegistration export_registration{"export", add_export};
pb::cli::CommandRegistration claims_registration{"claims", add_claims};
pb::cli::CommandRegistration video_registration{"video", add_video};
pb::cli::CommandRegistration scaling_registration{"scaling", add_scaling};

}  // namespace
