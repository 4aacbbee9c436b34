// The benchmark config: loading, --set overrides and validation of the keys the harness owns (every
// error names file:line:col and key). It only parses and checks: scene names, technique names and
// parameters are resolved against the scenes and plugins by plan/plan.h, which expands the sweeps.
#pragma once

#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "config/yaml_view.h"

namespace pb::config {

// A run plays at most kMaxWarmupFrames + kMaxMeasuredFrames frames, and every frame number a run
// (frames.start + frames.count), a scene's default animation or `reference --frames` names is
// below kMaxFrames.
inline constexpr uint32_t kMaxWarmupFrames = 100000;
inline constexpr uint32_t kMaxMeasuredFrames = 1000000;
inline constexpr uint32_t kMaxFrames = kMaxWarmupFrames + kMaxMeasuredFrames;

// A config's `name` names its run folder (results/<name>-<time>): letters, digits, '.', '_' and
// '-', starting with a letter or digit, at most kMaxNameLength characters.
inline constexpr size_t kMaxNameLength = 100;

// A match at a frame time takes each probe's median over at least this many measured frames.
inline constexpr uint32_t kMinMatchFrames = 5;

// The defaults of this file's structs are the config format's: config.cpp's key tables take each
// default from a default-constructed struct (`photonbench schema config` prints them).

// A cell plays frames first_frame() .. last_frame(): `warmup` frames, then `count` measured ones
// from `start` on. The warm-up frames run just before the first measured frame, so a run can
// measure frames 298.. of an animation with 4 warm-up frames (294..297) rather than 298.
struct FrameSettings {
  uint32_t warmup = 4;
  uint32_t count = 32;
  uint32_t metrics_every = 8;   // score every Nth measured frame (0: never)
  uint32_t metrics_window = 1;  // and the frames after it: this many scored in a row (flicker)
  // The first measured frame; at least `warmup`. An absent `start` is `warmup` (frames 0 .. warmup
  // - 1 warm up), so configs written before it play the frames they did.
  uint32_t start = warmup;
  uint32_t first_frame() const { return start - warmup; }
  uint32_t last_frame() const { return start + count - 1; }
  bool measured(uint32_t frame) const { return frame >= start; }
};

// How references are rendered (reference/reference.h): a frame's render stops at the first
// stop rule reached; 0 turns a rule off, and at least one stays on. A reference block that names
// any of rel_error, max_seconds and samples uses those alone; one that names none keeps the
// defaults.
struct ReferenceSettings {
  double rel_error = 0.05;         // estimated relative RMS error of the mean (the default rule)
  double max_seconds = 600;        // per frame, a safety net for a target a scene cannot reach
  uint32_t samples = 0;            // iterations (camera samples per pixel); 0 or at least 2
  uint32_t max_bounces = 0;        // scattering vertices on a full path; 0: untruncated
  std::string estimator = "auto";  // auto | bdpt | pt (trace::Estimator)
  std::string light_sampler = "power";  // power | bvh (trace::LightSelection)
  // Also score every cell of a technique with a max_bounces parameter against a reference truncated
  // like it (trace::bounces_matching_photon_technique): metrics.csv rows with reference
  // "bounce_matched" beside the "full" ones, so a study separates estimator error from truncation.
  bool bounce_matched = false;
  std::filesystem::path cache_dir = "results/reference-cache";  // shared by runs
};

struct Limits {
  double cell_seconds = 1800;  // a cell running longer is killed and recorded failed
};

// Testing hooks: never set in real benchmarks. slow_pass makes one named pass slower by a factor,
// so a regression detector can be shown to flag it.
struct TestingHooks {
  std::string slow_pass;
  double slow_factor = 1.0;
};

// `match:` (plan/match_plan.h): find, per scene and technique, the budget knob value at which the
// technique reaches one frame time or one error, by a bracketing search over measured cells. The
// knob itself is checked against the plugins by the plan; these are the harness's keys alone.
struct MatchSettings {
  enum class At { time, quality };
  YamlView node;  // the block, for errors about it
  At at = At::time;
  double frame_ms = 0;       // at: time, the target median frame time
  std::string metric;        // at: quality, an error metric of `metrics` (flip, rmse, relmse, mae)
  double value = 0;          // at: quality, the target error (the mean over the metric frames)
  double tolerance = 0.05;   // relative: |achieved - target| <= tolerance x target
  std::string knob;          // every technique's knob (empty: each technique's first budget knob)
  uint32_t max_probes = 12;  // probe cells per match, the first at the config's value
  uint32_t rounds = 3;       // re-measurements of each scene's matched cells, alternating order
};

// `video:` (cell/video_capture.h): the output of every `every`-th measured frame of the chosen
// cells saved as an image (cells/<cell>/video/), from the readback the NaN check already makes
// after the timed region, for `photonbench video` to encode; off unless the config has the block.
struct VideoSettings {
  bool enabled = false;
  uint32_t every = 1;
  std::vector<std::string> techniques;  // the cells captured by technique; empty: every cell
  // [x, y, w, h] in pixels: the window the lossless animated PNG shows; w == 0: the centre half.
  uint32_t crop[4] = {0, 0, 0, 0};
};

// The stop rules of one scene's references, where its entry names them (`reference:` in a scene
// entry): a scene whose references are cheap can be rendered to a finer error than the config's
// rule, so that its scores stand above their noise floors, without making every other scene's
// references dearer. Naming any rule uses those alone, as the config's reference block does.
struct ReferenceStopRules {
  double rel_error = 0;
  double max_seconds = 0;
  uint32_t samples = 0;
  bool operator==(const ReferenceStopRules&) const = default;
};

struct SceneEntry {
  std::string scene;   // a name under the scene folders, or a path
  YamlView node;       // the entry itself: a name, or {scene, params, reference}
  YamlView name_node;  // where the name is written, for errors about it
  std::optional<ReferenceStopRules> reference;  // replaces the config's stop rules for this scene
};

struct TechniqueEntry {
  std::string technique;
  YamlView node;  // the entry itself, for error locations
  // The config's scenes (as `scenes:` names them) this technique runs on; empty: every scene.
  std::vector<std::string> scenes;
  // With `match:`: false runs the technique at its config values, unmatched (a baseline such as
  // direct, which has no budget knob); `knob` replaces match.knob for this technique; `knob_range`
  // narrows the knob's schema range for the search ([lo, hi]; empty: the schema's).
  bool matched = true;
  std::string knob;
  std::vector<double> knob_range;
};

struct Config {
  std::filesystem::path file;
  std::string name;
  uint32_t width = 640, height = 360;
  FrameSettings frames;
  uint64_t seed = 1;
  uint32_t seeds = 1;  // the seed axis: each cell run with seeds seed .. seed + seeds - 1
  // seed_order: rounds: seed index i of every cell in round i, rounds alternately forward and
  // backward over the cells (false: each cell's seeds next to each other).
  bool seed_rounds = false;
  std::vector<SceneEntry> scenes;
  std::vector<std::filesystem::path> scene_dirs;  // where scene names are looked up
  std::vector<TechniqueEntry> techniques;
  std::vector<std::string> metrics;
  ReferenceSettings reference;
  Limits limits;
  std::vector<std::filesystem::path> plugin_dirs;
  TestingHooks testing;
  std::optional<MatchSettings> match;
  VideoSettings video;
  YAML::Node resolved;    // the whole config after --set overrides
  std::string canonical;  // `resolved` emitted as text: what the config hash is over
  std::string hash;       // 16 hex digits
};

// Reads `file`, applies `overrides` ("key.path=value", value parsed as YAML), validates the keys
// the harness owns. Scene names are checked by plan/plan.h, which resolves them. Throws
// pb::InputError.
Config load_config(const std::filesystem::path& file, const std::vector<std::string>& overrides);
// The same from the text of `file` (relative plugin_dirs are resolved against its folder).
Config parse_config(const std::string& text, const std::filesystem::path& file,
                    const std::vector<std::string>& overrides);

// The reference settings of the cells of config.scenes[scene_entry]: the config's reference
// block, its stop rules replaced by the scene entry's where it names them (kNoSceneEntry, or any
// index past the last entry: the block alone).
inline constexpr size_t kNoSceneEntry = std::numeric_limits<size_t>::max();
ReferenceSettings reference_settings(const Config& config, size_t scene_entry);

// Applies one --set "key.path=value" (or "key+=value", appending to a list) to `root`: numeric
// parts index lists, missing mapping keys are created. Returns the key path it set, as YamlView
// names it ("techniques[0].params"). Throws pb::InputError naming the assignment.
std::string apply_override(YAML::Node& root, const std::string& assignment);

// `text` as a folder name: every character outside [A-Za-z0-9._-] becomes '-', at most
// kMaxNameLength characters, never empty or starting with '.'.
std::string folder_safe_name(const std::string& text);

// 64-bit FNV-1a, as 16 hex digits: stable across platforms and runs (std::hash is neither).
std::string stable_hash(const std::string& text);

}  // namespace pb::config
