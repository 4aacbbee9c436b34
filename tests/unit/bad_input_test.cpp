// Bad configs, --set values and scene files (and the OBJ/MTL files they name) never crash, hang or
// lie: each is pb::InputError (the executable's exit 2) with a message naming the file, the line
// and the key, or the --set that set it; nothing is run or written before the input is valid.
// Driven through the calls `validate` and `run` make (plan_run, plan_matches, run_benchmark), one
// table row per kind of bad input; tests/e2e/config_errors.sh keeps one run of the executable per
// exit code.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <regex>
#include <string>
#include <vector>

#include "photonbench/error.h"
#include "plan/match_plan.h"
#include "plan/plan.h"
#include "run/runner.h"
#include "scene/scene.h"

namespace pb::run {
namespace bad_input_test {

namespace fs = std::filesystem;

const std::string kTestPlugins = PB_BINARY_DIR "/test-plugins";
// The build's technique plugins: the executable finds them beside itself, the test program (in
// build/tests/) is told.
const std::string kBuildPlugins = "plugin_dirs+=" PB_BINARY_DIR "/plugins";

// A scratch folder of this test process, removed afterwards.
class Scratch {
 public:
  Scratch() : dir_(fs::temp_directory_path() / ("pb_bad_input_" + std::to_string(::getpid()))) {
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  ~Scratch() { fs::remove_all(dir_); }
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;

  const fs::path& dir() const { return dir_; }
  // Writes `text` to DIR/name with every "$WORK" replaced by the folder; returns the file.
  fs::path write(const std::string& name, const std::string& text) const {
    fs::path file = dir_ / name;
    std::ofstream(file) << expand(text);
    return file;
  }
  std::string expand(std::string text) const {
    for (size_t at; (at = text.find("$WORK")) != std::string::npos;)
      text.replace(at, 5, dir_.string());
    return text;
  }

 private:
  fs::path dir_;
};

// What `photonbench validate CONFIG --set ...` decides: exit 2 with the error's message when the
// input is bad, 1 when it is valid but some cell's plugin does not load, else 0; and the plan.
struct Validation {
  int exit_code = 0;
  std::string message;
  size_t cells = 0, will_fail = 0;
  std::vector<Cell> cell_list;
};

Validation validate(const fs::path& config, const std::vector<std::string>& sets = {}) {
  Validation v;
  try {
    std::vector<std::string> overrides = {kBuildPlugins};
    overrides.insert(overrides.end(), sets.begin(), sets.end());
    const RunPlan plan = plan_run(config, overrides);
    plan_matches(plan);
    v.cells = plan.cells.size();
    v.cell_list = plan.cells;
    for (const Cell& cell : plan.cells) {
      const Plugin* plugin = plan.plugins->find(cell.technique);
      v.will_fail += plugin && !plugin->loaded();
    }
    v.exit_code = v.will_fail ? 1 : 0;
  } catch (const InputError& e) {
    v.exit_code = 2;
    v.message = e.what();
  }
  return v;
}

// `photonbench run CONFIG --out OUT --set ...`: the message of the InputError it throws before
// running anything, or "(ran)".
std::string run_error(const fs::path& config, const fs::path& out,
                      const std::vector<std::string>& sets = {}) {
  RunOptions options;
  options.config_file = config;
  options.out_dir = out;
  options.overrides = {kBuildPlugins};
  options.overrides.insert(options.overrides.end(), sets.begin(), sets.end());
  try {
    run_benchmark(options);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(ran)";
}

// The config of the config-key rows: one direct cell on cornell-box, nothing scored.
std::string base_config(const std::string& extra = "") {
  return "name: t\n"
         "resolution: [64, 36]\n"
         "frames: {warmup: 0, count: 2, metrics_every: 0}\n"
         "scenes: [cornell-box]\n"
         "techniques:\n"
         "  - technique: direct\n" +
         extra;
}

// `text` with the first `from` replaced by `to` (as the shell's ${base/from/to} did).
std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  if (at == std::string::npos) throw std::logic_error("no '" + from + "' in the text");
  return text.replace(at, from.size(), to);
}

// The config of the --set and scene rows: one small direct cell, plus `lines` (from line 6 on).
std::string probe_config(const std::string& lines) {
  return "name: t\n"
         "resolution: [64, 36]\n"
         "frames: {warmup: 0, count: 1, metrics_every: 0}\n"
         "techniques:\n"
         "  - technique: direct\n" +
         lines;
}

// The probe scene: a camera (line 3), one light (line 5) and one object (line 9), each replaceable,
// and an extra top-level line (line 2).
struct SceneLines {
  std::string camera = "camera: {position: [0, 1, 3], target: [0, 1, 0], fov_deg: 40}";
  std::string light = "  - {type: point, position: [0, 2, 0], intensity: 1}";
  std::string object = "  - {shape: {type: box}, material: white}";
  std::string extra = "";
};
std::string probe_scene(const SceneLines& s) {
  return "purpose: probe scene for the bad-input tests\n" + s.extra + "\n" + s.camera +
         "\nlights:\n" + s.light + "\nmaterials:\n  white: {type: diffuse}\nobjects:\n" + s.object +
         "\n";
}

// One kind of bad input: the files it writes into the scratch folder ("$WORK" is the folder), the
// config (config.yaml unless named), the --set values, and what the message must (and must not)
// match (ECMAScript regular expressions, searched).
struct BadInput {
  std::string name;
  std::vector<std::pair<std::string, std::string>> files;
  std::string config;  // the file validated, relative to the folder
  std::vector<std::string> sets;
  std::string message;
  std::string not_message = "";
  void (*prepare)(const fs::path& dir) = nullptr;  // files the table cannot write as text
  bool short_message = false;  // the row gives a long value: the message must stay short
};

// The row's name in test names and failures (not its bytes).
void PrintTo(const BadInput& row, std::ostream* out) { *out << row.name; }

BadInput config_row(std::string name, std::string config, std::string message) {
  return {std::move(name), {{"bad.yaml", std::move(config)}}, "bad.yaml", {}, std::move(message)};
}
BadInput set_row(std::string name, std::vector<std::string> sets, std::string message) {
  return {std::move(name),
          {{"config.yaml", probe_config("scenes: [cornell-box]\n")}},
          "config.yaml",
          std::move(sets),
          std::move(message)};
}
BadInput scene_row(std::string name, SceneLines scene, std::string message,
                   std::string not_message = "") {
  return {
      std::move(name),
      {{"s.yaml", probe_scene(scene)}, {"config.yaml", probe_config("scenes: [$WORK/s.yaml]\n")}},
      "config.yaml",
      {},
      std::move(message),
      std::move(not_message)};
}
// A scene with one OBJ object, m.obj, whose materials are m.mtl.
BadInput obj_row(std::string name, std::string obj, std::string mtl, std::string message) {
  SceneLines scene;
  scene.object = "  - {shape: {type: obj, file: m.obj}}";
  BadInput row = scene_row(std::move(name), scene, std::move(message));
  row.files.push_back({"m.obj", std::move(obj)});
  row.files.push_back({"m.mtl", std::move(mtl)});
  return row;
}
SceneLines with_camera(std::string camera, std::string extra = "") {
  SceneLines s;
  s.camera = std::move(camera);
  s.extra = std::move(extra);
  return s;
}
SceneLines with_light(std::string light) {
  SceneLines s;
  s.light = std::move(light);
  return s;
}
SceneLines with_object(std::string object) {
  SceneLines s;
  s.object = std::move(object);
  return s;
}

// Bytes that are no YAML (a fixed seed: the same bytes every run).
void write_binary(const fs::path& file, size_t size) {
  std::mt19937 bits(7);
  std::string bytes(size, '\0');
  for (char& c : bytes) c = char(bits() & 0xff);
  std::ofstream(file, std::ios::binary) << bytes;
}

// A camera that reaches its target at t = 1 s (frame 30) of its default animation.
const char* kLateCamera =
    "camera: {position: {keys: [[0, [0, 1, 3]], [1, [0, 1, 0]], [2, [0, 1, 3]]]}, target: [0, 1, "
    "0], fov_deg: 40}";
const char* kTriangle = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n";

std::string alias_bomb() {
  std::string text = probe_config("scenes: [cornell-box]\n");
  text += "a0: &a0 [x, x, x, x, x, x, x, x, x, x]\n";
  for (int i = 1; i <= 8; ++i) {
    const std::string p = "*a" + std::to_string(i - 1);
    text += "a" + std::to_string(i) + ": &a" + std::to_string(i) + " [" + p;
    for (int k = 1; k < 10; ++k) text += ", " + p;
    text += "]\n";
  }
  return text;
}

std::string joined_range(double first, double step, int count) {
  std::string out;
  for (int i = 0; i < count; ++i) {
    char value[32];
    std::snprintf(value, sizeof value, "%g", first + step * i);
    out += (i ? "," : "") + std::string(value);
  }
  return out;
}
// 100 values of shadow_map_size; of shadow_bias (or shadow_normal_offset).
const std::string kSizes = joined_range(16, 1, 100);
const std::string kSmall = joined_range(0.001, 0.001, 100);

std::vector<BadInput> bad_inputs() {
  std::vector<BadInput> rows = {
      // Config keys: file:line:col, the key, a suggestion.
      config_row("YamlSyntax", base_config("  - technique: [direct\n"),
                 "bad.yaml:[0-9]+:[0-9]+: YAML syntax error"),
      config_row("UnknownTopLevelKey", base_config("frame: {count: 3}\n"),
                 "bad.yaml:7:1: frame: unknown key; did you mean 'frames'"),
      config_row("WrongType", replaced(base_config(), "count: 2", "count: many"),
                 "bad.yaml:3:[0-9]+: frames.count: expected a number, got 'many'"),
      config_row("OutOfRange", replaced(base_config(), "[64, 36]", "[64, 100000]"),
                 "bad.yaml:2:[0-9]+: resolution\\[1\\]: value 100000 is out of range"),
      config_row("MissingScene", replaced(base_config(), "cornell-box", "no-such-scene"),
                 "bad.yaml:4:[0-9]+: scenes\\[0\\]: .*no-such-scene"),
      config_row("UnknownTechnique",
                 replaced(base_config(), "technique: direct", "technique: drect"),
                 "bad.yaml:6:[0-9]+: techniques\\[0\\].technique: unknown technique 'drect'; did "
                 "you mean 'direct'"),
      config_row("UnknownTechniqueParameter", base_config("    params: {shadow_map_sise: 256}\n"),
                 "bad.yaml:7:[0-9]+: techniques\\[0\\].params.shadow_map_sise: unknown key; did "
                 "you mean 'shadow_map_size'"),
      config_row("SweptValueOutOfTheSchemasRange",
                 base_config("    params: {shadow_map_size: [256, 8]}\n"),
                 "bad.yaml:7:[0-9]+: techniques\\[0\\].params.shadow_map_size\\[1\\]: value 8 is "
                 "out of range \\[16, 4096\\]"),
      // A technique's check of its values together (the descriptor's `check`), at the key it
      // blames.
      config_row("AapsDensityCeilingBelowItsFloor",
                 replaced(base_config("    params: {density_min: 8, density_max: 4}\n"),
                          "technique: direct", "technique: aaps"),
                 "bad.yaml:7:[0-9]+: techniques\\[0\\].params.density_max: 4 is below density_min "
                 "= 8 \\(0: no ceiling\\) \\(aaps\\)"),
      config_row(
          "TiledTileSideNotAMultipleOf8",
          replaced(base_config("    params: {tile_size: [32, 12]}\n"), "technique: direct",
                   "technique: tiled"),
          "bad.yaml:7:[0-9]+: techniques\\[0\\].params.tile_size: 12 is not a multiple of 8"),
      config_row("UnknownParameterInASceneOverride",
                 replaced(base_config(), "[cornell-box]",
                          "[cornell-box, {scene: pillars, params: {shadow_map_sise: 256}}]"),
                 "bad.yaml:4:[0-9]+: scenes\\[1\\].params.shadow_map_sise: unknown key; did you "
                 "mean 'shadow_map_size'"),
      config_row("SceneOverrideOutOfTheSchemasRange",
                 replaced(base_config(), "[cornell-box]",
                          "[cornell-box, {scene: pillars, params: {shadow_map_size: [64, 8]}}]"),
                 "bad.yaml:4:[0-9]+: scenes\\[1\\].params.shadow_map_size\\[1\\]: value 8 is out "
                 "of range"),
      config_row("SceneReferenceUnknownKey",
                 replaced(base_config(), "[cornell-box]",
                          "[{scene: cornell-box, reference: {rel_eror: 0.05}}]"),
                 "bad.yaml:4:[0-9]+: scenes\\[0\\].reference.rel_eror: unknown key; did you "
                 "mean 'rel_error'"),
      config_row("SceneReferenceWithoutAStopRule",
                 replaced(base_config(), "[cornell-box]", "[{scene: cornell-box, reference: {}}]"),
                 "bad.yaml:4:[0-9]+: scenes\\[0\\].reference: names no stop rule"),
      config_row("SceneReferenceOfOneSample",
                 replaced(base_config(), "[cornell-box]",
                          "[{scene: cornell-box, reference: {samples: 1}}]"),
                 "bad.yaml:4:[0-9]+: scenes\\[0\\].reference.samples: 0 \\(off\\) or at "
                 "least 2"),
      config_row("SceneListedTwiceWithOtherReferenceRules",
                 replaced(base_config(), "[cornell-box]",
                          "[{scene: cornell-box, reference: {rel_error: 0.05}}, cornell-box]"),
                 "bad.yaml:4:[0-9]+: scenes\\[1\\]: scene 'cornell-box' is listed again with "
                 "other reference stop rules"),
      {"SetWithABadValue",
       {{"bad.yaml", base_config()}},
       "bad.yaml",
       {"frames.count=-3"},
       "frames.count: value -3 is out of range"},
      {"TestPluginWithoutItsFolder",
       {{"bad.yaml", replaced(base_config(), "technique: direct", "technique: sleeps")}},
       "bad.yaml",
       {},
       "techniques\\[0\\].technique: unknown technique 'sleeps'"},
      // The file itself: empty, not a mapping, not text; keys written twice; alias bombs. The
      // error is at the file, never "the command line".
      {"EmptyConfig",
       {{"empty.yaml", ""}},
       "empty.yaml",
       {},
       "^[^ ]*empty.yaml: the file is empty; a config is a mapping",
       "command line"},
      {"ListAsAConfig",
       {{"list.yaml", "- 1\n"}},
       "list.yaml",
       {},
       "list.yaml:1:1: a config is a mapping"},
      {"BinaryConfig",
       {},
       "binary.yaml",
       {},
       "binary.yaml",
       "",
       [](const fs::path& dir) { write_binary(dir / "binary.yaml", 4000); }},
      {"ConfigKeyWrittenTwice",
       {{"config.yaml", probe_config("scenes: [cornell-box]\nname: u\n")}},
       "config.yaml",
       {},
       "config.yaml:7:1: key 'name' is written twice in this mapping \\(first at line 1\\)"},
      {"AliasBomb",
       {{"bomb.yaml", alias_bomb()}},
       "bomb.yaml",
       {},
       "expands to more than 1000000 nodes"},
      // A --set value's error names the --set, not a position in its text.
      set_row("SetScenesToAMissingScene", {"scenes=[nowhere]"},
              "config.yaml \\(--set scenes=\\[nowhere\\]\\): scenes\\[0\\]: unknown scene "
              "'nowhere'"),
      set_row("SetNaN", {"frames.count=nan"},
              "\\(--set frames.count=nan\\): frames.count: expected a finite number"),
      set_row("NameWithAPath", {"name=../escaped"},
              "\\(--set name=../escaped\\): name: '../escaped' is not a folder name"),
      set_row("NameOf300Characters", {"name=" + std::string(300, 'n')},
              "is not a folder name: use at most 100 letters"),
      set_row("ListIndexOf20Digits", {"techniques.99999999999999999999=1"},
              "'techniques' has 1 elements, no element 99999999999999999999"),
      set_row("EmptyPathPart", {"frames..count=1"}, "no empty part in the path"),
      // Sweeps are capped, naming the key and the count.
      set_row("SweepOfAMillionCells",
              {"techniques.0.params={shadow_map_size: [" + kSizes + "], shadow_bias: [" + kSmall +
               "], shadow_normal_offset: [" + kSmall + "]}"},
              "techniques\\[0\\].params.shadow_normal_offset: this sweep makes 10000 x 100 = "
              "1000000 cells, more than the 10000"),
      set_row("ScenesTimesSweepBeyondTheCap",
              {"scenes=[cornell-box, pillars]", "techniques.0.params={shadow_map_size: [" + kSizes +
                                                    "], shadow_bias: [" + kSmall + "]}"},
              "scenes\\[1\\]: with technique 'direct' the config expands to 20000 cells or more"),
      // The unknown-scene message offers scenes, not the other YAML files beside the config.
      {"UnknownSceneOffersScenesOnly",
       {{"config.yaml", probe_config("scenes: [cornell-box]\n")},
        {"other-config.yaml", probe_config("scenes: [cornell-box]\n")}},
       "config.yaml",
       {"scenes=[cornel-box]"},
       "did you mean 'cornell-box'\\?.*available: .*pillars",
       "available: .*(other-config|config,)"},
      // A plugin of a built-in's name in a plugin folder: both files named.
      {"PluginFolderWithADirectSo",
       {{"config.yaml", probe_config("scenes: [cornell-box]\n")}},
       "config.yaml",
       {"plugin_dirs+=$WORK/plugins"},
       "two technique plugins are named 'direct': .*/plugins/direct.so and $WORK/plugins/direct.so",
       "",
       [](const fs::path& dir) {
         fs::create_directories(dir / "plugins");
         fs::copy_file(kTestPlugins + "/sleeps.so", dir / "plugins" / "direct.so");
       }},

      // Scenes: a degenerate camera, huge coordinates, NaN, lights aimed at themselves.
      scene_row(
          "CameraOnItsTarget",
          with_camera("camera: {position: [0, 1, 3], target: [0, 1, 3], fov_deg: 40}"),
          "s.yaml:3:9: camera: at frame 0 \\(t = 0 s\\) the position \\(0, 1, 3\\) equals the "
          "target"),
      scene_row("CameraLookingAlongUp",
                with_camera("camera: {position: [0, 1, 3], target: [0, 5, 3], fov_deg: 40}"),
                "s.yaml:3:9: camera: at frame 0 .*parallel to up"),
      scene_row("CameraPosition1e23",
                with_camera("camera: {position: [0, 1e23, 3], target: [0, 1, 0], fov_deg: 40}"),
                "s.yaml:3:[0-9]+: camera.position\\[1\\]: value 1e23 is out of range "
                "\\[-1000000, 1000000\\]"),
      scene_row("LightPosition1e308",
                with_light("  - {type: point, position: [0, 1e308, 0], intensity: 1}"),
                "s.yaml:5:[0-9]+: lights\\[0\\].position\\[1\\]: value 1e308 is out of range"),
      scene_row("LightPositionBeyondADouble",
                with_light("  - {type: point, position: [0, 1e999, 0], intensity: 1}"),
                "lights\\[0\\].position\\[1\\]: '1e999' is beyond the range of a double"),
      scene_row("Translate1e308",
                with_object("  - {shape: {type: box}, material: white, transform: {translate: "
                            "[1e308, 0, 0]}}"),
                "s.yaml:9:[0-9]+: objects\\[0\\].transform.translate\\[0\\]: value 1e308 is out "
                "of range"),
      scene_row("WaveDirection1e23",
                with_object("  - {shape: {type: height_field, waves: [{amplitude: 0.1, "
                            "wavelength: 1, direction: [1e23, 0]}]}, material: white}"),
                "objects\\[0\\].shape.waves\\[0\\].direction\\[0\\]: value 1e23 is out of range"),
      scene_row("NaNInAColour",
                with_light("  - {type: point, position: [0, 2, 0], intensity: 1, color: [nan, 1, "
                           "1]}"),
                "lights\\[0\\].color\\[0\\]: expected a finite number, got 'nan'"),
      scene_row("SpotLightAimedAtItsOwnPosition",
                with_light("  - {type: spot, position: [0, 2, 0], target: [0, 2, 0], intensity: "
                           "1}"),
                "s.yaml:5:5: lights\\[0\\]: at frame 0 \\(t = 0 s\\) the target \\(0, 2, 0\\) is "
                "the light's own position"),
      scene_row("DirectionalLightWhosePositionIsItsTarget",
                with_light("  - {type: directional, position: [1, 2, 0], target: [1, 2, 0], "
                           "irradiance: 1}"),
                "s.yaml:5:5: lights\\[0\\]: at frame 0 .*is the light's own position"),
      scene_row("CameraOnItsTargetAtALaterFrame", with_camera(kLateCamera, "frames: 60"),
                "s.yaml:3:9: camera: at frame 30 \\(t = 1 s\\)"),
      // Scene files that are no scene: empty, binary, an OBJ, a folder, a device.
      {"EmptySceneFile",
       {{"empty.yaml", ""}, {"config.yaml", probe_config("scenes: [$WORK/empty.yaml]\n")}},
       "config.yaml",
       {},
       "scenes\\[0\\]: .*empty.yaml: the file is empty; a scene is a mapping",
       "command line"},
      {"BinarySceneFile",
       {{"config.yaml", probe_config("scenes: [$WORK/binary.yaml]\n")}},
       "config.yaml",
       {},
       "binary.yaml",
       "",
       [](const fs::path& dir) { write_binary(dir / "binary.yaml", 3000); }},
      {"ObjGivenAsAScene",
       {{"config.yaml", probe_config("scenes: [$WORK/mesh.yaml]\n")}},
       "config.yaml",
       {},
       "mesh.yaml:1:1: not a scene file: a scene is a mapping",
       "",
       [](const fs::path& dir) {
         fs::copy_file(PB_SOURCE_DIR "/tests/data/scenes/plain.obj", dir / "mesh.yaml");
       }},
      {"FolderAsAScene",
       {{"config.yaml", probe_config("scenes: [$WORK/folder.yaml]\n")}},
       "config.yaml",
       {},
       "folder.yaml: is a directory, not a scene file",
       "",
       [](const fs::path& dir) { fs::create_directories(dir / "folder.yaml"); }},
      {"DevZeroAsAScene",
       {{"config.yaml", probe_config("scenes: [/dev/zero]\n")}},
       "config.yaml",
       {},
       "/dev/zero: is not a regular file"},
      // OBJ and MTL files: only degenerate faces, values not finite or too large, a device.
      obj_row("ObjOfOnlyDegenerateFaces",
              "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 2 0 0\nusemtl a\nf 1 2 3\nf 1 3 2\n",
              "newmtl a\nKd 0.5 0.5 0.5\n",
              "objects\\[0\\].shape.file: .*m.obj: all 2 faces of the OBJ file have zero area"),
      obj_row("MtlKdNaN", kTriangle, "newmtl a\nKd nan 0.5 0.5\n",
              "m.mtl:2: 'Kd': 'nan' is not a finite number"),
      obj_row("MtlKe1e999", kTriangle, "newmtl a\nKd 0.5 0.5 0.5\nKe 1e999 1 1\n",
              "m.mtl:3: 'Ke': '1e999' is not a finite number"),
      obj_row("ObjVertexAt1e30", "mtllib m.mtl\nv 0 0 0\nv 1e30 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n",
              "newmtl a\n", "m.obj:3: 'v': 1e\\+30 is out of range"),
      obj_row("MtllibDevZero", "mtllib /dev/zero\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "",
              "/dev/zero: is not a regular file"),
      // Disc area lights: a finite radius, a normal that is not the zero vector, exactly one of
      // radiance and power, and no quad keys.
      scene_row("DiscRadius0",
                with_light("  - {type: disc, position: [0, 2, 0], normal: [0, -1, 0], radius: 0, "
                           "radiance: 1}"),
                "s.yaml:5:[0-9]+: lights\\[0\\].radius: value 0 is out of range \\[0.0001, "
                "10000\\]"),
      scene_row("DiscRadius1e5",
                with_light("  - {type: disc, position: [0, 2, 0], normal: [0, -1, 0], radius: "
                           "1e5, radiance: 1}"),
                "s.yaml:5:[0-9]+: lights\\[0\\].radius: value 1e5 is out of range"),
      scene_row("DiscNormalZero",
                with_light("  - {type: disc, position: [0, 2, 0], normal: [0, 0, 0], radius: 0.2, "
                           "radiance: 1}"),
                "s.yaml:5:[0-9]+: lights\\[0\\].normal: a direction must not be the zero vector"),
      scene_row("DiscWithoutANormal",
                with_light("  - {type: disc, position: [0, 2, 0], radius: 0.2, radiance: 1}"),
                "s.yaml:5:[0-9]+: lights\\[0\\]: missing required key 'normal'"),
      scene_row("DiscWithRadianceAndPower",
                with_light("  - {type: disc, position: [0, 2, 0], normal: [0, -1, 0], radius: 0.2, "
                           "radiance: 1, power: 3}"),
                "s.yaml:5:[0-9]+: lights\\[0\\]: a disc light needs exactly one of 'radiance' or "
                "'power'"),
      scene_row("DiscWithAQuadsEdge",
                with_light("  - {type: disc, position: [0, 2, 0], normal: [0, -1, 0], radius: 0.2, "
                           "radiance: 1, edge_u: [1, 0, 0]}"),
                "s.yaml:5:[0-9]+: lights\\[0\\].edge_u: unknown key"),
      scene_row("DiscRadianceNegative",
                with_light("  - {type: disc, position: [0, 2, 0], normal: [0, -1, 0], radius: 0.2, "
                           "radiance: -1}"),
                "s.yaml:5:[0-9]+: lights\\[0\\].radiance: value -1 is out of range"),
  };
  // An error never echoes a whole line of whatever it was given.
  BadInput long_number =
      scene_row("Number500CharactersLong",
                with_camera("camera: {position: [0, 1, 3], target: [0, 1, 0], fov_deg: " +
                            std::string(500, 'x') + "}"),
                "fov_deg: expected a number, got 'x{40}\\.\\.\\.'");
  long_number.short_message = true;
  rows.push_back(long_number);
  // A scene key written twice is an error naming both lines, not "last one wins".
  BadInput twice = scene_row("SceneKeyWrittenTwice", {},
                             "s.yaml:11:1: key 'fps' is written twice in this mapping \\(first at "
                             "line 10\\)");
  twice.files[0].second += "fps: 30\nfps: 60\n";
  rows.push_back(twice);
  return rows;
}

class Refused : public ::testing::TestWithParam<BadInput> {};

TEST_P(Refused, WithTheFileLineAndKey) {
  const BadInput& row = GetParam();
  Scratch scratch;
  for (const auto& [name, text] : row.files) scratch.write(name, text);
  if (row.prepare) row.prepare(scratch.dir());
  std::vector<std::string> sets;
  for (const std::string& set : row.sets) sets.push_back(scratch.expand(set));
  const Validation v = validate(scratch.dir() / row.config, sets);
  ASSERT_EQ(v.exit_code, 2) << "valid, " << v.cells << " cells";
  EXPECT_TRUE(std::regex_search(v.message, std::regex(scratch.expand(row.message))))
      << "no match for /" << row.message << "/ in: " << v.message;
  if (!row.not_message.empty())
    EXPECT_FALSE(std::regex_search(v.message, std::regex(row.not_message))) << v.message;
  // The executable prints "error: MESSAGE": short, whatever it was given.
  if (row.short_message)
    EXPECT_LT(std::string("error: ").size() + v.message.size(), 400u) << v.message;
}

INSTANTIATE_TEST_SUITE_P(BadInput, Refused, ::testing::ValuesIn(bad_inputs()),
                         [](const auto& info) { return info.param.name; });

// The probes the rows start from are valid, so each row's error is its own.
TEST(BadInputProbes, AreValid) {
  Scratch scratch;
  EXPECT_EQ(validate(scratch.write("bad.yaml", base_config())).exit_code, 0);
  EXPECT_EQ(
      validate(scratch.write("config.yaml", probe_config("scenes: [cornell-box]\n"))).exit_code, 0);
  scratch.write("s.yaml", probe_scene({}));
  Validation scene =
      validate(scratch.write("config.yaml", probe_config("scenes: [$WORK/s.yaml]\n")));
  EXPECT_EQ(scene.exit_code, 0) << scene.message;
  scratch.write("m.obj", kTriangle);
  scratch.write("m.mtl", "newmtl a\nKd 0.5 0.5 0.5\n");
  scratch.write("s.yaml", probe_scene(with_object("  - {shape: {type: obj, file: m.obj}}")));
  Validation obj = validate(scratch.dir() / "config.yaml");
  EXPECT_EQ(obj.exit_code, 0) << obj.message;
}

// A scene entry's overrides sweep that scene only; a --set sweep expands into cells.
TEST(BadInputProbes, OverridesSweepWhereTheyAreSet) {
  Scratch scratch;
  const fs::path config = scratch.write(
      "bad.yaml",
      replaced(base_config(), "[cornell-box]",
               "[cornell-box, {scene: pillars, params: {shadow_map_size: [64, 128]}}]"));
  const Validation v = validate(config);
  ASSERT_EQ(v.exit_code, 0) << v.message;
  EXPECT_EQ(v.cells, 3u);
  std::vector<std::string> pillars_sizes;
  for (const Cell& cell : v.cell_list)
    if (cell.scene == "pillars") pillars_sizes.push_back(cell.params.at("shadow_map_size"));
  std::sort(pillars_sizes.begin(), pillars_sizes.end());
  EXPECT_EQ(pillars_sizes, (std::vector<std::string>{"128", "64"}));
  EXPECT_EQ(validate(scratch.write("bad.yaml", base_config()),
                     {"techniques.0.params={shadow_map_size: [128, 256]}"})
                .cells,
            2u);
}

// A sweep of exactly the cap is valid (and expands in time linear in its cells).
TEST(BadInputProbes, ASweepOfExactlyTheCapIsValid) {
  Scratch scratch;
  const Validation v = validate(
      scratch.write("config.yaml", probe_config("scenes: [cornell-box]\n")),
      {"techniques.0.params={shadow_map_size: [" + kSizes + "], shadow_bias: [" + kSmall + "]}"});
  EXPECT_EQ(v.exit_code, 0) << v.message;
  EXPECT_EQ(v.cells, 10000u);
}

// A test plugin is found through plugin_dirs (what --plugin-dir adds); the same folder twice is no
// conflict; a cell whose plugin does not load makes the config valid but failing (exit 1).
TEST(BadInputProbes, PluginFolders) {
  Scratch scratch;
  const fs::path sleeps =
      scratch.write("bad.yaml", replaced(base_config(), "technique: direct", "technique: sleeps"));
  EXPECT_EQ(validate(sleeps, {"plugin_dirs+=" + kTestPlugins}).exit_code, 0);
  const fs::path config = scratch.write("config.yaml", probe_config("scenes: [cornell-box]\n"));
  EXPECT_EQ(
      validate(config, {"plugin_dirs+=" + kTestPlugins, "plugin_dirs+=" + kTestPlugins}).exit_code,
      0);
  const Validation failing = validate(
      scratch.write("config.yaml",
                    probe_config("  - technique: not_a_module\nscenes: [cornell-box]\nplugin_dirs: "
                                 "[" +
                                 kTestPlugins + "]\n")));
  EXPECT_EQ(failing.exit_code, 1) << failing.message;
  EXPECT_EQ(failing.will_fail, 1u);
  EXPECT_EQ(failing.cells, 2u);
}

// `run` refuses bad input before running: no reference, no cell, no run.json, no run folder.
TEST(BadInputRun, WritesNothingForARefusedConfig) {
  Scratch scratch;
  const fs::path tiled =
      scratch.write("bad.yaml", replaced(base_config("    params: {tile_size: [32, 12]}\n"),
                                         "technique: direct", "technique: tiled"));
  EXPECT_NE(run_error(tiled, scratch.dir() / "refused").find("tile_size: 12 is not a multiple"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(scratch.dir() / "refused"));

  const fs::path base = scratch.write("base.yaml", base_config());
  EXPECT_NE(run_error(base, scratch.dir() / "run", {"frames.count=-3"})
                .find("frames.count: value -3 is out of range"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(scratch.dir() / "run" / "run.json"));

  // A name with a path, with no --out: nothing is written where the run folder would go.
  const fs::path cwd = scratch.dir() / "cwd";
  fs::create_directories(cwd);
  const fs::path here = fs::current_path();
  fs::current_path(cwd);
  const std::string escaped =
      run_error(scratch.write("config.yaml", probe_config("scenes: [cornell-box]\n")), {},
                {"name=../escaped"});
  fs::current_path(here);
  EXPECT_NE(escaped.find("(--set name=../escaped): name: '../escaped' is not a folder name"),
            std::string::npos)
      << escaped;
  EXPECT_TRUE(fs::is_empty(cwd));
  for (const auto& entry : fs::directory_iterator(scratch.dir()))
    EXPECT_EQ(entry.path().filename().string().rfind("escaped", 0), std::string::npos)
        << entry.path();

  // A camera that reaches its target at frame 30: a run of 40 frames names the scene entry, the
  // camera and the frame; 20 frames are valid.
  scratch.write("late.yaml", probe_scene(with_camera(kLateCamera, "frames: 2")));
  const fs::path late = scratch.write("config.yaml", probe_config("scenes: [$WORK/late.yaml]\n"));
  const std::string message = run_error(late, scratch.dir() / "run", {"frames.count=40"});
  EXPECT_TRUE(std::regex_search(
      message, std::regex("config.yaml:[0-9]+:[0-9]+: scenes\\[0\\]: .*late.yaml:3:9: camera: at "
                          "frame 30")))
      << message;
  EXPECT_FALSE(fs::exists(scratch.dir() / "run" / "run.json"));
  EXPECT_EQ(validate(late, {"frames.count=20"}).exit_code, 0);
}

// `reference SCENE` checks the frames it renders before the first (scene::check_frames).
TEST(BadInputScene, FramesAreCheckedBeforeRendering) {
  Scratch scratch;
  const fs::path degenerate = scratch.write(
      "degenerate.yaml",
      probe_scene(with_camera("camera: {position: [0, 1, 3], target: [0, 1, 3], fov_deg: 40}")));
  std::string message;
  try {
    scene::check_frames(scene::load_scene(degenerate), 0, 0);
  } catch (const InputError& e) {
    message = e.what();
  }
  EXPECT_NE(message.find("degenerate.yaml:3:9: camera: at frame 0"), std::string::npos) << message;
}

}  // namespace bad_input_test
}  // namespace pb::run
