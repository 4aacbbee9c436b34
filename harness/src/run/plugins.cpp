#include "run/plugins.h"

#include <dlfcn.h>
#include <fmt/format.h>
#include <unistd.h>

#include <cmath>
#include <sstream>

#include "photonbench/error.h"

namespace pb::run {

std::filesystem::path PluginRegistry::build_plugin_dir() {
  // Next to the executable when it has a plugins/ folder (the build tree and installs), else the
  // configured build directory.
  std::error_code ec;
  auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec && std::filesystem::is_directory(exe.parent_path() / "plugins"))
    return exe.parent_path() / "plugins";
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
      const pb_technique_descriptor* descriptor = entry(PB_PLUGIN_API_VERSION);
      if (!descriptor) {
        plugin->load_error = "the entry point returned no descriptor";
      } else if (descriptor->api_version != PB_PLUGIN_API_VERSION) {
        plugin->version_error = fmt::format(
            "plugin {} was built for plugin API version {}, this photonbench has {}; rebuild it",
            plugin->file.string(), descriptor->api_version, PB_PLUGIN_API_VERSION);
      } else {
        plugin->descriptor = descriptor;
      }
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
