// Finding and loading technique plugins. Plugins load only from the build's plugin directory and
// from directories named by --plugin-dir or the config's `plugin_dirs`: never from the working
// directory.
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "photonbench/plugin.h"

namespace pb::run {

// A plugin file that was found, and what loading it gave: the descriptor, or the loader's own
// error.
struct Plugin {
  std::string name;
  std::filesystem::path file;
  const pb_technique_descriptor* descriptor = nullptr;
  // Why it did not load (dlopen / dlsym error, API version or build mismatch, unknown path
  // class): fails only this plugin's cells, with this message.
  std::string load_error;
  void* handle = nullptr;
  bool loaded() const { return descriptor != nullptr; }
};

class PluginRegistry {
 public:
  // The build's plugin directory comes first, then `extra_dirs` in order. Two plugin files of one
  // name (a --plugin-dir holding a direct.so) are pb::InputError naming both files: a technique's
  // name identifies what was measured.
  explicit PluginRegistry(const std::vector<std::filesystem::path>& extra_dirs);
  ~PluginRegistry();
  PluginRegistry(const PluginRegistry&) = delete;
  PluginRegistry& operator=(const PluginRegistry&) = delete;

  static std::filesystem::path build_plugin_dir();
  std::vector<std::string> names() const;
  const Plugin* find(const std::string& name);  // loads on first use; null when no such file

 private:
  std::vector<std::filesystem::path> dirs_;
  std::map<std::string, std::filesystem::path> files_;
  std::map<std::string, std::unique_ptr<Plugin>> loaded_;
};

// A technique made by its plugin's `create` and destroyed by its `destroy` (the plugin's own heap).
struct TechniqueDeleter {
  void (*destroy)(void*);
  void operator()(Technique* technique) const {
    if (technique) destroy(technique);
  }
};
using TechniqueInstance = std::unique_ptr<Technique, TechniqueDeleter>;
TechniqueInstance create_technique(const pb_technique_descriptor& descriptor);

// Why a module built as `module` cannot run in a host built as `host`, naming both sides of each
// difference; empty when they match (pb_build_record says what must match).
std::string build_mismatch(const pb_build_record& host, const pb_build_record& module);

// The budget knob of `d` named `param`; null when `param` is none of its budget knobs.
const pb_budget_knob* find_budget_knob(const pb_technique_descriptor& d, const std::string& param);
// A budget knob's directions and scale as words: "grows", "falls", "mixed"; "linear", "log".
std::string budget_direction_text(pb_budget_direction direction);
std::string budget_scale_text(pb_budget_scale scale);

// A counter's kind as a word: "work", "size", "ratio".
std::string counter_kind_text(pb_counter_kind kind);

// The type of a parameter spec as a word ("int", "float", "bool", "enum") and its default as text.
std::string param_type_name(const pb_param_spec& spec);
std::string param_default_text(const pb_param_spec& spec);

}  // namespace pb::run
