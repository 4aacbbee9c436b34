#include "config/config.h"

#include <fmt/format.h>

#include <algorithm>
#include <regex>
#include <sstream>

#include "config/key_table.h"
#include "config/reference_rules.h"
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

namespace {

using nlohmann::json;

// What folder_safe_name leaves as it is: at most kMaxNameLength of [A-Za-z0-9._-], not starting
// with '.'.
const std::string kNamePattern =
    fmt::format("^[A-Za-z0-9_-][A-Za-z0-9._-]{{0,{}}}$", kMaxNameLength - 1);

// The config format, one table per mapping (key_table.h): the reader below takes every key name,
// range and default from these rows, and `photonbench schema config` prints them.
// Each row's default is its struct's (config.h), written once there.
const FrameSettings kFrameDefaults;
const ReferenceSettings kReferenceDefaults;
const Limits kLimitsDefaults;
const TestingHooks kTestingDefaults;
const MatchSettings kMatchDefaults{YamlView(YAML::Node(), nullptr, "")};  // no block: no node
const Config kConfigDefaults;

const KeyTable kFramesTable{
    "config.frames",
    "How many frames each cell plays and scores.",
    {{"warmup", integer_type(0, kMaxWarmupFrames), false, kFrameDefaults.warmup,
      "frames played before timing starts (not recorded), just before `start`"},
     {"count", integer_type(1, kMaxMeasuredFrames), false, kFrameDefaults.count, "measured frames"},
     {"start", integer_type(0, kMaxFrames - 1), false, nullptr,
      "the first measured frame (default: warmup); the warm-up frames are start - warmup .. "
      "start - 1, and start + count is at most " +
          std::to_string(kMaxFrames)},
     {"metrics_every", integer_type(0, kMaxMeasuredFrames), false, kFrameDefaults.metrics_every,
      "score every Nth measured frame against its reference (0: never)"},
     {"metrics_window", integer_type(1, kMaxMeasuredFrames), false, kFrameDefaults.metrics_window,
      "frames scored in a row from each of those: 2 or more also measures flicker, which "
      "compares consecutive frames only"}}};

const KeyTable kReferenceTable{
    "config.reference",
    "How references are rendered. A frame's render stops at the first stop rule reached (0 "
    "turns a rule off); naming any of rel_error, max_seconds and samples uses those alone.",
    {{"rel_error", number_type(0, 1), false, kReferenceDefaults.rel_error,
      "stop at this estimated relative RMS error of the mean"},
     {"max_seconds", number_type(0, 1e7), false, kReferenceDefaults.max_seconds,
      "stop after this many seconds per frame"},
     {"samples", integer_type(0, 1 << 24), false, kReferenceDefaults.samples,
      "stop after this many iterations (0: off, else at least 2)"},
     {"max_bounces", integer_type(0, 64), false, kReferenceDefaults.max_bounces,
      "scattering vertices on a full path (0: untruncated)"},
     {"estimator", choice_type(estimator_names()), false, kReferenceDefaults.estimator,
      "the unbiased estimator: bidirectional path tracing, path tracing, or a pilot's choice"},
     {"light_sampler", choice_type(light_sampler_names()), false, kReferenceDefaults.light_sampler,
      "path tracing's next-event light choice: by power alone, or by the light BVH's walk from "
      "the shading point (fewer samples to an error, slower per sample)"},
     {"bounce_matched", boolean_type(), false, kReferenceDefaults.bounce_matched,
      "also score techniques with a max_bounces parameter against a reference truncated like "
      "them"},
     {"cache_dir", string_type(), false, kReferenceDefaults.cache_dir.string(),
      "where rendered references are kept (shared by runs)"}}};

const KeyTable kLimitsTable{
    "config.limits",
    "Limits on one cell.",
    {{"cell_seconds", number_type(0.1, 1e7), false, kLimitsDefaults.cell_seconds,
      "a cell running longer is killed and recorded failed"}}};

const KeyTable kTestingTable{"config.testing",
                             "Testing hooks: never set in real benchmarks.",
                             {{"slow_pass", string_type(), false, kTestingDefaults.slow_pass,
                               "a pass made slower, to show a regression flagged"},
                              {"slow_factor", number_type(1, 100), false,
                               kTestingDefaults.slow_factor, "how much slower slow_pass runs"}}};

// The parameters of techniques: what the loaded plugins declare (plan/plan.cpp checks them), so
// `photonbench schema` replaces these two definitions with the plugins' parameter schemas.
const KeyTable kSceneParamsTable{
    "config.scene_params",
    "parameters replacing (or sweeping) those of the same name of every technique of the config, "
    "for this scene's cells",
    {}};
const KeyTable kTechniqueTable{
    "config.technique",
    "A technique plugin and its parameters; a list of values sweeps a parameter.",
    {{"technique", string_type(), true, nullptr, "the plugin's name (photonbench list)"},
     {"params", table_type(kSceneParamsTable), false, nullptr,
      "parameter values, each one value or a list to sweep"},
     {"scenes", list_type(string_type(), 1, true), false, nullptr,
      "only these of the config's scenes (as `scenes` names them; default: every scene), for a "
      "technique whose mechanism shows only on some"},
     {"match", boolean_type(), false, true,
      "with the config's `match`: false runs this technique at its config values, unmatched (a "
      "baseline without a budget knob)"},
     {"knob", string_type(), false, nullptr,
      "with `match`: the budget knob searched for this technique (default: match.knob, else the "
      "technique's first budget knob)"},
     {"knob_range", tuple_type({number_type(-1e300, 1e300), number_type(-1e300, 1e300)}), false,
      nullptr, "with `match`: [lo, hi], the part of the knob's range the search may probe"}}};

// The comparison papers make by hand: plan/match_plan.h.
const KeyTable kMatchTable{
    "config.match",
    "Equal time or equal quality: per scene and technique, the budget knob value that reaches one "
    "frame time (at: time) or one error (at: quality), found by a bracketing search over measured "
    "probe cells, each a cell of the run.",
    {{"at", choice_type({"time", "quality"}), true, nullptr,
      "time: a median frame time (frame_ms); quality: an error (metric, value)"},
     {"frame_ms", number_type(1e-3, 1e7), false, nullptr,
      "at: time, the target median frame time in ms (the whole timed region of a frame)"},
     {"metric", choice_type({"flip", "rmse", "relmse", "mae"}), false, nullptr,
      "at: quality, the error metric (of `metrics`) on the combined image"},
     {"value", number_type(0, 1e30), false, nullptr,
      "at: quality, the target mean error; at least 4x the reference's noise floor"},
     {"tolerance", number_type(1e-4, 1), false, kMatchDefaults.tolerance,
      "relative: a probe within tolerance x target of the target matches"},
     {"knob", string_type(), false, nullptr,
      "the budget knob searched for every technique (default: each technique's first)"},
     {"max_probes", integer_type(1, 64), false, kMatchDefaults.max_probes,
      "probe cells per scene and technique at most"},
     {"rounds", integer_type(0, 50), false, kMatchDefaults.rounds,
      "re-measurements of each scene's found cells, in alternating order, for the achieved "
      "times"}}};

const VideoSettings kVideoDefaults;

const KeyTable kVideoTable{
    "config.video",
    "Videos of the run: every `every`-th measured frame of the chosen cells saved as an image "
    "after the timed region (timings do not move); `photonbench video RUN_DIR` (or `report`) "
    "encodes them with ffmpeg.",
    {{"every", integer_type(1, kMaxMeasuredFrames), false, kVideoDefaults.every,
      "save every Nth measured frame (1: all of them)"},
     {"cells", any_of_type({choice_type({"all"}), list_type(string_type(), 1, false)}), false,
      "all", "all, or a list of the config's technique names whose cells are captured"},
     {"crop",
      tuple_type({integer_type(0, 8191), integer_type(0, 8191), integer_type(1, 8192),
                  integer_type(1, 8192)}),
      false, nullptr,
      "[x, y, w, h] in pixels: the window of the lossless animated PNG (default: the centre "
      "half)"}}};

// The video block: technique names the config lists, a crop inside the image.
VideoSettings read_video(const YamlView& block, const Config& config) {
  kVideoTable.allow(block);
  VideoSettings video;
  video.enabled = true;
  video.every = uint32_t(kVideoTable.integer(block, "every"));
  if (auto cells = block.get("cells")) {
    if (cells->is_sequence()) {
      for (const YamlView& name : cells->elements()) {
        const std::string technique = name.as_string();
        const bool listed =
            std::any_of(config.techniques.begin(), config.techniques.end(),
                        [&](const TechniqueEntry& t) { return t.technique == technique; });
        if (!listed)
          name.fail(
              fmt::format("'{}' is not a technique of this config's `techniques`", technique));
        video.techniques.push_back(technique);
      }
    } else if (cells->as_string() != "all") {
      cells->fail("expected all, or a list of the config's technique names");
    }
  }
  if (auto crop = block.get("crop")) {
    const Key& key = kVideoTable.key("crop");
    if (!crop->is_sequence() || crop->size() != 4) crop->fail("expected [x, y, w, h]");
    for (size_t i = 0; i < 4; ++i) video.crop[i] = uint32_t(key.type.parts[i].integer((*crop)[i]));
    if (video.crop[0] + video.crop[2] > config.width ||
        video.crop[1] + video.crop[3] > config.height)
      crop->fail(fmt::format("the window {}x{} at ({}, {}) is not inside the {}x{} image",
                             video.crop[2], video.crop[3], video.crop[0], video.crop[1],
                             config.width, config.height));
  }
  return video;
}

const KeyTable kSceneReferenceTable{
    "config.scene_reference",
    "The stop rules of this scene's references, replacing the config's reference stop rules "
    "(naming any uses those alone); the reference block's other keys hold for every scene.",
    {{"rel_error", number_type(0, 1), false, 0, "stop at this estimated relative RMS error"},
     {"max_seconds", number_type(0, 1e7), false, 0, "stop after this many seconds per frame"},
     {"samples", integer_type(0, 1 << 24), false, 0,
      "stop after this many iterations (0: off, else at least 2)"}}};

const KeyTable kSceneEntryTable{
    "config.scene",
    "A scene with parameters of its own.",
    {{"scene", string_type(), true, nullptr, "a scene name (photonbench list) or a path"},
     {"params", table_type(kSceneParamsTable), false, nullptr,
      "technique parameters for this scene's cells (photon radii are in scene units)"},
     {"reference", table_type(kSceneReferenceTable), false, nullptr,
      "stop rules of this scene's references: a cheap scene rendered finer than the others"}}};

const KeyTable kConfigTable{
    "config",
    "A photonbench benchmark config: scenes x techniques x parameter sweeps.",
    {{"name", string_type(kNamePattern), false, nullptr,
      "names the run folder: letters, digits, '.', '_' and '-' (default: the file's name)"},
     {"resolution", tuple_type({integer_type(16, 8192), integer_type(16, 8192)}), false,
      json::array({kConfigDefaults.width, kConfigDefaults.height}), "[width, height] in pixels"},
     {"frames", table_type(kFramesTable), false, nullptr, ""},
     {"seed", integer_type(0, int64_t(1) << 53), false, kConfigDefaults.seed,
      "seeds the references (and, with seeds > 1, the photons of every cell but the first seed's)"},
     {"seeds", integer_type(1, 1000), false, kConfigDefaults.seeds,
      "K > 1: every cell runs K times, with seeds seed, seed + 1, ..., seed + K - 1"},
     {"seed_order", choice_type({"grouped", "rounds"}), false,
      kConfigDefaults.seed_rounds ? "rounds" : "grouped",
      "with seeds > 1: grouped runs each cell's K seeds next to each other; rounds runs K rounds "
      "over every cell, alternately forward and backward, so that a shared machine's drift falls "
      "on every cell alike (time ratios between cells)"},
     {"scenes", list_type(any_of_type({string_type(), table_type(kSceneEntryTable)}), 1, true),
      true, nullptr, "scene names or paths, or {scene, params}"},
     {"techniques", list_type(table_type(kTechniqueTable), 1, false), true, nullptr, ""},
     {"metrics", list_type(choice_type({"flip", "ssim", "psnr", "rmse", "mae", "relmse"}), 0, true),
      false, json::array({"flip", "ssim", "psnr", "rmse", "relmse"}),
      "the image metrics scored and written (metrics.csv, cell.json), each with its noise floor; "
      "the others are left out; [] scores nothing and renders no reference (the metric frames' "
      "images are still written)"},
     {"reference", table_type(kReferenceTable), false, nullptr, ""},
     {"limits", table_type(kLimitsTable), false, nullptr, ""},
     {"plugin_dirs", list_type(string_type(), 0, true), false, nullptr,
      "more folders to load technique plugins from (relative to the config's folder)"},
     {"testing", table_type(kTestingTable), false, nullptr, ""},
     {"match", table_type(kMatchTable), false, nullptr, ""},
     {"video", table_type(kVideoTable), false, nullptr, ""}}};

// The mapping at `key`, or an empty one when it is absent: its keys take the table's defaults
// (and no error can arise in it, so it needs no position).
YamlView section(const YamlView& root, std::string_view key) {
  if (auto found = root.get(key)) return *found;
  return YamlView::parse("", root.source());
}

// The match block: each mode's own keys present, the other's absent; a quality metric the run
// scores (with its floor), at metric frames; a time over enough measured frames for a median.
MatchSettings read_match(const YamlView& block, const Config& config) {
  kMatchTable.allow(block);
  MatchSettings m{block};
  m.at = kMatchTable.string(block, "at") == "time" ? MatchSettings::At::time
                                                   : MatchSettings::At::quality;
  const char* mode = m.at == MatchSettings::At::time ? "time" : "quality";
  const std::vector<std::string> own = m.at == MatchSettings::At::time
                                           ? std::vector<std::string>{"frame_ms"}
                                           : std::vector<std::string>{"metric", "value"};
  const std::vector<std::string> other = m.at == MatchSettings::At::time
                                             ? std::vector<std::string>{"metric", "value"}
                                             : std::vector<std::string>{"frame_ms"};
  for (const std::string& key : own)
    if (!block.has(key)) block.fail(fmt::format("at: {} needs '{}'", mode, key));
  for (const std::string& key : other)
    if (auto node = block.get(key))
      node->fail(fmt::format("'{}' is not a key of at: {}", key, mode));
  if (m.at == MatchSettings::At::time) {
    m.frame_ms = kMatchTable.number(block, "frame_ms");
    // A probe's time is the median of its measured frames: with fewer than 5, one slow frame moves
    // it.
    if (config.frames.count < kMinMatchFrames)
      block["at"].fail(fmt::format(
          "at: time takes each probe's median frame time, over at least {} measured frames; "
          "frames.count is {}",
          kMinMatchFrames, config.frames.count));
  } else {
    m.metric = kMatchTable.string(block, "metric");
    m.value = kMatchTable.number(block, "value");
    if (std::find(config.metrics.begin(), config.metrics.end(), m.metric) == config.metrics.end())
      block["metric"].fail(fmt::format("'{}' is not scored by this run (metrics: {})", m.metric,
                                       fmt::join(config.metrics, ", ")));
    if (config.frames.metrics_every == 0)
      block["at"].fail("at: quality needs scored frames; frames.metrics_every is 0");
    if (!(m.value > 0)) block["value"].fail("a target error above 0");
  }
  m.tolerance = kMatchTable.number(block, "tolerance");
  if (auto knob = block.get("knob")) m.knob = knob->as_string();
  m.max_probes = uint32_t(kMatchTable.integer(block, "max_probes"));
  m.rounds = uint32_t(kMatchTable.integer(block, "rounds"));
  return m;
}

// The stop rules a reference block names (rel_error, max_seconds, samples), checked; none when it
// names none. Naming any replaces every rule: {samples: 1024} means exactly 1024.
std::optional<ReferenceStopRules> named_stop_rules(const KeyTable& table, const YamlView& block) {
  if (!block.has("rel_error") && !block.has("max_seconds") && !block.has("samples"))
    return std::nullopt;
  ReferenceStopRules rules;
  rules.rel_error = table.number_or(block, "rel_error", 0);
  rules.max_seconds = table.number_or(block, "max_seconds", 0);
  rules.samples = block.has("samples") ? uint32_t(table.integer(block, "samples")) : 0;
  if (auto problem = stop_rule_problem(rules.rel_error, rules.max_seconds, rules.samples))
    (problem->key.empty() ? block : block[problem->key]).fail(problem->message);
  return rules;
}

void set_stop_rules(ReferenceSettings& settings, const ReferenceStopRules& rules) {
  settings.rel_error = rules.rel_error;
  settings.max_seconds = rules.max_seconds;
  settings.samples = rules.samples;
}

// Each scene entry's `reference:` stop rules (kSceneReferenceTable). The plan checks that entries
// of one scene file agree (plan/plan.cpp: the cache holds one reference per scene and frame).
void read_scene_stop_rules(Config& config) {
  for (SceneEntry& entry : config.scenes) {
    if (!entry.node.is_map()) continue;
    auto block = entry.node.get("reference");
    if (!block) continue;
    kSceneReferenceTable.allow(*block);
    entry.reference = named_stop_rules(kSceneReferenceTable, *block);
    if (!entry.reference) block->fail("names no stop rule (rel_error, max_seconds or samples)");
  }
}

}  // namespace

const KeyTable& config_table() { return kConfigTable; }

Config load_config(const std::filesystem::path& file, const std::vector<std::string>& overrides) {
  return parse_config(read_text_file(file, kMaxYamlBytes, "config file"), file, overrides);
}

ReferenceSettings reference_settings(const Config& config, size_t scene_entry) {
  ReferenceSettings settings = config.reference;
  if (scene_entry < config.scenes.size())
    if (const auto& rules = config.scenes[scene_entry].reference) set_stop_rules(settings, *rules);
  return settings;
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

  kConfigTable.allow(root);
  config.name = folder_safe_name(file.stem().string());
  if (auto name = root.get("name")) {
    config.name = name->as_string();
    if (!std::regex_match(config.name, std::regex(kNamePattern)))
      name->fail(fmt::format(
          "'{}' is not a folder name: use at most {} letters, digits, '.', '_' and '-', starting "
          "with a letter or digit (it names the run folder)",
          quote(config.name), kMaxNameLength));
  }
  const Key& resolution_key = kConfigTable.key("resolution");
  config.width = resolution_key.default_value[0].get<uint32_t>();
  config.height = resolution_key.default_value[1].get<uint32_t>();
  if (auto resolution = root.get("resolution")) {
    if (!resolution->is_sequence() || resolution->size() != 2)
      resolution->fail("expected [width, height]");
    config.width = uint32_t(resolution_key.type.parts[0].integer((*resolution)[size_t(0)]));
    config.height = uint32_t(resolution_key.type.parts[1].integer((*resolution)[size_t(1)]));
  }
  const YamlView frames = section(root, "frames");
  kFramesTable.allow(frames);
  config.frames.warmup = uint32_t(kFramesTable.integer(frames, "warmup"));
  config.frames.count = uint32_t(kFramesTable.integer(frames, "count"));
  config.frames.metrics_every = uint32_t(kFramesTable.integer(frames, "metrics_every"));
  config.frames.metrics_window = uint32_t(kFramesTable.integer(frames, "metrics_window"));
  config.frames.start = config.frames.warmup;
  if (auto start = frames.get("start")) {
    const Key& start_key = kFramesTable.key("start");
    config.frames.start = uint32_t(start_key.type.integer(*start));
    if (config.frames.start < config.frames.warmup)
      start->fail(fmt::format(
          "the first measured frame {} leaves no room for the {} warm-up frames, which run just "
          "before it (frames start - warmup .. start - 1): start at {} or later, or warm up less",
          config.frames.start, config.frames.warmup, config.frames.warmup));
  }
  if (uint64_t(config.frames.start) + config.frames.count > kMaxFrames)
    (frames.has("start") ? frames["start"] : frames["count"])
        .fail(fmt::format("frames {} .. {} (start + count) go past the last frame a run may play, "
                          "{}",
                          config.frames.start,
                          uint64_t(config.frames.start) + config.frames.count - 1, kMaxFrames - 1));
  config.seed = uint64_t(kConfigTable.integer(root, "seed"));
  config.seeds = uint32_t(kConfigTable.integer(root, "seeds"));
  config.seed_rounds = kConfigTable.string(root, "seed_order") == "rounds";

  YamlView scenes = root["scenes"];
  if (scenes.elements().empty()) scenes.fail("at least one scene is needed");
  config.scene_dirs = {file.parent_path(), file.parent_path() / "scenes"};
  for (const YamlView& scene : scenes.elements()) {
    // A scene is a name, or {scene: NAME, params: {...}} whose parameters replace the techniques'
    // own for this scene's cells (photon radii are in scene units: Paper I's Table 2 sets them per
    // scene).
    if (scene.is_map()) kSceneEntryTable.allow(scene);
    // (Constructed, never assigned: assigning a YAML::Node rebinds the node inside the tree.)
    const YamlView name_node = scene.is_map() ? scene["scene"] : scene;
    config.scenes.push_back({name_node.as_string(), scene, name_node, std::nullopt});
  }

  YamlView techniques = root["techniques"];
  if (!techniques.is_sequence() || techniques.size() == 0)
    techniques.fail("expected a list of {technique: NAME, params: {...}}");
  for (const YamlView& entry : techniques.elements()) {
    kTechniqueTable.allow(entry);
    TechniqueEntry technique{entry["technique"].as_string(), entry, {}};
    if (auto only = entry.get("scenes")) {
      for (const YamlView& name : only->elements()) {
        std::string scene = name.as_string();
        auto listed = std::find_if(config.scenes.begin(), config.scenes.end(),
                                   [&](const SceneEntry& s) { return s.scene == scene; });
        if (listed == config.scenes.end())
          name.fail(
              fmt::format("technique '{}' names scene '{}', which the config's `scenes` "
                          "does not list",
                          technique.technique, scene));
        technique.scenes.push_back(scene);
      }
    }
    technique.matched = kTechniqueTable.boolean(entry, "match");
    if (auto knob = entry.get("knob")) technique.knob = knob->as_string();
    if (auto range = entry.get("knob_range")) {
      const Key& key = kTechniqueTable.key("knob_range");
      if (!range->is_sequence() || range->size() != 2) range->fail("expected [lo, hi]");
      for (size_t i = 0; i < 2; ++i)
        technique.knob_range.push_back(key.type.parts[i].number((*range)[i]));
      if (!(technique.knob_range[0] < technique.knob_range[1]))
        range->fail(fmt::format("lo {} is not below hi {}", technique.knob_range[0],
                                technique.knob_range[1]));
    }
    config.techniques.push_back(std::move(technique));
  }

  const Key& metrics_key = kConfigTable.key("metrics");
  config.metrics = metrics_key.default_value.get<std::vector<std::string>>();
  if (auto metrics = root.get("metrics")) {
    config.metrics.clear();
    for (const YamlView& m : metrics->elements())
      config.metrics.push_back(metrics_key.type.parts[0].choice(m));
  }
  {
    const YamlView reference = section(root, "reference");
    kReferenceTable.allow(reference);
    ReferenceSettings& r = config.reference;
    if (auto rules = named_stop_rules(kReferenceTable, reference)) {
      set_stop_rules(r, *rules);
    } else {  // the defaults
      r.rel_error = kReferenceTable.number(reference, "rel_error");
      r.max_seconds = kReferenceTable.number(reference, "max_seconds");
      r.samples = uint32_t(kReferenceTable.integer(reference, "samples"));
    }
    r.max_bounces = uint32_t(kReferenceTable.integer(reference, "max_bounces"));
    r.estimator = kReferenceTable.string(reference, "estimator");
    r.light_sampler = kReferenceTable.string(reference, "light_sampler");
    r.bounce_matched = kReferenceTable.boolean(reference, "bounce_matched");
    r.cache_dir = kReferenceTable.string(reference, "cache_dir");
  }
  read_scene_stop_rules(config);
  const YamlView limits = section(root, "limits");
  kLimitsTable.allow(limits);
  config.limits.cell_seconds = kLimitsTable.number(limits, "cell_seconds");
  if (auto dirs = root.get("plugin_dirs")) {
    for (const YamlView& d : dirs->elements()) {
      std::filesystem::path dir = d.as_string();
      if (dir.is_relative()) dir = file.parent_path() / dir;
      if (!std::filesystem::is_directory(dir))
        d.fail(fmt::format("plugin directory {} does not exist", dir.string()));
      config.plugin_dirs.push_back(dir);
    }
  }
  const YamlView testing = section(root, "testing");
  kTestingTable.allow(testing);
  config.testing.slow_pass = kTestingTable.string(testing, "slow_pass");
  config.testing.slow_factor = kTestingTable.number(testing, "slow_factor");

  if (auto match = root.get("match")) config.match = read_match(*match, config);
  if (auto video = root.get("video")) config.video = read_video(*video, config);
  for (const TechniqueEntry& t : config.techniques)
    if (!config.match)
      for (const char* key : {"match", "knob", "knob_range"})
        if (auto node = t.node.get(key))
          node->fail(fmt::format("'{}' of a technique needs the config's `match` block", key));

  config.resolved = tree;
  YAML::Emitter emitter;
  emitter << tree;
  config.canonical = emitter.c_str();
  config.hash = stable_hash(config.canonical);
  return config;
}

}  // namespace pb::config
