// Sub-commands. Each lives in its own file and registers itself with one static
// CommandRegistration, so adding a command touches no other file:
//
//   static void add_validate(CLI::App& app, int& exit_code) {
//     auto* cmd = app.add_subcommand(...); ...
//   }
//   static pb::cli::CommandRegistration registration{"validate", add_validate};
//
// A command sets `exit_code` (0 ok, 1 failed work, 2 bad input) or throws: main turns
// pb::InputError into exit 2 and any other exception into exit 1, printing the message.
#pragma once

#include <CLI/CLI.hpp>

namespace pb::cli {

using AddCommand = void (*)(CLI::App& app, int& exit_code);

struct CommandRegistration {
  CommandRegistration(const char* name, AddCommand add);
};

}  // namespace pb::cli
