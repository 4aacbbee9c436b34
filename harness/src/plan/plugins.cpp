#include "plan/plugins.h"

#include <dlfcn.h>
#include <fmt/format.h>
#include <unistd.h>

#include <cmath>
#include <sstream>
#include <string_view>
#include <vector>

#include "photonbench/error.h"
#include "reference/path_class.h"

namespace pb::run {

std::filesystem::path PluginRegistry::build_plugin_dir() {
  // Found from the executable's own location: plugins/ beside it (the build tree), else the
  // installed layout (<prefix>/bin/photonbench, <prefix>/lib/photonbench/plugins/), so a moved
  // install still finds its own plugins; the configured build directory only as a last resort.
  std::error_code ec;
  auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    for (const auto& dir : {exe.parent_path() / "plugins",
                            (exe.parent_path() / PB_INSTALLED_PLUGIN_DIR).lexically_normal()})
      if (std::filesystem::is_directory(dir)) return dir;
  }
  return PB_PLUGIN_DIR;
}

PluginRegistry::PluginRegistry(const std::vector<std::filesystem::path>& extra_dirs) {
  dirs_.push_back(build_plugin_dir());
  for (const auto& d : extra_dirs) dirs_.push_back(std::filesystem::absolute(d));
  for (const auto& dir : dirs_) {
    std::error_code ec;
    for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
      if (entry.path().extension() != ".so") continue;
      const std::string name = entry.path().stem().string();
      auto [it, added] = files_.try_emplace(name, entry.path());
      // One name, one technique (as Falcor refuses a second registration of a render pass): a
      // module that silently replaced a built-in would be measured under the built-in's name. The
      // same folder named twice finds the same file, which is no conflict.
      if (!added && !std::filesystem::equivalent(it->second, entry.path(), ec))
        throw InputError(fmt::format(
            "two technique plugins are named '{}': {} and {}; remove or rename one (a plugin "
            "folder cannot replace a technique of the same name)",
            name, it->second.string(), entry.path().string()));
    }
  }
}

PluginRegistry::~PluginRegistry() {
  // Handles stay open for the process's life: a technique's code may still be referenced by objects
  // being destroyed during exit.
}

std::vector<std::string> PluginRegistry::names() const {
  std::vector<std::string> out;
  for (const auto& [name, file] : files_) out.push_back(name);
  return out;
}

namespace {

std::string assertion_text(uint32_t assertions) {
  return assertions ? "built without NDEBUG (a Debug build, or no build type)"
                    : "built with NDEBUG (a Release build)";
}

std::string describe(const pb_build_record& build) {
  return fmt::format("{}, {}, Vulkan-Hpp {}", build.compiler, build.standard_library,
                     build.vulkan_hpp_version);
}

std::string known_path_classes() {
  std::vector<std::string> known;
  for (trace::PathClass c : trace::all_path_classes())
    known.push_back(
        fmt::format("{} ({})", trace::path_class_name(c), trace::path_class_expression(c)));
  return fmt::format("{}", fmt::join(known, ", "));
}

// What is wrong with the descriptor's counters ("" when nothing): each named, of a known kind, and
// a name declared twice declared the same way (two parts of a technique may list one counter).
std::string counter_problem(const pb_technique_descriptor& d) {
  if (d.counter_count > 0 && !d.counters) return "declares counters but gives none";
  std::map<std::string, std::pair<int, std::string>> seen;
  for (uint32_t i = 0; i < d.counter_count; ++i) {
    const pb_counter_spec& c = d.counters[i];
    if (!c.name || !*c.name) return fmt::format("declares counter {} without a name", i);
    if (c.kind < PB_COUNTER_WORK || c.kind > PB_COUNTER_RATIO)
      return fmt::format("declares counter '{}' of unknown kind {}", c.name, int(c.kind));
    auto [it, added] = seen.try_emplace(c.name, int(c.kind), c.unit ? c.unit : "");
    if (!added && it->second != std::pair<int, std::string>(int(c.kind), c.unit ? c.unit : ""))
      return fmt::format("declares counter '{}' twice, of different kinds or units", c.name);
  }
  return "";
}

// What is wrong with the descriptor's budget knobs ("" when nothing): each names an int or float
// parameter of the schema, once, with a cost that grows or falls, and a known error direction and
// scale.
std::string budget_problem(const pb_technique_descriptor& d) {
  if (d.budget_count > 0 && !d.budget) return "declares budget knobs but gives none";
  for (uint32_t i = 0; i < d.budget_count; ++i) {
    const pb_budget_knob& k = d.budget[i];
    if (!k.param || !*k.param) return fmt::format("declares budget knob {} without a parameter", i);
    const pb_param_spec* spec = nullptr;
    for (uint32_t j = 0; j < d.param_count; ++j)
      if (std::string_view(d.params[j].name) == k.param) spec = &d.params[j];
    if (!spec || (spec->type != PB_PARAM_INT && spec->type != PB_PARAM_FLOAT))
      return fmt::format(
          "declares budget knob '{}', which is no int or float parameter of its "
          "schema",
          k.param);
    for (uint32_t j = 0; j < i; ++j)
      if (std::string_view(d.budget[j].param) == k.param)
        return fmt::format("declares budget knob '{}' twice", k.param);
    if (k.cost != PB_BUDGET_GROWS && k.cost != PB_BUDGET_FALLS)
      return fmt::format("declares budget knob '{}' with a cost that neither grows nor falls",
                         k.param);
    if (k.error < PB_BUDGET_FALLS || k.error > PB_BUDGET_GROWS ||
        (k.scale != PB_SCALE_LINEAR && k.scale != PB_SCALE_LOG))
      return fmt::format("declares budget knob '{}' of unknown error direction or scale", k.param);
    if (k.scale == PB_SCALE_LOG && !(spec->min_value > 0))
      return fmt::format("declares budget knob '{}' logarithmic, but its range starts at {}",
                         k.param, spec->min_value);
  }
  return "";
}

// What each plugin API version changed for a module, so that a module of an older version is
// refused with the change it needs, not only with the two numbers.
std::string_view version_change(uint32_t version) {
  switch (version) {
    case 2:
      return "a build record follows the version";
    case 3:
      return "counters and a check of the parameters close the descriptor";
    case 4:
      return "budget knobs follow the check";
    case 5:
      return "the photon tracer's modes (TraceSettings' aaps, aaps_jitter, photon_differentials "
             "and keep_paths, PhotonBatch's texel_power) became tracer policies a technique "
             "supplies: TraceSettings' emission (an EmissionSampler) and policy (a VertexPolicy), "
             "keep_light_paths, and PhotonBatch's emitted_power (photonbench/photons.h)";
    case 6:
      return "the photon tracer computes ray differentials and footprints only for a trace that "
             "asks (TraceSettings' footprints, or a policy that shapes them)";
    default:
      return "";
  }
}

std::string changes_since(uint32_t module_version) {
  std::vector<std::string> changes;
  for (uint32_t v = module_version + 1; v <= PB_PLUGIN_API_VERSION; ++v)
    if (std::string_view change = version_change(v); !change.empty())
      changes.push_back(fmt::format("version {}: {}", v, change));
  return changes.empty() ? "" : fmt::format(" ({})", fmt::join(changes, "; "));
}

// The boundary checks, in the order the descriptor may be read: its version (the opening every
// version keeps), then its build record, then its contents. Sets plugin.descriptor when all pass;
// returns the error otherwise.
std::string check_descriptor(Plugin& plugin, const pb_technique_descriptor* descriptor) {
  if (!descriptor) return "the entry point returned no descriptor";
  const pb_build_record& host = *detail::this_build();
  if (descriptor->api_version < PB_PLUGIN_API_OLDEST_LOADED ||
      descriptor->api_version > PB_PLUGIN_API_VERSION) {
    // Version 1 descriptors had no build record; from 2 on it follows the version.
    const std::string built_with = descriptor->api_version >= 2 && descriptor->build
                                       ? fmt::format(" ({})", describe(*descriptor->build))
                                       : "";
    const std::string needed =
        descriptor->api_version < PB_PLUGIN_API_VERSION
            ? fmt::format("; what changed since version {}{}", descriptor->api_version,
                          changes_since(descriptor->api_version))
            : "";
    return fmt::format(
        "plugin {} was built for plugin API version {}{}, this photonbench has {} ({}){}; "
        "rebuild it against this photonbench's package",
        plugin.file.string(), descriptor->api_version, built_with, PB_PLUGIN_API_VERSION,
        describe(host), needed);
  }
  if (!descriptor->build) return fmt::format("plugin {} has no build record", plugin.file.string());
  if (std::string mismatch = build_mismatch(host, *descriptor->build); !mismatch.empty())
    return fmt::format(
        "plugin {} was built unlike this photonbench: {}; rebuild it against this "
        "photonbench's package",
        plugin.file.string(), mismatch);
  if (!descriptor->name || !descriptor->create || !descriptor->destroy)
    return fmt::format("plugin {} returned a descriptor without a name or factory",
                       plugin.file.string());
  if (std::string problem = counter_problem(*descriptor); !problem.empty())
    return fmt::format("plugin {} ('{}') {}", plugin.file.string(), descriptor->name, problem);
  if (std::string problem = budget_problem(*descriptor); !problem.empty())
    return fmt::format("plugin {} ('{}') {}", plugin.file.string(), descriptor->name, problem);
  // A class the references do not have would leave the technique scored on `combined` alone.
  if (!trace::reference_class_of(descriptor->path_class ? descriptor->path_class : ""))
    return fmt::format("plugin {} ('{}') declares path class '{}', which is none of: {}",
                       plugin.file.string(), descriptor->name,
                       descriptor->path_class ? descriptor->path_class : "", known_path_classes());
  plugin.descriptor = descriptor;
  return "";
}

}  // namespace

std::string build_mismatch(const pb_build_record& host, const pb_build_record& module) {
  std::vector<std::string> differences;
  const std::string sides =
      fmt::format("plugin built with {}; photonbench with {}", describe(module), describe(host));
  if (std::string_view(host.standard_library_abi) != module.standard_library_abi)
    differences.push_back(fmt::format("standard library ABI {} (photonbench: {})",
                                      module.standard_library_abi, host.standard_library_abi));
  if (host.vulkan_hpp_version != module.vulkan_hpp_version)
    differences.push_back(fmt::format("Vulkan-Hpp headers {} (photonbench: {})",
                                      module.vulkan_hpp_version, host.vulkan_hpp_version));
  // NDEBUG first: it also changes the dispatchers' sizes below, and it is the one to fix.
  if (host.assertions != module.assertions)
    differences.push_back(
        fmt::format("{} (photonbench: {}; configure the plugin with -DCMAKE_BUILD_TYPE={})",
                    assertion_text(module.assertions), assertion_text(host.assertions),
                    host.assertions ? "Debug" : "Release"));
  for (uint32_t i = 0; i < host.class_size_count; ++i) {
    const pb_class_size& want = host.class_sizes[i];
    const pb_class_size* got = nullptr;
    for (uint32_t j = 0; j < module.class_size_count; ++j)
      if (std::string_view(module.class_sizes[j].name) == want.name) got = &module.class_sizes[j];
    if (!got)
      differences.push_back(
          fmt::format("no size recorded for {} (photonbench: {} bytes)", want.name, want.bytes));
    else if (got->bytes != want.bytes)
      differences.push_back(
          fmt::format("sizeof({}) {} bytes (photonbench: {})", want.name, got->bytes, want.bytes));
  }
  if (differences.empty()) return "";
  return fmt::format("{} ({})", fmt::join(differences, "; "), sides);
}

const Plugin* PluginRegistry::find(const std::string& name) {
  if (auto it = loaded_.find(name); it != loaded_.end()) return it->second.get();
  auto file = files_.find(name);
  if (file == files_.end()) return nullptr;
  auto plugin = std::make_unique<Plugin>();
  plugin->name = name;
  plugin->file = file->second;
  // RTLD_LOCAL keeps each technique's symbols to itself; RTLD_NOW reports missing symbols here,
  // with the loader's own message, instead of crashing mid-frame.
  plugin->handle = dlopen(plugin->file.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!plugin->handle) {
    const char* error = dlerror();
    plugin->load_error = fmt::format("dlopen failed: {}", error ? error : "unknown error");
  } else {
    dlerror();
    auto entry =
        reinterpret_cast<pb_technique_entry>(dlsym(plugin->handle, PB_TECHNIQUE_ENTRY_SYMBOL));
    if (const char* error = dlerror(); error || !entry) {
      plugin->load_error =
          fmt::format("dlsym({}) failed: {}", PB_TECHNIQUE_ENTRY_SYMBOL, error ? error : "null");
    } else {
      plugin->load_error = check_descriptor(*plugin, entry(PB_PLUGIN_API_VERSION));
    }
  }
  const Plugin* result = plugin.get();
  loaded_[name] = std::move(plugin);
  return result;
}

TechniqueInstance create_technique(const pb_technique_descriptor& descriptor) {
  return TechniqueInstance(static_cast<Technique*>(descriptor.create()),
                           TechniqueDeleter{descriptor.destroy});
}

const pb_budget_knob* find_budget_knob(const pb_technique_descriptor& d, const std::string& param) {
  for (uint32_t i = 0; i < d.budget_count; ++i)
    if (param == d.budget[i].param) return &d.budget[i];
  return nullptr;
}

std::string budget_direction_text(pb_budget_direction direction) {
  switch (direction) {
    case PB_BUDGET_FALLS:
      return "falls";
    case PB_BUDGET_MIXED:
      return "mixed";
    case PB_BUDGET_GROWS:
      return "grows";
  }
  return "?";
}

std::string budget_scale_text(pb_budget_scale scale) {
  return scale == PB_SCALE_LOG ? "log" : "linear";
}

std::string counter_kind_text(pb_counter_kind kind) {
  switch (kind) {
    case PB_COUNTER_WORK:
      return "work";
    case PB_COUNTER_SIZE:
      return "size";
    case PB_COUNTER_RATIO:
      return "ratio";
  }
  return "?";
}

std::string param_type_name(const pb_param_spec& spec) {
  switch (spec.type) {
    case PB_PARAM_INT:
      return "int";
    case PB_PARAM_FLOAT:
      return "float";
    case PB_PARAM_BOOL:
      return "bool";
    case PB_PARAM_ENUM:
      return "enum";
  }
  return "?";
}

std::string param_default_text(const pb_param_spec& spec) {
  switch (spec.type) {
    case PB_PARAM_INT:
      return fmt::format("{}", int64_t(spec.default_value));
    case PB_PARAM_FLOAT:
      return fmt::format("{}", spec.default_value);
    case PB_PARAM_BOOL:
      return spec.default_value != 0 ? "true" : "false";
    case PB_PARAM_ENUM: {
      std::istringstream choices(spec.choices ? spec.choices : "");
      std::string choice;
      for (int i = 0; std::getline(choices, choice, '|'); ++i)
        if (i == int(spec.default_value)) return choice;
      return "";
    }
  }
  return "";
}

}  // namespace pb::run
