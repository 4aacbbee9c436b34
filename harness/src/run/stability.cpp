#include "run/stability.h"

#include <fmt/chrono.h>
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "cell/cell_runner.h"
#include "io/results.h"
#include "photonbench/error.h"
#include "plan/plan.h"
#include "run/runner.h"
#include "scene/scene.h"

namespace pb::run {

namespace fs = std::filesystem;
using json = nlohmann::json;

const char* stability_class_name(StabilityClass c) {
  switch (c) {
    case StabilityClass::ok:
      return "ok";
    case StabilityClass::degraded:
      return "degraded";
    case StabilityClass::failed:
      return "failed";
    case StabilityClass::unrated:
      return "unrated";
    case StabilityClass::skipped:
      return "skipped";
  }
  return "?";
}

Verdict classify_cell(const CellOutcome& cell, const CellOutcome* baseline,
                      const StabilityRules& rules, const CellOutcome* no_gi) {
  if (cell.status != "ok")
    return {StabilityClass::failed, cell.reason.empty() ? "failed" : cell.reason, std::nullopt};
  if (!cell.frame_warnings.empty()) {
    const auto& [frame, message] = cell.frame_warnings.front();
    std::string reason = fmt::format("warning at frame {}: {}", frame, message);
    if (cell.frame_warnings.size() > 1)
      reason += fmt::format(" (and {} more warnings)", cell.frame_warnings.size() - 1);
    return {StabilityClass::failed, reason, std::nullopt};
  }
  if (!cell.flip) return {StabilityClass::unrated, "no FLIP score", std::nullopt};
  if (cell.flicker && rules.flicker_bound && *cell.flicker > *rules.flicker_bound)
    return {
        StabilityClass::degraded,
        fmt::format("flicker {:.3g} above the bound {:.3g}", *cell.flicker, *rules.flicker_bound),
        std::nullopt};
  const bool resolved =
      !cell.flip_floor || *cell.flip >= rules.resolved_floor_factor * *cell.flip_floor;
  const double no_gi_factor = rules.no_gi_factor.value_or(rules.degraded_factor);
  if (no_gi && no_gi->status == "ok" && no_gi->flip && resolved &&
      *cell.flip > no_gi_factor * *no_gi->flip &&
      *cell.flip - *no_gi->flip > cell.flip_floor.value_or(0) + no_gi->flip_floor.value_or(0))
    return {StabilityClass::degraded,
            fmt::format("FLIP {:.3g} = {:.3g}x {}'s {:.3g} on this scenario (no indirect light at "
                        "all; bound {:.3g}x)",
                        *cell.flip, *cell.flip / std::max(*no_gi->flip, 1e-12),
                        rules.no_gi_technique, *no_gi->flip, no_gi_factor),
            std::nullopt};
  if (!baseline) return {StabilityClass::ok, fmt::format("FLIP {:.3g}", *cell.flip), std::nullopt};
  if (baseline->status != "ok" || !baseline->frame_warnings.empty() || !baseline->flip)
    return {StabilityClass::unrated,
            fmt::format("FLIP {:.3g}; its baseline cell failed, so nothing to compare with",
                        *cell.flip),
            std::nullopt};
  const double base = *baseline->flip;
  const std::optional<double> ratio =
      base > 0 ? std::optional<double>(*cell.flip / base) : std::nullopt;
  const std::string against =
      ratio ? fmt::format("FLIP {:.3g} = {:.2f}x the baseline's {:.3g}", *cell.flip, *ratio, base)
            : fmt::format("FLIP {:.3g}, the baseline's 0", *cell.flip);
  const bool beyond = *cell.flip > rules.degraded_factor * base;
  if (beyond && resolved)
    return {StabilityClass::degraded,
            fmt::format("{} (bound {:.3g}x)", against, rules.degraded_factor), ratio};
  if (beyond)
    return {StabilityClass::ok,
            fmt::format("{}, but within {:.3g}x its noise floor {:.3g}", against,
                        rules.resolved_floor_factor, *cell.flip_floor),
            ratio};
  return {StabilityClass::ok, against, ratio};
}

CellOutcome read_cell_outcome(const fs::path& cell_json) {
  CellOutcome out;
  const json record = json::parse(io::read_text(cell_json));
  out.status = record.value("status", "failed");
  out.reason = record.value("reason", "");
  for (const json& w : record.value("warnings", json::array()))
    if (w.contains("frame") && w["frame"].is_number_unsigned())
      out.frame_warnings.emplace_back(w["frame"].get<uint32_t>(), w.value("message", ""));
  const json combined = record.value("metrics", json::object()).value("combined", json::object());
  auto number = [&combined](const char* key) -> std::optional<double> {
    if (combined.contains(key) && combined[key].is_number()) return combined[key].get<double>();
    return std::nullopt;
  };
  out.flip = number("flip");
  out.flip_floor = number("flip_floor");
  out.flicker = number("flicker");
  return out;
}

namespace {

// A scene entry of the stability file: its scene resolved to an absolute path (the generated config
// lives in the run folder), its params kept as written.
struct EntrySpec {
  YAML::Node node;
  std::string label;
};

struct ScenarioSpec {
  std::string name;
  std::string aims_at;
  EntrySpec entry;
  size_t baseline = 0;      // index into StabilitySpec::baselines
  std::string skip_reason;  // non-empty: not run (a technique it needs is not built)
};

struct StabilitySpec {
  std::string name;
  StabilityRules rules;
  YAML::Node benchmark;  // the benchmark keys, techniques filtered, scenes not yet added
  std::vector<EntrySpec> baselines;
  std::vector<ScenarioSpec> scenarios;
  std::vector<std::string> techniques;  // those that run, in order
  std::vector<std::string> absent;      // `when_built` techniques that are not built
  std::vector<std::string> left_out;    // built, but not chosen by --technique
  std::set<std::string> params;         // the parameters of the techniques that run
};

// Names with a '/' or an extension are paths relative to the stability file, as scene files name
// their OBJ files; other names are looked up beside it, in its scenes/ and in the shipped scenes.
fs::path resolve_scene(const std::string& name, const fs::path& dir) {
  const bool is_path = name.find('/') != std::string::npos || fs::path(name).has_extension();
  if (is_path && fs::path(name).is_relative())
    return fs::absolute(scene::find_scene((dir / name).string(), {})).lexically_normal();
  return fs::absolute(scene::find_scene(name, {dir, dir / "scenes"})).lexically_normal();
}

EntrySpec read_entry(const config::YamlView& v, const fs::path& dir) {
  if (v.is_map()) v.allow_keys({"scene", "params"});
  const config::YamlView name_node = v.is_map() ? v["scene"] : v;
  const std::string name = name_node.as_string();
  EntrySpec entry;
  try {
    entry.node["scene"] = resolve_scene(name, dir).string();
  } catch (const InputError& e) {
    name_node.fail(e.what());
  }
  if (auto params = v.is_map() ? v.get("params") : std::nullopt) {
    if (!params->is_map()) params->fail("expected a mapping of technique parameters");
    entry.node["params"] = YAML::Clone(params->node());
  }
  entry.label = fs::path(name).stem().string();
  return entry;
}

std::string entry_key(const YAML::Node& node) {
  YAML::Emitter out;
  out << YAML::Flow << node;
  return out.c_str();
}

size_t add_baseline(StabilitySpec& spec, EntrySpec entry, const std::string& label) {
  const std::string key = entry_key(entry.node);
  for (size_t i = 0; i < spec.baselines.size(); ++i)
    if (entry_key(spec.baselines[i].node) == key) return i;
  entry.label = label;
  spec.baselines.push_back(std::move(entry));
  return spec.baselines.size() - 1;
}

StabilityRules read_rules(const config::YamlView& rules) {
  rules.allow_keys({"degraded_factor", "resolved_floor_factor", "flicker_bound", "no_gi_technique",
                    "no_gi_factor", "baseline"});
  StabilityRules out;
  out.no_gi_technique = rules.string_or("no_gi_technique", "");
  out.degraded_factor = rules.number_or("degraded_factor", 2.0, 1.0, 1e6);
  out.resolved_floor_factor = rules.number_or("resolved_floor_factor", 4.0, 0.0, 1e6);
  if (auto bound = rules.get("flicker_bound")) out.flicker_bound = bound->as_number(0, 1e6);
  if (auto factor = rules.get("no_gi_factor")) out.no_gi_factor = factor->as_number(1, 1e6);
  return out;
}

bool listed(const std::vector<std::string>& names, const std::string& name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

// The techniques: the entries pass to the generated config as written, less `when_built`; one
// marked `when_built: true` whose plugin is not built is left out (it joins the suite when it
// lands), and so is one that `chosen` (--technique, when not empty) does not name, unless it is the
// no-GI technique the classification compares with. Returns the entries for the generated config.
YAML::Node read_techniques(const config::YamlView& root, const std::vector<fs::path>& plugin_dirs,
                           const std::vector<std::string>& chosen, StabilitySpec& spec) {
  PluginRegistry plugins(plugin_dirs);
  YAML::Node techniques(YAML::NodeType::Sequence);
  std::vector<std::string> names;
  auto add = [&](const std::string& name, YAML::Node entry, bool when_built) {
    names.push_back(name);
    const Plugin* plugin = plugins.find(name);
    if (when_built && !plugin) {
      spec.absent.push_back(name);
      return;
    }
    if (!chosen.empty() && !listed(chosen, name) && name != spec.rules.no_gi_technique) {
      spec.left_out.push_back(name);
      return;
    }
    entry.remove("when_built");
    techniques.push_back(entry);
    spec.techniques.push_back(name);
    if (plugin && plugin->loaded())
      for (uint32_t i = 0; i < plugin->descriptor->param_count; ++i)
        spec.params.insert(plugin->descriptor->params[i].name);
  };
  const config::YamlView list = root["techniques"];
  if (list.is_scalar() && list.as_string() == "built") {
    // Every plugin the suite can load, with its defaults, in name order: a technique joins the
    // suite by being built.
    for (const std::string& name : plugins.names()) {
      YAML::Node entry;
      entry["technique"] = name;
      add(name, entry, false);
    }
  } else {
    for (const config::YamlView& t : list.elements()) {
      if (!t.is_map())
        t.fail(
            "expected `built` or a list of {technique: NAME, params: {...}, when_built: "
            "true|false}");
      t.allow_keys({"technique", "params", "when_built"});
      add(t["technique"].as_string(), YAML::Clone(t.node()), t.bool_or("when_built", false));
    }
  }
  for (const std::string& name : chosen)
    if (!listed(names, name))
      throw InputError(fmt::format("--technique {}: not one of the suite's techniques ({})", name,
                                   fmt::join(names, ", ")));
  if (spec.techniques.empty()) root["techniques"].fail("no technique of the list is built");
  return techniques;
}

// With techniques left out by --technique, a scene entry's params that no technique of the run has
// are theirs: dropped, so that the plan (which refuses a parameter no technique of the config has)
// runs the rest. Without, every key stays and a misspelt one is refused.
void drop_left_out_params(StabilitySpec& spec) {
  if (spec.left_out.empty()) return;
  auto prune = [&](EntrySpec& entry) {
    const YAML::Node params = static_cast<const YAML::Node&>(entry.node)["params"];
    if (!params) return;
    std::vector<std::string> theirs;
    for (const auto& kv : params)
      if (!spec.params.count(kv.first.as<std::string>()))
        theirs.push_back(kv.first.as<std::string>());
    for (const std::string& key : theirs) entry.node["params"].remove(key);
    if (entry.node["params"].size() == 0) entry.node.remove("params");
  };
  for (EntrySpec& b : spec.baselines) prune(b);
  for (ScenarioSpec& s : spec.scenarios) prune(s.entry);
}

bool has_technique(const StabilitySpec& spec, const std::string& name) {
  return listed(spec.techniques, name);
}

void read_scenarios(const config::YamlView& scenarios, const fs::path& dir, StabilitySpec& spec) {
  if (scenarios.elements().empty()) scenarios.fail("at least one scenario is needed");
  std::set<std::string> names;
  for (const config::YamlView& s : scenarios.elements()) {
    s.allow_keys({"name", "aims_at", "scene", "baseline", "needs"});
    ScenarioSpec scenario;
    scenario.name = s["name"].as_string();
    if (scenario.name == "baseline" || !names.insert(scenario.name).second)
      s["name"].fail(fmt::format("scenario '{}' is named twice (or 'baseline', which is taken)",
                                 config::quote(scenario.name)));
    scenario.aims_at = s["aims_at"].as_string();
    scenario.entry = read_entry(s["scene"], dir);
    scenario.entry.label = scenario.name;
    scenario.baseline = 0;
    if (auto own = s.get("baseline"))
      scenario.baseline = add_baseline(spec, read_entry(*own, dir), scenario.name + " baseline");
    if (auto needs = s.get("needs"))
      for (const config::YamlView& n : needs->elements())
        if (!has_technique(spec, n.as_string()))
          scenario.skip_reason = fmt::format(
              "needs technique '{}', {}", n.as_string(),
              listed(spec.left_out, n.as_string()) ? "not chosen (--technique)" : "not built");
    spec.scenarios.push_back(std::move(scenario));
  }
}

// The stress suite as one benchmark config: the file's own keys less `stability` and
// `scenarios`, the built techniques, and the baselines' and runnable scenarios' scene entries.
YAML::Node generated_benchmark(const config::YamlView& root, const StabilitySpec& spec,
                               const YAML::Node& techniques,
                               const std::vector<fs::path>& plugin_dirs) {
  YAML::Node benchmark = YAML::Clone(root.node());
  benchmark.remove("stability");
  benchmark.remove("scenarios");
  benchmark["name"] = spec.name;
  benchmark["techniques"] = techniques;
  if (root.has("plugin_dirs")) {
    YAML::Node dirs(YAML::NodeType::Sequence);
    for (const fs::path& d : plugin_dirs) dirs.push_back(d.string());
    benchmark["plugin_dirs"] = dirs;
  }
  YAML::Node scenes(YAML::NodeType::Sequence);
  for (const EntrySpec& b : spec.baselines) scenes.push_back(b.node);
  for (const ScenarioSpec& s : spec.scenarios)
    if (s.skip_reason.empty()) scenes.push_back(s.entry.node);
  benchmark["scenes"] = scenes;
  return benchmark;
}

StabilitySpec read_stability_file(const fs::path& file, const std::vector<std::string>& chosen) {
  const config::YamlView root = config::YamlView::load_file(file);
  if (!root.is_map())
    root.fail("a stability file is a mapping (a benchmark config's keys, stability, scenarios)");
  if (root.has("scenes"))
    root["scenes"].fail(
        "a stability file lists `scenarios` (each a scene entry with its `aims_at`), not `scenes`");
  root.allow_keys({"name", "resolution", "frames", "seed", "techniques", "metrics", "reference",
                   "limits", "plugin_dirs", "testing", "stability", "scenarios"});
  const fs::path dir = fs::absolute(file).parent_path();
  StabilitySpec spec;
  spec.name = root.string_or("name", file.stem().string());
  const config::YamlView rules = root["stability"];
  spec.rules = read_rules(rules);
  add_baseline(spec, read_entry(rules["baseline"], dir), "baseline");

  std::vector<fs::path> plugin_dirs;
  if (auto dirs = root.get("plugin_dirs"))
    for (const config::YamlView& d : dirs->elements()) {
      fs::path p = d.as_string();
      plugin_dirs.push_back(p.is_relative() ? dir / p : p);
    }
  const YAML::Node techniques = read_techniques(root, plugin_dirs, chosen, spec);
  if (!spec.rules.no_gi_technique.empty() && !has_technique(spec, spec.rules.no_gi_technique))
    rules["no_gi_technique"].fail(fmt::format("'{}' is not one of the suite's techniques",
                                              config::quote(spec.rules.no_gi_technique)));
  read_scenarios(root["scenarios"], dir, spec);
  drop_left_out_params(spec);
  spec.benchmark = generated_benchmark(root, spec, techniques, plugin_dirs);
  return spec;
}

// The keys a scene entry's params set: a baseline cell matches a scenario cell on every other one.
std::set<std::string> param_keys(const YAML::Node& entry) {
  std::set<std::string> keys;
  if (entry["params"])
    for (const auto& kv : entry["params"]) keys.insert(kv.first.as<std::string>());
  return keys;
}

const Cell* matching_baseline(const Cell& cell, const std::vector<Cell>& baseline_cells,
                              const std::set<std::string>& free_keys) {
  for (const Cell& b : baseline_cells) {
    if (b.technique != cell.technique) continue;
    bool same = true;
    for (const auto& [key, value] : cell.params)
      if (!free_keys.count(key) && b.params.count(key) && b.params.at(key) != value) same = false;
    if (same) return &b;
  }
  return nullptr;
}

struct Row {
  std::string scenario, technique, cell, baseline_cell, aims_at;
  Verdict verdict;
  std::optional<double> flip, flip_floor, baseline_flip;
};

std::string number_text(const std::optional<double>& v) {
  return v ? fmt::format("{:.6g}", *v) : std::string();
}

void write_stability_csv(const fs::path& file, const std::vector<Row>& rows) {
  std::string text = io::csv_row({"scenario", "technique", "class", "reason", "flip", "flip_floor",
                                  "baseline_flip", "ratio", "cell", "baseline_cell", "aims_at"});
  for (const Row& r : rows)
    text += io::csv_row({r.scenario, r.technique, stability_class_name(r.verdict.verdict),
                         r.verdict.reason, number_text(r.flip), number_text(r.flip_floor),
                         number_text(r.baseline_flip), number_text(r.verdict.ratio), r.cell,
                         r.baseline_cell, r.aims_at});
  io::write_text_atomic(file, text);
}

// The matrix on stdout: a scenario per line, a technique per column, the worst class of its cells.
void print_matrix(const std::vector<Row>& rows, const std::vector<std::string>& techniques) {
  std::vector<std::string> scenarios;
  std::map<std::pair<std::string, std::string>, StabilityClass> worst;
  for (const Row& r : rows) {
    if (std::find(scenarios.begin(), scenarios.end(), r.scenario) == scenarios.end())
      scenarios.push_back(r.scenario);
    auto [it, fresh] = worst.try_emplace({r.scenario, r.technique}, r.verdict.verdict);
    // failed > degraded > unrated > ok > skipped, by how much a reader must look at it
    auto rank = [](StabilityClass c) {
      return c == StabilityClass::failed     ? 4
             : c == StabilityClass::degraded ? 3
             : c == StabilityClass::unrated  ? 2
             : c == StabilityClass::ok       ? 1
                                             : 0;
    };
    if (!fresh && rank(r.verdict.verdict) > rank(it->second)) it->second = r.verdict.verdict;
  }
  size_t width = 8;
  for (const auto& s : scenarios) width = std::max(width, s.size());
  std::string line = fmt::format("{:<{}}", "scenario", width);
  for (const auto& t : techniques) line += fmt::format("  {:<10}", t);
  std::printf("%s\n", line.c_str());
  for (const auto& s : scenarios) {
    line = fmt::format("{:<{}}", s, width);
    for (const auto& t : techniques) {
      auto it = worst.find({s, t});
      line += fmt::format("  {:<10}", it == worst.end() ? "-" : stability_class_name(it->second));
    }
    std::printf("%s\n", line.c_str());
  }
}

Row skipped_row(const std::string& scenario, const ScenarioSpec& spec, const std::string& technique,
                const std::string& reason) {
  Row row;
  row.scenario = scenario;
  row.technique = technique;
  row.aims_at = spec.aims_at;
  row.verdict = {StabilityClass::skipped, reason, std::nullopt};
  return row;
}

// The classification reads what the run left: each cell's record, matched to its baseline's.
class Classifier {
 public:
  Classifier(const StabilitySpec& spec, const RunPlan& plan, const fs::path& out)
      : spec_(spec), plan_(plan), out_(out) {}

  std::vector<Row> rows() {
    std::vector<Row> rows;
    for (size_t b = 0; b < spec_.baselines.size(); ++b) {
      baseline_cells_.push_back(cells_of(b));
      for (const Cell& cell : baseline_cells_.back()) rows.push_back(baseline_row(b, cell));
    }
    size_t scene_index = spec_.baselines.size();
    for (const ScenarioSpec& scenario : spec_.scenarios) {
      if (!scenario.skip_reason.empty()) {
        for (const std::string& t : spec_.techniques)
          rows.push_back(skipped_row(scenario.name, scenario, t, scenario.skip_reason));
        continue;
      }
      for (Row& row : scenario_rows(scenario, cells_of(scene_index++))) rows.push_back(row);
    }
    for (const std::string& t : spec_.absent)
      for (const ScenarioSpec& scenario : spec_.scenarios)
        rows.push_back(skipped_row(scenario.name, scenario, t, "technique not built"));
    return rows;
  }

 private:
  // Each scene entry's own cells: the plan of a config holding that entry alone.
  std::vector<Cell> cells_of(size_t scene_index) const {
    config::Config one = plan_.config;
    one.scenes = {plan_.config.scenes[scene_index]};
    return expand_cells(one, *plan_.plugins);
  }
  std::optional<CellOutcome> outcome_of(const Cell& cell) const {
    const fs::path file = cell_dir(out_, cell.id) / "cell.json";
    if (!fs::exists(file)) return std::nullopt;
    return read_cell_outcome(file);
  }

  Row baseline_row(size_t b, const Cell& cell) const {
    Row row;
    row.scenario = spec_.baselines[b].label;
    row.technique = cell.technique;
    row.cell = cell.id;
    row.aims_at = "the scenarios' reference point";
    const auto outcome = outcome_of(cell);
    row.verdict = outcome ? classify_cell(*outcome, nullptr, spec_.rules)
                          : Verdict{StabilityClass::unrated, "no cell record", std::nullopt};
    if (outcome) row.flip = outcome->flip, row.flip_floor = outcome->flip_floor;
    return row;
  }

  std::vector<Row> scenario_rows(const ScenarioSpec& scenario,
                                 const std::vector<Cell>& cells) const {
    std::set<std::string> free_keys = param_keys(scenario.entry.node);
    for (const std::string& k : param_keys(spec_.baselines[scenario.baseline].node))
      free_keys.insert(k);
    std::optional<CellOutcome> no_gi;
    for (const Cell& cell : cells)
      if (cell.technique == spec_.rules.no_gi_technique) no_gi = outcome_of(cell);
    std::vector<Row> rows;
    for (const Cell& cell : cells) {
      const CellOutcome* no_gi_here =
          no_gi && cell.technique != spec_.rules.no_gi_technique ? &*no_gi : nullptr;
      Row row;
      row.scenario = scenario.name;
      row.technique = cell.technique;
      row.cell = cell.id;
      row.aims_at = scenario.aims_at;
      const auto outcome = outcome_of(cell);
      const Cell* base = matching_baseline(cell, baseline_cells_[scenario.baseline], free_keys);
      const auto base_outcome = base ? outcome_of(*base) : std::nullopt;
      if (base) row.baseline_cell = base->id;
      if (base_outcome) row.baseline_flip = base_outcome->flip;
      if (!outcome) {
        row.verdict = {StabilityClass::unrated, "no cell record", std::nullopt};
      } else if (!base_outcome) {
        // A failure is one with or without a baseline; anything else needs one to compare with.
        row.verdict = classify_cell(*outcome, nullptr, spec_.rules, no_gi_here);
        if (row.verdict.verdict == StabilityClass::ok)
          row.verdict = {StabilityClass::unrated, "no baseline cell to compare with", std::nullopt};
      } else {
        row.verdict = classify_cell(*outcome, &*base_outcome, spec_.rules, no_gi_here);
      }
      if (outcome) row.flip = outcome->flip, row.flip_floor = outcome->flip_floor;
      rows.push_back(std::move(row));
    }
    return rows;
  }

  const StabilitySpec& spec_;
  const RunPlan& plan_;
  const fs::path& out_;
  std::vector<std::vector<Cell>> baseline_cells_;
};

// The stability run's folder (OUT, or results/<name>-<time>), checked to be new unless resumed,
// with the generated benchmark config written into it; returns that config's path.
fs::path write_generated_config(const StabilityOptions& options, const StabilitySpec& spec,
                                fs::path& out) {
  out = options.out_dir;
  if (out.empty()) {
    if (options.resume) throw InputError("--resume needs --out DIR, the stability run to continue");
    auto now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
    out = fs::path("results") / fmt::format("{}-{:%Y%m%d-%H%M%S}", spec.name, fmt::localtime(now));
  }
  std::error_code ec;
  if (!options.resume &&
      (fs::exists(out / "run.json", ec) || fs::exists(out / "invocation.json", ec)))
    throw InputError(fmt::format(
        "{} already holds a run; use --resume to continue it, or another --out", out.string()));
  fs::create_directories(out, ec);
  if (ec) throw InputError(fmt::format("--out {}: {}", out.string(), ec.message()));
  const fs::path generated = fs::absolute(out / "benchmark.yaml");
  YAML::Emitter emitter;
  emitter << spec.benchmark;
  io::write_text_atomic(
      generated, fmt::format("# Generated by `photonbench stability {}`: the stress suite as "
                             "one benchmark config.\n{}\n",
                             options.stability_file.string(), emitter.c_str()));
  return generated;
}

// The classification needs scores: checked before anything runs.
void check_scored(const RunPlan& plan, const StabilityOptions& options) {
  if (plan.config.frames.metrics_every == 0)
    throw InputError(
        fmt::format("{}: frames.metrics_every is 0: stability classifies cells by "
                    "their scores, so it needs metric frames",
                    options.stability_file.string()));
  if (std::find(plan.config.metrics.begin(), plan.config.metrics.end(), "flip") ==
      plan.config.metrics.end())
    throw InputError(fmt::format("{}: metrics must include flip (the error stability compares)",
                                 options.stability_file.string()));
}

}  // namespace

int run_stability(const StabilityOptions& options) {
  const StabilitySpec spec = read_stability_file(options.stability_file, options.techniques);
  fs::path out;
  const fs::path generated = write_generated_config(options, spec, out);
  check_scored(plan_run(generated, options.overrides), options);

  RunOptions run;
  run.config_file = generated;
  run.overrides = options.overrides;
  run.out_dir = out;
  run.device = options.device;
  run.resume = options.resume;
  run.validation = options.validation;
  run_benchmark(run);  // failed cells are this command's results, not its failure

  const RunPlan plan = plan_run(generated, options.overrides);
  const std::vector<Row> rows = Classifier(spec, plan, out).rows();
  write_stability_csv(out / "stability.csv", rows);
  std::vector<std::string> columns = spec.techniques;
  columns.insert(columns.end(), spec.absent.begin(), spec.absent.end());
  print_matrix(rows, columns);
  std::fprintf(stderr, "photonbench stability: %zu cells classified -> %s\n", rows.size(),
               (out / "stability.csv").string().c_str());
  return 0;
}

}  // namespace pb::run
