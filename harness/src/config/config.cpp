#include "config/config.h"

#include <fmt/format.h>

#include <sstream>

#include "photonbench/error.h"
#include "run/plugins.h"
#include "scene/scene.h"

namespace pb::config {

namespace {

// Applies one "key.path=value" override. Numeric path parts index lists; missing mapping keys are created
// so any key can be set, and validation afterwards treats the result as if it had been written in the file.
void apply_override(YAML::Node& root, const std::string& assignment) {
  auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw InputError(fmt::format("--set {}: expected key.path=value", assignment));
  std::string path = assignment.substr(0, eq);
  // "key+=value" appends to a list (created if absent): --plugin-dir is plugin_dirs+=DIR.
  bool append = !path.empty() && path.back() == '+';
  if (append) path.pop_back();
  YAML::Node value;
  try {
    value = YAML::Load(assignment.substr(eq + 1));
  } catch (const YAML::Exception& e) {
    throw InputError(fmt::format("--set {}: the value is not valid YAML: {}", assignment, e.msg));
  }
  std::vector<std::string> parts;
  std::istringstream stream(path);
  for (std::string part; std::getline(stream, part, '.');) parts.push_back(part);
  YAML::Node node;
  node.reset(root);
  for (size_t i = 0; i < parts.size(); ++i) {
    const std::string& part = parts[i];
    bool is_index = !part.empty() && part.find_first_not_of("0123456789") == std::string::npos;
    bool last = i + 1 == parts.size();
    if (is_index && node.IsSequence()) {
      size_t index = std::stoul(part);
      if (index >= node.size())
        throw InputError(fmt::format("--set {}: '{}' has {} elements, no element {}", assignment,
                                     fmt::join(parts.begin(), parts.begin() + i, "."), node.size(), index));
      if (last) {
        node[index] = value;
      } else {
        YAML::Node child = node[index];
        node.reset(child);
      }
    } else {
      if (!node.IsMap() && !node.IsNull())
        throw InputError(fmt::format("--set {}: '{}' is not a mapping", assignment,
                                     fmt::join(parts.begin(), parts.begin() + i, ".")));
      if (last && append) {
        if (!node[part].IsDefined() || node[part].IsNull()) node[part] = YAML::Node(YAML::NodeType::Sequence);
        if (!node[part].IsSequence())
          throw InputError(fmt::format("--set {}: '{}' is not a list to append to", assignment, path));
        YAML::Node list = node[part];
        list.push_back(value);
      } else if (last) {
        node[part] = value;
      } else {
        if (!node[part].IsDefined() || node[part].IsNull()) node[part] = YAML::Node(YAML::NodeType::Map);
        YAML::Node child = node[part];
        node.reset(child);
      }
    }
  }
}

std::string format_number(double v) { return fmt::format("{}", v); }

}  // namespace

std::string stable_hash(const std::string& text) {
  uint64_t hash = 1469598103934665603ull;
  for (unsigned char c : text) {
    hash ^= c;
    hash *= 1099511628211ull;
  }
  return fmt::format("{:016x}", hash);
}

Config load_config(const std::filesystem::path& file, const std::vector<std::string>& overrides) {
  Config config;
  config.file = file;
  YamlView root = YamlView::load_file(file);
  YAML::Node tree = root.node();
  if (!tree.IsMap()) root.fail("a config is a mapping of keys (name, resolution, frames, scenes, techniques, ...)");
  for (const auto& assignment : overrides) apply_override(tree, assignment);
  root = YamlView(tree, std::make_shared<const std::string>(file.string()), "");

  root.allow_keys({"name", "resolution", "frames", "seed", "scenes", "techniques", "metrics", "reference",
                   "limits", "plugin_dirs", "testing"});
  config.name = root.string_or("name", file.stem().string());
  if (auto resolution = root.get("resolution")) {
    if (!resolution->is_sequence() || resolution->size() != 2) resolution->fail("expected [width, height]");
    config.width = uint32_t((*resolution)[size_t(0)].as_int(16, 8192));
    config.height = uint32_t((*resolution)[size_t(1)].as_int(16, 8192));
  }
  if (auto frames = root.get("frames")) {
    frames->allow_keys({"warmup", "count", "metrics_every"});
    config.frames.warmup = uint32_t(frames->int_or("warmup", config.frames.warmup, 0, 100000));
    config.frames.count = uint32_t(frames->int_or("count", config.frames.count, 1, 1000000));
    config.frames.metrics_every = uint32_t(frames->int_or("metrics_every", config.frames.metrics_every, 0, 1000000));
  }
  config.seed = uint64_t(root.int_or("seed", 1, 0, int64_t(1) << 53));

  YamlView scenes = root["scenes"];
  if (scenes.elements().empty()) scenes.fail("at least one scene is needed");
  std::vector<std::filesystem::path> search = {file.parent_path(), file.parent_path() / "scenes"};
  for (const YamlView& scene : scenes.elements()) {
    // A scene is a name, or {scene: NAME, params: {...}} whose parameters replace the techniques' own
    // for this scene's cells (photon radii are in scene units: Paper I's Table 2 sets them per scene).
    if (scene.is_map()) scene.allow_keys({"scene", "params"});
    // (Constructed, never assigned: assigning a YAML::Node rebinds the node inside the tree.)
    const YamlView name_node = scene.is_map() ? scene["scene"] : scene;
    std::string name = name_node.as_string();
    try {
      scene::find_scene(name, search);
    } catch (const InputError& e) {
      name_node.fail(e.what());
    }
    config.scenes.push_back({name, scene});
  }

  YamlView techniques = root["techniques"];
  if (!techniques.is_sequence() || techniques.size() == 0)
    techniques.fail("expected a list of {technique: NAME, params: {...}}");
  for (const YamlView& entry : techniques.elements()) {
    entry.allow_keys({"technique", "params"});
    config.techniques.push_back({entry["technique"].as_string(), entry});
  }

  config.metrics = {"flip", "ssim", "psnr"};
  if (auto metrics = root.get("metrics")) {
    config.metrics.clear();
    for (const YamlView& m : metrics->elements())
      config.metrics.push_back(m.as_enum({"flip", "ssim", "psnr", "rmse", "mae", "relmse"}));
  }
  config.reference.cache_dir = "results/reference-cache";
  if (auto reference = root.get("reference")) {
    reference->allow_keys(
        {"rel_error", "max_seconds", "samples", "max_bounces", "estimator", "cache_dir"});
    ReferenceSettings& r = config.reference;
    // Naming any stop rule replaces the default rules: {samples: 1024} means exactly 1024.
    if (reference->has("rel_error") || reference->has("max_seconds") || reference->has("samples"))
      r.rel_error = 0, r.max_seconds = 0, r.samples = 0;
    r.rel_error = reference->number_or("rel_error", r.rel_error, 0, 1);
    r.max_seconds = reference->number_or("max_seconds", r.max_seconds, 0, 1e7);
    r.samples = uint32_t(reference->int_or("samples", r.samples, 0, 1 << 24));
    if (r.samples == 1)  // one iteration has no variance and an empty odd half
      (*reference)["samples"].fail("0 (off) or at least 2 iterations");
    r.max_bounces = uint32_t(reference->int_or("max_bounces", r.max_bounces, 0, 64));
    if (auto e = reference->get("estimator")) r.estimator = e->as_enum({"auto", "bdpt", "pt"});
    if (!(r.rel_error > 0) && !(r.max_seconds > 0) && r.samples == 0)
      reference->fail("rel_error, max_seconds and samples are all 0: no rule would stop a reference");
    r.cache_dir = reference->string_or("cache_dir", r.cache_dir.string());
  }
  if (auto limits = root.get("limits")) {
    limits->allow_keys({"cell_seconds"});
    config.limits.cell_seconds = limits->number_or("cell_seconds", config.limits.cell_seconds, 0.1, 1e7);
  }
  if (auto dirs = root.get("plugin_dirs")) {
    for (const YamlView& d : dirs->elements()) {
      std::filesystem::path dir = d.as_string();
      if (dir.is_relative()) dir = file.parent_path() / dir;
      if (!std::filesystem::is_directory(dir)) d.fail(fmt::format("plugin directory {} does not exist", dir.string()));
      config.plugin_dirs.push_back(dir);
    }
  }
  if (auto testing = root.get("testing")) {
    testing->allow_keys({"slow_pass", "slow_factor"});
    config.testing.slow_pass = testing->string_or("slow_pass", "");
    config.testing.slow_factor = testing->number_or("slow_factor", 1.0, 1.0, 100.0);
  }

  config.resolved = tree;
  YAML::Emitter emitter;
  emitter << tree;
  config.canonical = emitter.c_str();
  config.hash = stable_hash(config.canonical);
  return config;
}

namespace {

// Checks one value against its spec and returns its canonical text.
std::string check_param(const pb_param_spec& spec, const YamlView& value) {
  switch (spec.type) {
    case PB_PARAM_INT:
      return fmt::format("{}", value.as_int(int64_t(spec.min_value), int64_t(spec.max_value)));
    case PB_PARAM_FLOAT:
      return format_number(value.as_number(spec.min_value, spec.max_value));
    case PB_PARAM_BOOL:
      return value.as_bool() ? "true" : "false";
    case PB_PARAM_ENUM: {
      std::string text = value.as_string();
      std::vector<std::string> choices;
      std::istringstream stream(spec.choices ? spec.choices : "");
      for (std::string c; std::getline(stream, c, '|');) choices.push_back(c);
      for (const auto& c : choices)
        if (c == text) return text;
      std::string hint = closest_name(text, choices);
      value.fail(fmt::format("'{}' is not one of: {}{}", text, fmt::join(choices, ", "),
                             hint.empty() ? "" : fmt::format("; did you mean '{}'?", hint)));
    }
  }
  value.fail("unknown parameter type");
}

// A scene entry's `params` replace (and, given a list, sweep) the parameters of the same name of every
// technique that has them; a name no technique of the config has is an error at its key.
std::vector<std::map<std::string, std::string>> with_scene_params(
    const YamlView& scene_node, const Config& config, size_t technique,
    const std::vector<std::map<std::string, std::string>>& combos, run::PluginRegistry& plugins) {
  std::optional<YamlView> overrides = scene_node.is_map() ? scene_node.get("params") : std::nullopt;
  if (!overrides) return combos;
  std::vector<std::string> known;
  for (const auto& entry : config.techniques)
    if (const run::Plugin* plugin = plugins.find(entry.technique); plugin && plugin->loaded())
      for (uint32_t i = 0; i < plugin->descriptor->param_count; ++i)
        if (std::find(known.begin(), known.end(), plugin->descriptor->params[i].name) == known.end())
          known.push_back(plugin->descriptor->params[i].name);
  overrides->allow_keys(known);
  const run::Plugin* plugin = plugins.find(config.techniques[technique].technique);
  if (!plugin || !plugin->loaded()) return combos;
  std::vector<std::map<std::string, std::string>> result = combos;
  for (const auto& [key, value] : overrides->entries()) {
    const pb_param_spec* spec = nullptr;
    for (uint32_t i = 0; i < plugin->descriptor->param_count; ++i)
      if (key == plugin->descriptor->params[i].name) spec = &plugin->descriptor->params[i];
    if (!spec) continue;  // another technique's parameter
    std::vector<YamlView> values = value.elements();
    if (values.empty()) value.fail("expected a value or a non-empty list of values to sweep");
    std::vector<std::map<std::string, std::string>> expanded;
    for (const auto& combo : result)
      for (const YamlView& v : values) {
        auto next = combo;
        next[key] = check_param(*spec, v);
        if (std::find(expanded.begin(), expanded.end(), next) == expanded.end()) expanded.push_back(std::move(next));
      }
    result = std::move(expanded);
  }
  return result;
}

}  // namespace

std::vector<Cell> expand_cells(const Config& config, run::PluginRegistry& plugins) {
  // Per technique entry: the list of parameter maps its sweeps expand to.
  std::vector<std::vector<std::map<std::string, std::string>>> combos(config.techniques.size());
  for (size_t t = 0; t < config.techniques.size(); ++t) {
    const TechniqueEntry& entry = config.techniques[t];
    YamlView name_node = entry.node["technique"];
    const run::Plugin* plugin = plugins.find(entry.technique);
    if (!plugin) {
      auto names = plugins.names();
      std::string hint = closest_name(entry.technique, names);
      name_node.fail(fmt::format("unknown technique '{}'{} (available: {})", entry.technique,
                                 hint.empty() ? "" : fmt::format("; did you mean '{}'?", hint),
                                 fmt::join(names, ", ")));
    }
    if (!plugin->version_error.empty()) name_node.fail(plugin->version_error);
    if (!plugin->loaded()) {
      combos[t].push_back({});  // fails when it runs, with the loader's error
      continue;
    }
    const pb_technique_descriptor& d = *plugin->descriptor;
    std::vector<std::string> names;
    for (uint32_t i = 0; i < d.param_count; ++i) names.push_back(d.params[i].name);
    std::map<std::string, std::string> defaults;
    for (uint32_t i = 0; i < d.param_count; ++i) defaults[d.params[i].name] = run::param_default_text(d.params[i]);
    combos[t].push_back(defaults);
    std::optional<YamlView> params = entry.node.get("params");
    if (!params) continue;
    params->allow_keys(names);
    for (const auto& [key, value] : params->entries()) {
      const pb_param_spec* spec = nullptr;
      for (uint32_t i = 0; i < d.param_count; ++i)
        if (key == d.params[i].name) spec = &d.params[i];
      std::vector<YamlView> values = value.elements();
      if (values.empty()) value.fail("expected a value or a non-empty list of values to sweep");
      std::vector<std::map<std::string, std::string>> expanded;
      for (const auto& combo : combos[t])
        for (const YamlView& v : values) {
          auto next = combo;
          next[key] = check_param(*spec, v);
          expanded.push_back(std::move(next));
        }
      combos[t] = std::move(expanded);
    }
  }

  std::vector<Cell> cells;
  std::vector<std::filesystem::path> search = {config.file.parent_path(), config.file.parent_path() / "scenes"};
  for (const auto& [scene_name, scene_node] : config.scenes) {
    std::filesystem::path scene_file = scene::find_scene(scene_name, search);
    std::string scene_id = scene_file.stem().string();
    for (size_t t = 0; t < config.techniques.size(); ++t) {
      for (const auto& params : with_scene_params(scene_node, config, t, combos[t], plugins)) {
        Cell cell;
        cell.scene = scene_id;
        cell.scene_file = scene_file;
        cell.technique = config.techniques[t].technique;
        cell.params = params;
        std::string key;
        for (const auto& [k, v] : params) key += k + "=" + v + ";";
        cell.id = fmt::format("{}__{}__{}", scene_id, cell.technique, stable_hash(key).substr(0, 8));
        bool duplicate = false;
        for (const auto& c : cells) duplicate |= c.id == cell.id;
        if (!duplicate) cells.push_back(std::move(cell));
      }
    }
  }
  return cells;
}

}  // namespace pb::config
