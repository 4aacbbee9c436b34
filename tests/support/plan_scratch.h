// A benchmark config written into a scratch folder and planned (plan/plan.h) with the build's
// plugins: for tests of what a plan makes of a config.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "photonbench/error.h"
#include "plan/plan.h"

namespace pb::testing {

class PlanScratch {
 public:
  explicit PlanScratch(const std::string& suite)
      : dir_(std::filesystem::temp_directory_path() /
             ("pb_" + suite + "_" + std::to_string(::getpid()))) {
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  ~PlanScratch() { std::filesystem::remove_all(dir_); }
  PlanScratch(const PlanScratch&) = delete;
  PlanScratch& operator=(const PlanScratch&) = delete;

  run::RunPlan plan(const std::string& yaml, const std::vector<std::string>& overrides = {}) const {
    std::ofstream(dir_ / "config.yaml") << yaml << "plugin_dirs: [" PB_BINARY_DIR "/plugins]\n";
    return run::plan_run(dir_ / "config.yaml", overrides);
  }

  // The message of the InputError planning `yaml` throws (a refusal), or "" when it plans.
  std::string refusal(const std::string& yaml) const {
    try {
      plan(yaml);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }

 private:
  std::filesystem::path dir_;
};

}  // namespace pb::testing
