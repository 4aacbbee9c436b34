// `photonbench schema config|scene`: the JSON Schema (draft 2020-12) of config files or of scene
// files, printed from the key tables the readers validate with (config/key_table.h), so a YAML
// editor completes and checks what `validate` accepts. The config schema also holds what the
// loaded plugins declare: each technique's parameters ($defs "techniques.<name>.params", from its
// pb_param_spec rows, as plan/plan.cpp checks them; a list of values sweeps), the technique names,
// and the parameters a scene entry may set (any technique's).
#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli/command.h"
#include "config/key_table.h"
#include "plan/plugins.h"

namespace {

using nlohmann::json;

// One parameter's value, as plan/plan.cpp's check_param reads it.
json param_value_schema(const pb_param_spec& spec) {
  json out;
  switch (spec.type) {
    case PB_PARAM_INT:
      out = {{"type", "integer"},
             {"minimum", int64_t(spec.min_value)},
             {"maximum", int64_t(spec.max_value)},
             {"default", int64_t(spec.default_value)}};
      break;
    case PB_PARAM_FLOAT:
      out = {{"type", "number"},
             {"minimum", spec.min_value},
             {"maximum", spec.max_value},
             {"default", spec.default_value}};
      break;
    case PB_PARAM_BOOL:
      out = {{"type", "boolean"}, {"default", spec.default_value != 0}};
      break;
    case PB_PARAM_ENUM: {
      std::vector<std::string> choices;
      std::istringstream stream(spec.choices ? spec.choices : "");
      for (std::string c; std::getline(stream, c, '|');) choices.push_back(c);
      out = {{"enum", choices}};
      if (size_t(spec.default_value) < choices.size())
        out["default"] = choices[size_t(spec.default_value)];
      break;
    }
  }
  std::string unit = spec.unit && *spec.unit ? fmt::format(" [{}]", spec.unit) : "";
  out["description"] = fmt::format("{}{}", spec.doc ? spec.doc : "", unit);
  return out;
}

// A value, or a non-empty list of values to sweep.
json sweepable(const json& value) {
  return {{"anyOf", {value, {{"type", "array"}, {"items", value}, {"minItems", 1}}}}};
}

// $defs from the plugins: techniques.<name>.params, config.technique (an entry naming one of the
// techniques, with its parameters) and config.scene_params (any technique's parameters).
json plugin_defs(pb::run::PluginRegistry& plugins) {
  json defs = json::object();
  json entries = json::array();
  // An entry's `scenes` as the config's own table checks it (the plugins add nothing to it).
  const pb::config::Key& scenes_key =
      pb::config::config_table().key("techniques").type.parts[0].table->key("scenes");
  json scenes = scenes_key.type.schema();
  scenes["description"] = scenes_key.doc;
  // An entry's match keys as the config's table has them; `knob` is one of the plugin's knobs.
  const pb::config::KeyTable& entry_table =
      *pb::config::config_table().key("techniques").type.parts[0].table;
  auto entry_key = [&](const char* key) {
    json value = entry_table.key(key).type.schema();
    value["description"] = entry_table.key(key).doc;
    return value;
  };
  std::map<std::string, json> scene_params;  // name -> the alternatives of its techniques
  for (const std::string& name : plugins.names()) {
    const pb::run::Plugin* plugin = plugins.find(name);
    if (!plugin->load_error.empty()) {  // its cells would fail: the schema offers what can run
      std::fprintf(stderr, "schema: leaving out %s: %s\n", name.c_str(),
                   plugin->load_error.c_str());
      continue;
    }
    json params = {{"type", "object"}, {"additionalProperties", false}};
    json technique = {{"const", name}};
    json knob = entry_key("knob");
    if (plugin->loaded()) {
      const pb_technique_descriptor& d = *plugin->descriptor;
      technique["description"] = d.summary ? d.summary : "";
      // The counters its cells write (counters.csv), an annotation: {name: {kind, unit, doc}}.
      json counters = json::object();
      for (uint32_t i = 0; i < d.counter_count; ++i)
        counters[d.counters[i].name] = {
            {"kind", pb::run::counter_kind_text(d.counters[i].kind)},
            {"unit", d.counters[i].unit ? d.counters[i].unit : ""},
            {"description", d.counters[i].doc ? d.counters[i].doc : ""}};
      technique["x-counters"] = counters;
      // The budget knobs a match may turn (the first is the default): {name: {cost, error, scale}}.
      json budget = json::object();
      json knobs = json::array();
      for (uint32_t i = 0; i < d.budget_count; ++i) {
        budget[d.budget[i].param] = {{"cost", pb::run::budget_direction_text(d.budget[i].cost)},
                                     {"error", pb::run::budget_direction_text(d.budget[i].error)},
                                     {"scale", pb::run::budget_scale_text(d.budget[i].scale)}};
        knobs.push_back(d.budget[i].param);
      }
      technique["x-budget"] = budget;
      knob["enum"] = knobs;
      params["properties"] = json::object();
      for (uint32_t i = 0; i < d.param_count; ++i) {
        json value = param_value_schema(d.params[i]);
        params["properties"][d.params[i].name] = sweepable(value);
        scene_params[d.params[i].name].push_back(value);
      }
    } else {  // its cells fail when they run (validate exits 1); its parameters are unknown
      std::fprintf(stderr, "schema: %s does not load (%s); its parameters are not checked\n",
                   name.c_str(), plugin->load_error.c_str());
      params.erase("additionalProperties");
    }
    std::string params_def = "techniques." + name + ".params";
    defs[params_def] = params;
    entries.push_back({{"type", "object"},
                       {"properties",
                        {{"technique", technique},
                         {"params", {{"$ref", "#/$defs/" + params_def}}},
                         {"scenes", scenes},
                         {"match", entry_key("match")},
                         {"knob", knob},
                         {"knob_range", entry_key("knob_range")}}},
                       {"required", {"technique"}},
                       {"additionalProperties", false}});
  }
  defs["config.technique"] = {
      {"description", "A technique plugin and its parameters; a list of values sweeps one."},
      {"anyOf", entries}};
  json properties = json::object();
  for (const auto& [name, alternatives] : scene_params)
    properties[name] =
        sweepable(alternatives.size() == 1 ? alternatives[0] : json{{"anyOf", alternatives}});
  defs["config.scene_params"] = {
      {"description",
       "Parameters replacing (or sweeping) those of the same name of the config's techniques, "
       "for this scene's cells."},
      {"type", "object"},
      {"properties", properties},
      {"additionalProperties", false}};
  return defs;
}

void add_schema(CLI::App& app, int& exit_code) {
  struct Args {
    std::string format;
    std::vector<std::string> plugin_dirs;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand(
      "schema", "print the JSON Schema of config files or of scene files (for YAML editors)");
  cmd->add_option("format", args->format, "config or scene")
      ->required()
      ->check(CLI::IsMember({"config", "scene"}));
  cmd->add_option("--plugin-dir", args->plugin_dirs,
                  "also describe the technique plugins in this folder (repeatable)")
      ->check(CLI::ExistingDirectory);
  cmd->callback([args, &exit_code] {
    json document;
    if (args->format == "scene") {
      document = pb::config::schema_document(pb::scene::scene_table());
    } else {
      std::vector<std::filesystem::path> dirs(args->plugin_dirs.begin(), args->plugin_dirs.end());
      pb::run::PluginRegistry plugins(dirs);
      document = pb::config::schema_document(pb::config::config_table(), plugin_defs(plugins));
    }
    std::printf("%s\n", document.dump(2).c_str());
    exit_code = 0;
  });
}

pb::cli::CommandRegistration schema_registration{"schema", add_schema};

}  // namespace
