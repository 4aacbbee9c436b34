#include "plan/plan.h"

#include <fmt/format.h>

#include <algorithm>
#include <optional>
#include <set>
#include <sstream>
#include <unordered_set>

#include "photonbench/error.h"
#include "scene/scene.h"

namespace pb::run {

namespace {

using ParamMap = std::map<std::string, std::string>;

// Checks one value against its spec and returns its canonical text.
std::string check_param(const pb_param_spec& spec, const config::YamlView& value) {
  switch (spec.type) {
    case PB_PARAM_INT:
      return fmt::format("{}", value.as_int(int64_t(spec.min_value), int64_t(spec.max_value)));
    case PB_PARAM_FLOAT:
      return fmt::format("{}", value.as_number(spec.min_value, spec.max_value));
    case PB_PARAM_BOOL:
      return value.as_bool() ? "true" : "false";
    case PB_PARAM_ENUM: {
      std::string text = value.as_string();
      std::vector<std::string> choices;
      std::istringstream stream(spec.choices ? spec.choices : "");
      for (std::string c; std::getline(stream, c, '|');) choices.push_back(c);
      for (const auto& c : choices)
        if (c == text) return text;
      std::string hint = config::closest_name(text, choices);
      value.fail(fmt::format("'{}' is not one of: {}{}", config::quote(text),
                             fmt::join(choices, ", "),
                             hint.empty() ? "" : fmt::format("; did you mean '{}'?", hint)));
    }
  }
  value.fail("unknown parameter type");
}

const pb_param_spec* find_spec(const pb_technique_descriptor& d, const std::string& name) {
  for (uint32_t i = 0; i < d.param_count; ++i)
    if (name == d.params[i].name) return &d.params[i];
  return nullptr;
}

// Every combination times every value of one swept key (a scalar is a one-value list), each value
// checked once. A scene's value may make combinations equal; expand_cells keeps one cell of each.
std::vector<ParamMap> sweep(const std::vector<ParamMap>& combos, const std::string& key,
                            const pb_param_spec& spec, const config::YamlView& value) {
  std::vector<config::YamlView> values = value.elements();
  if (values.empty()) value.fail("expected a value or a non-empty list of values to sweep");
  if (combos.size() > kMaxCells / values.size())
    value.fail(fmt::format("this sweep makes {} x {} = {} cells, more than the {} a run may have",
                           combos.size(), values.size(), double(combos.size()) * values.size(),
                           kMaxCells));
  std::vector<std::string> texts;
  for (const config::YamlView& v : values) texts.push_back(check_param(spec, v));
  std::vector<ParamMap> expanded;
  expanded.reserve(combos.size() * texts.size());
  for (const auto& combo : combos)
    for (const std::string& text : texts) {
      ParamMap next = combo;
      next[key] = text;
      expanded.push_back(std::move(next));
    }
  return expanded;
}

// The parameter maps one technique entry's sweeps expand to, every schema parameter filled in.
std::vector<ParamMap> technique_combos(const config::TechniqueEntry& entry,
                                       PluginRegistry& plugins) {
  config::YamlView name_node = entry.node["technique"];
  const Plugin* plugin = plugins.find(entry.technique);
  if (!plugin) {
    auto names = plugins.names();
    std::string hint = config::closest_name(entry.technique, names);
    name_node.fail(fmt::format(
        "unknown technique '{}'{} (available: {}); a technique built elsewhere is found with "
        "--plugin-dir DIR or plugin_dirs: [DIR]",
        entry.technique, hint.empty() ? "" : fmt::format("; did you mean '{}'?", hint),
        fmt::join(names, ", ")));
  }
  if (!plugin->loaded()) return {{}};  // fails when it runs, with the loader's error
  const pb_technique_descriptor& d = *plugin->descriptor;
  std::vector<std::string> names;
  ParamMap defaults;
  for (uint32_t i = 0; i < d.param_count; ++i) {
    names.push_back(d.params[i].name);
    defaults[d.params[i].name] = param_default_text(d.params[i]);
  }
  std::vector<ParamMap> combos = {defaults};
  std::optional<config::YamlView> params = entry.node.get("params");
  if (!params) return combos;
  params->allow_keys(names);
  for (const auto& [key, value] : params->entries())
    combos = sweep(combos, key, *find_spec(d, key), value);
  return combos;
}

// A value as the config (or --set) wrote it: "20000", "[5000, 20000]".
std::string value_text(const config::YamlView& value) {
  std::vector<std::string> texts;
  for (const config::YamlView& v : value.elements())
    texts.push_back(v.is_scalar() ? v.as_string() : "...");
  return value.is_sequence() ? fmt::format("[{}]", fmt::join(texts, ", ")) : texts.front();
}

// A scene's value replacing one the technique entry sets (in the file or by --set) would pass
// unseen: a warning naming both keys. Where every scene a technique entry runs on replaces its
// sweep by fewer values, the sweep makes no cell anywhere: an error at the first scene's key (a
// sweep some scene keeps is the config's pattern of a per-scene exception, warned about only).
class ShadowCheck {
 public:
  explicit ShadowCheck(std::vector<std::string>* warnings) : warnings_(warnings) {}

  void scene_ran(size_t technique) { ++scenes_[technique]; }

  void check(const config::YamlView& scene_value, const config::TechniqueEntry& entry,
             size_t technique, const std::string& key, const std::string& scene_name) {
    std::optional<config::YamlView> params = entry.node.get("params");
    std::optional<config::YamlView> own = params ? params->get(key) : std::nullopt;
    if (!own) return;
    const size_t own_values = own->elements().size(), scene_values = scene_value.elements().size();
    const std::string own_text = value_text(*own), scene_text = value_text(scene_value);
    if (own_values > 1 && scene_values < own_values) {
      Collapse& collapse = collapses_[{technique, key}];
      if (collapse.scenes++ == 0) {
        collapse.at = scene_value;
        collapse.message = fmt::format(
            "{} on scene '{}' replaces {} = {} ({}), collapsing that sweep of {} values to {} on "
            "every scene '{}' runs on: set '{}' in one of the two places",
            scene_text, scene_name, own->key_path(), own_text, own->location(), own_values,
            scene_values, entry.technique, key);
      }
    }
    if (warnings_ && own_text != scene_text)
      warnings_->push_back(
          fmt::format("{}: {} = {} replaces {} = {} ({}) for technique '{}' on scene '{}'",
                      scene_value.location(), scene_value.key_path(), scene_text, own->key_path(),
                      own_text, own->location(), entry.technique, scene_name));
  }

  // After every scene: a sweep no scene kept is an error.
  void finish() const {
    for (const auto& [where, collapse] : collapses_)
      if (collapse.scenes == scenes_.at(where.first)) collapse.at->fail(collapse.message);
  }

 private:
  struct Collapse {
    size_t scenes = 0;
    std::optional<config::YamlView> at;
    std::string message;
  };
  std::vector<std::string>* warnings_;
  std::map<size_t, size_t> scenes_;  // per technique entry, the scenes it runs on
  std::map<std::pair<size_t, std::string>, Collapse> collapses_;
};

// A scene entry's `params` replace (and, given a list, sweep) the parameters of the same name of
// every technique that has them; a name no technique of the config has is an error at its key.
std::vector<ParamMap> with_scene_params(const config::SceneEntry& scene,
                                        const config::Config& config, size_t technique,
                                        const std::vector<ParamMap>& combos,
                                        PluginRegistry& plugins, ShadowCheck& shadows) {
  std::optional<config::YamlView> overrides =
      scene.node.is_map() ? scene.node.get("params") : std::nullopt;
  if (!overrides) return combos;
  std::vector<std::string> known;
  for (const auto& entry : config.techniques)
    if (const Plugin* plugin = plugins.find(entry.technique); plugin && plugin->loaded())
      for (uint32_t i = 0; i < plugin->descriptor->param_count; ++i)
        if (std::find(known.begin(), known.end(), plugin->descriptor->params[i].name) ==
            known.end())
          known.push_back(plugin->descriptor->params[i].name);
  overrides->allow_keys(known);
  const Plugin* plugin = plugins.find(config.techniques[technique].technique);
  if (!plugin || !plugin->loaded()) return combos;
  std::vector<ParamMap> result = combos;
  for (const auto& [key, value] : overrides->entries())
    if (const pb_param_spec* spec = find_spec(*plugin->descriptor, key)) {
      shadows.check(value, config.techniques[technique], technique, key, scene.scene);
      result = sweep(result, key, *spec, value);
    }  // else another technique's parameter
  return result;
}

// Where a parameter of one cell is set: the scene entry's params, else the technique entry's, else
// (its default) nowhere.
std::optional<config::YamlView> param_node(const config::SceneEntry& scene,
                                           const config::TechniqueEntry& entry,
                                           const std::string& key) {
  if (scene.node.is_map())
    if (auto params = scene.node.get("params"))
      if (auto value = params->get(key)) return value;
  if (auto params = entry.node.get("params"))
    if (auto value = params->get(key)) return value;
  return std::nullopt;
}

// The descriptor's cross-parameter check of one cell's values, before any work: its error is bad
// input at the key it names (pb_technique_descriptor::check), with the technique's name.
void check_together(const pb_technique_descriptor& d, const config::SceneEntry& scene,
                    const config::TechniqueEntry& entry, const ParamMap& params) {
  if (!d.check) return;
  std::vector<pb_param_value> values;
  values.reserve(params.size());
  for (const auto& [name, value] : params) values.push_back({name.c_str(), value.c_str()});
  const char* error = d.check(values.data(), uint32_t(values.size()));
  if (!error || !*error) return;
  const std::string message = error;
  const size_t colon = message.find(": ");
  if (colon != std::string::npos)
    if (auto node = param_node(scene, entry, message.substr(0, colon)))
      node->fail(fmt::format("{} ({})", message.substr(colon + 2), d.name));
  // The key keeps its default (or the message names none): at the technique entry, key and all.
  entry.node["technique"].fail(fmt::format("{} ({})", message, d.name));
}

// Each cell `config.seeds` times, seed index i with seed config.seed + i, next to each other (a
// shard or an interrupted run then holds whole seed groups as far as it can); with `seed_order:
// rounds`, seed index i of every cell in round i, forward in even rounds and backward in odd ones,
// so that a drift in the machine's load over the run weighs on every cell alike.
std::vector<Cell> with_seed_axis(std::vector<Cell> cells, const config::Config& config) {
  for (Cell& cell : cells) {
    cell.seed = config.seed;
    cell.seed_group = cell.id;
  }
  if (config.seeds <= 1) return cells;
  if (cells.size() > kMaxCells / config.seeds)
    throw InputError(fmt::format(
        "{}: seeds: {} x {} cells = {} cells, more than the {} a run may have",
        config.file.string(), config.seeds, cells.size(), cells.size() * config.seeds, kMaxCells));
  std::vector<Cell> seeded;
  seeded.reserve(cells.size() * config.seeds);
  auto add = [&](const Cell& cell, uint32_t i) {
    Cell copy = cell;
    copy.seed_index = i;
    copy.seed = config.seed + i;
    copy.id = fmt::format("{}__seed{}", cell.id, copy.seed);
    seeded.push_back(std::move(copy));
  };
  if (config.seed_rounds) {
    for (uint32_t i = 0; i < config.seeds; ++i)
      for (size_t c = 0; c < cells.size(); ++c) add(cells[i % 2 ? cells.size() - 1 - c : c], i);
  } else {
    for (const Cell& cell : cells)
      for (uint32_t i = 0; i < config.seeds; ++i) add(cell, i);
  }
  return seeded;
}

}  // namespace

Cell make_cell(const std::filesystem::path& scene_file, const std::string& technique,
               const ParamMap& params) {
  Cell cell;
  cell.scene = scene_file.stem().string();
  cell.scene_file = scene_file;
  cell.technique = technique;
  cell.params = params;
  std::string key;
  for (const auto& [k, v] : params) key += k + "=" + v + ";";
  cell.id = fmt::format("{}__{}__{}", cell.scene, technique, config::stable_hash(key).substr(0, 8));
  return cell;
}

const Cell* RunPlan::find(const std::string& id) const {
  auto it = std::find_if(cells.begin(), cells.end(), [&](const Cell& c) { return c.id == id; });
  return it == cells.end() ? nullptr : &*it;
}

const Cell& RunPlan::cell(const std::string& id) const {
  if (const Cell* found = find(id)) return *found;
  throw InputError(fmt::format("no cell '{}' in {}", id, config.file.string()));
}

RunPlan plan_run(const std::filesystem::path& config_file,
                 const std::vector<std::string>& overrides) {
  RunPlan plan;
  plan.config = config::load_config(config_file, overrides);
  plan.plugins = std::make_unique<PluginRegistry>(plan.config.plugin_dirs);
  plan.cells = expand_cells(plan.config, *plan.plugins, &plan.warnings);
  return plan;
}

std::vector<Cell> expand_cells(const config::Config& config, PluginRegistry& plugins,
                               std::vector<std::string>* warnings) {
  std::vector<std::filesystem::path> scene_files;
  std::set<std::filesystem::path> checked;
  for (const config::SceneEntry& scene : config.scenes) {
    try {
      scene_files.push_back(scene::find_scene(scene.scene, config.scene_dirs));
      if (checked.insert(scene_files.back()).second)
        scene::check_frames(scene::load_scene(scene_files.back()), config.frames.first_frame(),
                            config.frames.last_frame());
    } catch (const InputError& e) {
      scene.name_node.fail(e.what());
    }
  }
  // Entries of one scene file share its references (the cache holds one per scene and frame), so
  // they must not ask for different stop rules.
  for (size_t s = 0; s < config.scenes.size(); ++s)
    for (size_t o = 0; o < s; ++o)
      if (scene_files[o] == scene_files[s] &&
          config.scenes[o].reference != config.scenes[s].reference)
        config.scenes[s].node.fail(fmt::format(
            "scene '{}' is listed again with other reference stop rules; its references are "
            "rendered once, so its entries must agree",
            config.scenes[s].scene));
  std::vector<std::vector<ParamMap>> combos;  // per technique entry
  for (const config::TechniqueEntry& entry : config.techniques)
    combos.push_back(technique_combos(entry, plugins));

  std::vector<Cell> cells;
  std::unordered_set<std::string> ids;
  ShadowCheck shadows(warnings);
  for (size_t s = 0; s < config.scenes.size(); ++s)
    for (size_t t = 0; t < config.techniques.size(); ++t) {
      const std::vector<std::string>& only = config.techniques[t].scenes;
      if (!only.empty() &&
          std::find(only.begin(), only.end(), config.scenes[s].scene) == only.end())
        continue;
      shadows.scene_ran(t);
      std::vector<ParamMap> scene_combos =
          with_scene_params(config.scenes[s], config, t, combos[t], plugins, shadows);
      if (cells.size() + scene_combos.size() > kMaxCells)
        config.scenes[s].node.fail(fmt::format(
            "with technique '{}' the config expands to {} cells or more, more than the {} a run "
            "may have",
            config.techniques[t].technique, cells.size() + scene_combos.size(), kMaxCells));
      const Plugin* plugin = plugins.find(config.techniques[t].technique);
      for (const ParamMap& params : scene_combos) {
        if (plugin && plugin->loaded())
          check_together(*plugin->descriptor, config.scenes[s], config.techniques[t], params);
        Cell cell = make_cell(scene_files[s], config.techniques[t].technique, params);
        cell.entry = t;
        cell.scene_entry = s;
        // Equal values (a scene's override of a swept parameter) make one cell.
        if (ids.insert(cell.id).second) cells.push_back(std::move(cell));
      }
    }
  shadows.finish();
  return with_seed_axis(std::move(cells), config);
}

}  // namespace pb::run
