#include "config/config.h"

#include <fmt/format.h>

#include <algorithm>
#include <sstream>

#include "photonbench/error.h"

namespace pb::config {

namespace {

bool is_name_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
         c == '_' || c == '-';
}

}  // namespace

std::string folder_safe_name(const std::string& text) {
  std::string out;
  for (char c : text.substr(0, kMaxNameLength)) out += is_name_char(c) ? c : '-';
  if (out.empty() || out[0] == '.') out.insert(out.begin(), 'x');
  return out.substr(0, kMaxNameLength);
}

// Numeric path parts index lists; missing mapping keys are created so any key can be set, and
// validation afterwards treats the result as if it had been written in the file (YamlView says
// where it came from).
std::string apply_override(YAML::Node& root, const std::string& assignment) {
  auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw InputError(fmt::format("--set {}: expected key.path=value", quote(assignment, 80)));
  std::string path = assignment.substr(0, eq);
  // "key+=value" appends to a list (created if absent): --plugin-dir is plugin_dirs+=DIR.
  bool append = path.back() == '+';
  if (append) path.pop_back();
  auto fail = [&](const std::string& message) -> InputError {
    return InputError(fmt::format("--set {}: {}", quote(assignment, 80), message));
  };
  YAML::Node value;
  try {
    value = YAML::Load(assignment.substr(eq + 1));
  } catch (const YAML::Exception& e) {
    throw fail(fmt::format("the value is not valid YAML: {}", e.msg));
  }
  std::vector<std::string> parts;
  std::istringstream stream(path);
  for (std::string part; std::getline(stream, part, '.');) parts.push_back(part);
  if (parts.empty() || path.back() == '.' ||
      std::find(parts.begin(), parts.end(), "") != parts.end())
    throw fail("expected key.path=value, with no empty part in the path");
  std::string key_path;  // as YamlView writes it
  YAML::Node node;
  node.reset(root);
  for (size_t i = 0; i < parts.size(); ++i) {
    const std::string& part = parts[i];
    const std::string parent = fmt::format("{}", fmt::join(parts.begin(), parts.begin() + i, "."));
    bool is_index = part.find_first_not_of("0123456789") == std::string::npos;
    bool last = i + 1 == parts.size();
    if (is_index && node.IsSequence()) {
      // Compared as text first: an index of 30 digits is out of range, not an exception.
      size_t index = part.size() <= 9 ? size_t(std::stoul(part)) : ~size_t(0);
      if (index >= node.size())
        throw fail(
            fmt::format("'{}' has {} elements, no element {}", parent, node.size(), quote(part)));
      key_path += fmt::format("[{}]", index);
      if (last) {
        node[index] = value;
      } else {
        YAML::Node child = node[index];
        node.reset(child);
      }
    } else {
      if (!node.IsMap() && !node.IsNull()) throw fail(fmt::format("'{}' is not a mapping", parent));
      key_path += (key_path.empty() ? "" : ".") + quote(part, 60);
      if (last && append) {
        if (!node[part].IsDefined() || node[part].IsNull())
          node[part] = YAML::Node(YAML::NodeType::Sequence);
        if (!node[part].IsSequence())
          throw fail(fmt::format("'{}' is not a list to append to", path));
        YAML::Node list = node[part];
        key_path += fmt::format("[{}]", list.size());
        list.push_back(value);
      } else if (last) {
        node[part] = value;
      } else {
        if (!node[part].IsDefined() || node[part].IsNull())
          node[part] = YAML::Node(YAML::NodeType::Map);
        YAML::Node child = node[part];
        node.reset(child);
      }
    }
  }
  return key_path;
}

std::string stable_hash(const std::string& text) {
  uint64_t hash = 1469598103934665603ull;
  for (unsigned char c : text) {
    hash ^= c;
    hash *= 1099511628211ull;
  }
  return fmt::format("{:016x}", hash);
}

Config load_config(const std::filesystem::path& file, const std::vector<std::string>& overrides) {
  return parse_config(read_text_file(file, kMaxYamlBytes, "config file"), file, overrides);
}

Config parse_config(const std::string& text, const std::filesystem::path& file,
                    const std::vector<std::string>& overrides) {
  Config config;
  config.file = file;
  YamlView root = YamlView::parse(text, file.string());
  YAML::Node tree = root.node();
  if (tree.IsNull() || !tree.IsDefined())
    root.fail(
        "the file is empty; a config is a mapping of keys (name, resolution, frames, "
        "scenes, techniques, ...)");
  if (!tree.IsMap())
    root.fail("a config is a mapping of keys (name, resolution, frames, scenes, techniques, ...)");
  YamlSource source{file.string(), {}};
  for (const auto& assignment : overrides)
    source.overrides.push_back({apply_override(tree, assignment), assignment});
  // The --set values are checked as the file's text was: no alias bomb, no duplicate key.
  if (!overrides.empty()) check_yaml_tree(tree, file.string() + " (after --set)");
  root = YamlView(tree, std::make_shared<const YamlSource>(std::move(source)), "");

  root.allow_keys({"name", "resolution", "frames", "seed", "scenes", "techniques", "metrics",
                   "reference", "limits", "plugin_dirs", "testing"});
  config.name = folder_safe_name(file.stem().string());
  if (auto name = root.get("name")) {
    config.name = name->as_string();
    if (config.name != folder_safe_name(config.name))
      name->fail(fmt::format(
          "'{}' is not a folder name: use at most {} letters, digits, '.', '_' and '-', starting "
          "with a letter or digit (it names the run folder)",
          quote(config.name), kMaxNameLength));
  }
  if (auto resolution = root.get("resolution")) {
    if (!resolution->is_sequence() || resolution->size() != 2)
      resolution->fail("expected [width, height]");
    config.width = uint32_t((*resolution)[size_t(0)].as_int(16, 8192));
    config.height = uint32_t((*resolution)[size_t(1)].as_int(16, 8192));
  }
  if (auto frames = root.get("frames")) {
    frames->allow_keys({"warmup", "count", "metrics_every"});
    config.frames.warmup =
        uint32_t(frames->int_or("warmup", config.frames.warmup, 0, kMaxWarmupFrames));
    config.frames.count =
        uint32_t(frames->int_or("count", config.frames.count, 1, kMaxMeasuredFrames));
    config.frames.metrics_every = uint32_t(
        frames->int_or("metrics_every", config.frames.metrics_every, 0, kMaxMeasuredFrames));
  }
  config.seed = uint64_t(root.int_or("seed", 1, 0, int64_t(1) << 53));

  YamlView scenes = root["scenes"];
  if (scenes.elements().empty()) scenes.fail("at least one scene is needed");
  config.scene_dirs = {file.parent_path(), file.parent_path() / "scenes"};
  for (const YamlView& scene : scenes.elements()) {
    // A scene is a name, or {scene: NAME, params: {...}} whose parameters replace the techniques'
    // own for this scene's cells (photon radii are in scene units: Paper I's Table 2 sets them per
    // scene).
    if (scene.is_map()) scene.allow_keys({"scene", "params"});
    // (Constructed, never assigned: assigning a YAML::Node rebinds the node inside the tree.)
    const YamlView name_node = scene.is_map() ? scene["scene"] : scene;
    config.scenes.push_back({name_node.as_string(), scene, name_node});
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
        {"rel_error", "max_seconds", "samples", "max_bounces", "bounce_matched", "cache_dir"});
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
    if (!(r.rel_error > 0) && !(r.max_seconds > 0) && r.samples == 0)
      reference->fail(
          "rel_error, max_seconds and samples are all 0: no rule would stop a reference");
    r.bounce_matched = reference->bool_or("bounce_matched", r.bounce_matched);
    r.cache_dir = reference->string_or("cache_dir", r.cache_dir.string());
  }
  if (auto limits = root.get("limits")) {
    limits->allow_keys({"cell_seconds"});
    config.limits.cell_seconds =
        limits->number_or("cell_seconds", config.limits.cell_seconds, 0.1, 1e7);
  }
  if (auto dirs = root.get("plugin_dirs")) {
    for (const YamlView& d : dirs->elements()) {
      std::filesystem::path dir = d.as_string();
      if (dir.is_relative()) dir = file.parent_path() / dir;
      if (!std::filesystem::is_directory(dir))
        d.fail(fmt::format("plugin directory {} does not exist", dir.string()));
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

}  // namespace pb::config
