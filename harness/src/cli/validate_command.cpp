// `photonbench validate CONFIG`: everything `run` checks before running (the scenes loaded, their
// cameras and lights checked at every frame), and the cells it would run. Given a scene file, it
// checks the scene. Exit 0: valid; 1: valid,
// but some cells will fail (their plugin does not load); 2: bad input.
#include <yaml-cpp/yaml.h>

#include <cstdio>
#include <filesystem>

#include "cli/command.h"
#include "plan/match_plan.h"
#include "plan/plan.h"
#include "run/runner.h"
#include "scene/scene.h"

namespace {

// A scene file given where a config belongs: a YAML mapping without `techniques` but with a camera
// or objects. It is checked as a scene, not reported as a config of unknown keys.
bool looks_like_scene(const std::filesystem::path& file) {
  if (pb::run::is_benchmark_config(file)) return false;
  try {
    const YAML::Node root = YAML::LoadFile(file.string());
    return root.IsMap() && (root["camera"].IsDefined() || root["objects"].IsDefined());
  } catch (const YAML::Exception&) {
    return false;
  }
}

void add_validate(CLI::App& app, int& exit_code) {
  struct Args {
    std::string config;
    std::vector<std::string> overrides;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("validate", "check a config and list the cells it expands to");
  cmd->add_option("config", args->config, "the YAML config")->required()->check(CLI::ExistingFile);
  cmd->add_option("--set", args->overrides,
                  "override a config key: key.path=value, or key+=value to append (repeatable)");
  auto plugin_dirs = std::make_shared<std::vector<std::string>>();
  cmd->add_option("--plugin-dir", *plugin_dirs,
                  "also load technique plugins from this folder (repeatable)")
      ->check(CLI::ExistingDirectory);
  cmd->callback([args, plugin_dirs, &exit_code] {
    if (looks_like_scene(args->config)) {
      const pb::scene::Scene scene = pb::scene::load_scene(args->config);
      std::printf(
          "%s: a valid scene ('%s'), not a benchmark config; a config runs it with scenes: [%s]\n",
          args->config.c_str(), scene.name.c_str(), args->config.c_str());
      exit_code = 0;
      return;
    }
    for (const auto& dir : *plugin_dirs)
      args->overrides.push_back("plugin_dirs+=" + std::filesystem::absolute(dir).string());
    const pb::run::RunPlan plan = pb::run::plan_run(args->config, args->overrides);
    const pb::run::MatchPlan matches = pb::run::plan_matches(plan);
    const auto& [config, plugins, cells, warnings] = plan;
    for (const std::string& warning : warnings)
      std::fprintf(stderr, "warning: %s\n", warning.c_str());
    std::printf("%s: valid, %zu cells (config hash %s)\n", args->config.c_str(), cells.size(),
                config.hash.c_str());
    // A match run's cells are its searches' probes: each match starts at its first probe.
    for (const pb::run::MatchTarget& m : matches.matches)
      if (!m.knob.empty())
        std::printf("  match %s %s: %s in [%s, %s], first probe %s\n", m.start.scene.c_str(),
                    m.start.technique.c_str(), m.knob.c_str(),
                    pb::run::knob_text(m.space, m.space.lo).c_str(),
                    pb::run::knob_text(m.space, m.space.hi).c_str(),
                    m.start.params.at(m.knob).c_str());
    for (const pb::run::Cell& cell : matches.unmatched)
      std::printf("  baseline (unmatched) %s\n", cell.id.c_str());
    size_t will_fail = 0;
    for (const auto& cell : cells) {
      std::printf("  %s", cell.id.c_str());
      for (const auto& [k, v] : cell.params) std::printf(" %s=%s", k.c_str(), v.c_str());
      const pb::run::Plugin* plugin = plugins->find(cell.technique);
      if (plugin && !plugin->loaded()) {
        std::printf("  [will fail: %s]", plugin->load_error.c_str());
        ++will_fail;
      }
      std::printf("\n");
    }
    // A plugin that does not load is not bad input (its cells fail alone, exit 1 from `run`), but
    // a config that would fail is not one to start: validate says so with run's exit code.
    if (will_fail)
      std::fprintf(stderr, "%s: %zu of %zu cells will fail (their plugins do not load)\n",
                   args->config.c_str(), will_fail, cells.size());
    exit_code = will_fail ? 1 : 0;
  });
}

pb::cli::CommandRegistration validate_registration{"validate", add_validate};

}  // namespace
