// `photonbench list techniques|scenes|devices`: what can be named in a config (a technique with its
// parameters, the counters it emits and its budget knobs).
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cstdio>
#include <set>
#include <string>

#include "cli/command.h"
#include "config/yaml_view.h"
#include "gpu/device_accounting.h"
#include "photonbench/error.h"
#include "plan/plugins.h"
#include "scene/scene.h"

namespace {

// Every technique found, or only those `only` names (an unknown name is bad input, with the
// closest known one and where else plugins may be).
void list_techniques(const std::vector<std::string>& plugin_dirs,
                     const std::vector<std::string>& only) {
  std::vector<std::filesystem::path> dirs(plugin_dirs.begin(), plugin_dirs.end());
  pb::run::PluginRegistry plugins(dirs);
  const std::vector<std::string> known = plugins.names();
  for (const std::string& name : only)
    if (std::find(known.begin(), known.end(), name) == known.end()) {
      const std::string hint = pb::config::closest_name(name, known);
      throw pb::InputError(fmt::format(
          "list techniques: unknown technique '{}'{} (available: {}); a plugin built elsewhere is "
          "found with --plugin-dir DIR",
          name, hint.empty() ? "" : fmt::format("; did you mean '{}'?", hint),
          fmt::join(known, ", ")));
    }
  for (const auto& name : only.empty() ? known : only) {
    const pb::run::Plugin* plugin = plugins.find(name);
    if (!plugin->loaded()) {
      std::printf("%s  (%s)\n  cannot load: %s\n\n", name.c_str(), plugin->file.c_str(),
                  plugin->load_error.c_str());
      continue;
    }
    const auto& d = *plugin->descriptor;
    std::printf("%s  [%s]  %s\n", d.name, d.path_class, d.summary);
    for (uint32_t i = 0; i < d.param_count; ++i) {
      const auto& p = d.params[i];
      std::string range = p.type == PB_PARAM_ENUM ? std::string(p.choices)
                          : p.type == PB_PARAM_BOOL
                              ? "true|false"
                              : fmt::format("[{}, {}]", p.min_value, p.max_value);
      std::printf("  %-22s %-5s default %-10s %-18s %s%s%s\n", p.name,
                  pb::run::param_type_name(p).c_str(), pb::run::param_default_text(p).c_str(),
                  range.c_str(), p.doc, p.unit && *p.unit ? " (" : "",
                  p.unit && *p.unit ? (std::string(p.unit) + ")").c_str() : "");
    }
    if (d.budget_count > 0) std::printf("  budget knobs (match:):\n");
    for (uint32_t i = 0; i < d.budget_count; ++i) {
      const auto& k = d.budget[i];
      std::printf("  %-22s cost %-5s error %-5s %s scale%s\n", k.param,
                  pb::run::budget_direction_text(k.cost).c_str(),
                  pb::run::budget_direction_text(k.error).c_str(),
                  pb::run::budget_scale_text(k.scale).c_str(),
                  i == 0 ? "  (the default knob)" : "");
    }
    if (d.counter_count > 0) std::printf("  counters:\n");
    std::set<std::string> listed;  // a counter two parts of a technique declare, once
    for (uint32_t i = 0; i < d.counter_count; ++i) {
      const auto& c = d.counters[i];
      if (!listed.insert(c.name).second) continue;
      std::printf("  %-32s %-5s %-10s %s\n", c.name, pb::run::counter_kind_text(c.kind).c_str(),
                  c.unit ? c.unit : "", c.doc ? c.doc : "");
    }
    std::printf("\n");
  }
}

void list_scenes() {
  std::filesystem::path dir = std::filesystem::path(PB_SOURCE_DIR) / "scenes";
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    if (entry.path().extension() == ".yaml") files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  for (const auto& file : files) {
    try {
      auto scene = pb::scene::load_scene(file);
      std::printf("%-22s %s\n", file.stem().c_str(), scene.purpose.c_str());
    } catch (const std::exception& e) {
      std::printf("%-22s (does not load: %s)\n", file.stem().c_str(), e.what());
    }
  }
}

void add_list(CLI::App& app, int& exit_code) {
  auto what = std::make_shared<std::string>();
  auto plugin_dirs = std::make_shared<std::vector<std::string>>();
  auto* cmd =
      app.add_subcommand("list", "list techniques (with their parameters), scenes or devices");
  auto names = std::make_shared<std::vector<std::string>>();
  cmd->add_option("what", *what, "techniques, scenes or devices")
      ->required()
      ->check(CLI::IsMember({"techniques", "scenes", "devices"}));
  cmd->add_option("names", *names, "techniques: only these (e.g. list techniques tiled)");
  cmd->add_option("--plugin-dir", *plugin_dirs, "also look for technique plugins here");
  cmd->callback([what, names, plugin_dirs, &exit_code] {
    if (*what != "techniques" && !names->empty())
      throw pb::InputError(
          fmt::format("list {}: takes no names (list techniques NAME does)", *what));
    if (*what == "techniques") list_techniques(*plugin_dirs, *names);
    if (*what == "scenes") list_scenes();
    if (*what == "devices")
      for (const auto& name : pb::gpu::list_devices()) std::printf("%s\n", name.c_str());
    exit_code = 0;
  });
}

pb::cli::CommandRegistration list_registration{"list", add_list};

}  // namespace
