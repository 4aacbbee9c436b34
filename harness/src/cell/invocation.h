// How a run was started (config file and --set overrides), kept in the run folder so that each
// cell's child process and a later --resume rebuild exactly the same config.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace pb::run {

struct Invocation {
  std::filesystem::path config_file;  // absolute
  std::vector<std::string> overrides;
  std::string config_hash;
};

void write_invocation(const std::filesystem::path& run_dir, const Invocation& invocation);
Invocation read_invocation(const std::filesystem::path& run_dir);

}  // namespace pb::run
