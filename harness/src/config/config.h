// The benchmark config: loading, --set overrides, validation against the schema (every error names
// file:line:col and key), and the expansion of sweeps into cells (scene x technique x parameters).
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "config/yaml_view.h"

namespace pb::run {
class PluginRegistry;
}

namespace pb::config {

struct FrameSettings {
  uint32_t warmup = 4;
  uint32_t count = 32;
  uint32_t metrics_every = 8;  // score every Nth measured frame (0: never)
};

// How references are rendered (trace/reference.h): a frame's render stops at the first stop rule
// reached; 0 turns a rule off, and at least one stays on. A reference block that names any of
// rel_error, max_seconds and samples uses those alone; one that names none keeps the defaults.
struct ReferenceSettings {
  double rel_error = 0.05;    // estimated relative RMS error of the mean (the default rule)
  double max_seconds = 600;   // per frame, a safety net for a target a scene cannot reach
  uint32_t samples = 0;       // iterations (camera samples per pixel); 0 or at least 2
  uint32_t max_bounces = 0;   // scattering vertices on a full path; 0: untruncated
  std::string estimator = "auto";  // auto | bdpt | pt (trace::Estimator)
  std::filesystem::path cache_dir;  // default: results/reference-cache
};

struct Limits {
  double cell_seconds = 1800;  // a cell running longer is killed and recorded failed
};

// Testing hooks: never set in real benchmarks. slow_pass makes one named pass slower by a factor, so a
// regression detector can be shown to flag it.
struct TestingHooks {
  std::string slow_pass;
  double slow_factor = 1.0;
};

struct TechniqueEntry {
  std::string technique;
  YamlView node;  // the entry itself, for error locations
};

struct Config {
  std::filesystem::path file;
  std::string name;
  uint32_t width = 640, height = 360;
  FrameSettings frames;
  uint64_t seed = 1;
  std::vector<std::pair<std::string, YamlView>> scenes;  // as written, with location
  std::vector<TechniqueEntry> techniques;
  std::vector<std::string> metrics;
  ReferenceSettings reference;
  Limits limits;
  std::vector<std::filesystem::path> plugin_dirs;
  TestingHooks testing;
  YAML::Node resolved;     // the whole config after --set overrides
  std::string canonical;   // `resolved` emitted as text: what the config hash is over
  std::string hash;        // 16 hex digits
};

// A cell: one scene, one technique, one value of every parameter.
struct Cell {
  std::string id;  // "<scene>__<technique>__<8 hex of the parameter values>": stable across runs
  std::string scene;
  std::filesystem::path scene_file;
  std::string technique;
  std::map<std::string, std::string> params;  // every schema parameter, defaults filled in
};

// Reads `file`, applies `overrides` ("key.path=value", value parsed as YAML), validates the keys the
// harness owns. Throws pb::InputError.
Config load_config(const std::filesystem::path& file, const std::vector<std::string>& overrides);

// Expands sweeps and checks each technique and parameter against its plugin's schema. Throws
// pb::InputError for an unknown technique, a plugin built for another API version, an unknown
// parameter or a value of the wrong type or range. A plugin that exists but fails to load is not an
// input error: its cells are returned with an empty parameter map, to fail when they run.
std::vector<Cell> expand_cells(const Config& config, run::PluginRegistry& plugins);

// 64-bit FNV-1a, as 16 hex digits: stable across platforms and runs (std::hash is neither).
std::string stable_hash(const std::string& text);

}  // namespace pb::config
