// photonbench: the command-line entry. Sub-commands register themselves (see command.h); this file
// only parses, dispatches and maps errors to exit codes: 0 success, 1 some work failed, 2 bad
// input.
#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <new>
#include <string>
#include <vector>

#include "cli/command.h"
#include "photonbench/error.h"

namespace pb::cli {
namespace {
std::vector<std::pair<std::string, AddCommand>>& registry() {
  static std::vector<std::pair<std::string, AddCommand>> commands;
  return commands;
}
}  // namespace

CommandRegistration::CommandRegistration(const char* name, AddCommand add) {
  registry().emplace_back(name, add);
}

}  // namespace pb::cli

int main(int argc, char** argv) {
  CLI::App app{"photonbench: benchmark and evaluate real-time photon-based global illumination"};
  app.set_version_flag("--version", PB_VERSION);
  app.require_subcommand(1);
  int exit_code = 0;
  auto commands = pb::cli::registry();
  std::sort(commands.begin(), commands.end());
  for (auto& [name, add] : commands) add(app, exit_code);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    int code = app.exit(e);
    return code == 0 ? 0 : 2;
  } catch (const pb::InputError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const std::bad_alloc&) {
    // Input is bounded where it is read (file sizes, node counts, sweeps, scene triangles), so
    // this is the machine running out: say so rather than print "std::bad_alloc".
    std::fprintf(stderr, "error: out of memory\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return exit_code;
}
