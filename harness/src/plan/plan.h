// A run's plan: the config (parsed and checked by config/), the technique plugins it names, and the
// cells its sweeps expand to (scene x technique x one value of every parameter), each parameter
// checked against its plugin's schema. `run`, every cell's child process, `validate` and
// `reference` make it the same way, in this one direction: config, then scenes and plugins, then
// cells.
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "config/config.h"
#include "plan/plugins.h"

namespace pb::run {

// A cell: one scene, one technique, one value of every parameter and, with `seeds: K` > 1, one
// seed of the seed axis.
struct Cell {
  // "<scene>__<technique>__<8 hex of the parameter values>", and "__seed<seed>" after it on a seed
  // axis: stable across runs
  std::string id;
  std::string scene;
  std::filesystem::path scene_file;
  std::string technique;
  std::map<std::string, std::string> params;  // every schema parameter, defaults filled in
  // config.seed + seed_index. Seed index 0 is the cell a run without a seed axis makes, so its
  // photons are the technique's own; any other index scrambles the photon tracer's sequence with
  // `seed` (World::photon_tracer), so the K cells are independent Monte Carlo runs.
  uint64_t seed = 1;
  uint32_t seed_index = 0;
  std::string seed_group;  // the id without the seed: the same for the K cells of one seed axis
  size_t entry = 0;        // the config's technique entry (config.techniques[entry]) it comes from
  size_t scene_entry = 0;  // the config's scene entry (config.scenes[scene_entry]): its references
};

// A run has at most this many cells: a sweep beyond it is a slip of the keyboard or of a script
// (it would take hours to plan and months to run), and is an error naming the key that crossed it.
inline constexpr size_t kMaxCells = 10000;

struct RunPlan {
  config::Config config;
  std::unique_ptr<PluginRegistry> plugins;
  std::vector<Cell> cells;
  // What the plan did that the config may not mean, one line each with file:line:col (a scene's
  // value replacing one its technique entry sets): `run` and `validate` print them.
  std::vector<std::string> warnings;

  // The cell named `id`; pb::InputError when the config expands to no such cell.
  const Cell& cell(const std::string& id) const;
  // The same, null when there is none (a match run's probes are not in the plan: extra_cells.h).
  const Cell* find(const std::string& id) const;
};

// The cell of `scene_file`, `technique` and `params` (every schema parameter), with the id the plan
// gives it ("<scene>__<technique>__<8 hex of the values>"), seed index 0, no seed suffix.
Cell make_cell(const std::filesystem::path& scene_file, const std::string& technique,
               const std::map<std::string, std::string>& params);

// Loads the config with its --set overrides, opens its plugin folders and expands its cells.
// Throws pb::InputError (file:line:col: key) for anything expand_cells or load_config rejects.
RunPlan plan_run(const std::filesystem::path& config_file,
                 const std::vector<std::string>& overrides);

// Resolves each scene name, loads the scene (every error in it is bad input, at the config's scene
// entry) and checks its camera and lights at every frame the run plays, then expands the sweeps,
// checking each technique and parameter against its plugin's schema, and each cell's values
// together against the descriptor's check. Throws pb::InputError for a scene that is not found or
// does not load, an unknown technique, a plugin built for another API version, an unknown
// parameter, a value of the wrong type or range, values the technique's check refuses (at the key
// it names), or more than kMaxCells cells (seeds included: each cell is repeated `seeds` times, its
// seed indices in order).
// A plugin that exists but fails to load is not an input error: its cells are returned with an
// empty parameter map, to fail when they run.
// A scene's params replacing a value its technique entry sets is a line in `warnings` (when given),
// and an InputError at the scene's key where every scene the entry runs on would collapse its
// sweep to fewer values.
std::vector<Cell> expand_cells(const config::Config& config, PluginRegistry& plugins,
                               std::vector<std::string>* warnings = nullptr);

}  // namespace pb::run
