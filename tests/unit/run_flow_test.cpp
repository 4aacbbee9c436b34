// The pieces of a run that need no GPU: the plan (config -> plugins -> cells), the cell record
// (cell.json's one writer) and the frame log (frames.csv rows, harness overhead, the summary).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "cell/cell_record.h"
#include "cell/frame_log.h"
#include "io/results.h"
#include "photonbench/error.h"
#include "plan/plan.h"

namespace pb::run {
namespace run_flow_test {

namespace fs = std::filesystem;

fs::path scratch(const std::string& name) {
  fs::path dir =
      fs::temp_directory_path() / ("pb_run_flow_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// The test binary's own folder has a plugins/ folder of CMake's (no modules): name the build's.
fs::path write_config(const fs::path& dir, const std::string& yaml) {
  std::ofstream(dir / "config.yaml") << yaml << "plugin_dirs: [" PB_BINARY_DIR "/plugins]\n";
  return dir / "config.yaml";
}

TEST(RunPlan, ExpandsSweepsPerSceneWithStableIds) {
  const fs::path dir = scratch("plan");
  const fs::path config = write_config(dir, R"(name: t
scenes: [cornell-box, {scene: pillars, params: {shadow_map_size: 128}}]
techniques:
  - technique: direct
    params: {shadow_map_size: [64, 256]}
)");
  const RunPlan plan = plan_run(config, {});
  // cornell-box sweeps both values; pillars' own value replaces the sweep: 2 + 1 cells.
  ASSERT_EQ(plan.cells.size(), 3u);
  std::set<std::string> cornell, pillars;
  for (const Cell& cell : plan.cells) {
    EXPECT_EQ(cell.technique, "direct");
    EXPECT_TRUE(fs::exists(cell.scene_file)) << cell.scene_file;
    EXPECT_TRUE(cell.params.count("shadow_bias")) << "defaults are filled in";
    (cell.scene == "cornell-box" ? cornell : pillars).insert(cell.params.at("shadow_map_size"));
    EXPECT_EQ(cell.id.rfind(cell.scene + "__direct__", 0), 0u) << cell.id;
  }
  EXPECT_EQ(cornell, (std::set<std::string>{"64", "256"}));
  EXPECT_EQ(pillars, (std::set<std::string>{"128"}));
  // The same config plans the same ids: a cell process finds its cell by id.
  const RunPlan again = plan_run(config, {});
  for (size_t i = 0; i < plan.cells.size(); ++i) {
    EXPECT_EQ(again.cells[i].id, plan.cells[i].id);
    EXPECT_EQ(&again.cell(plan.cells[i].id), &again.cells[i]);
  }
  EXPECT_THROW(plan.cell("cornell-box__direct__00000000"), InputError);
  // An override changes the parameter values, and so the ids.
  const RunPlan set = plan_run(config, {"techniques.0.params.shadow_map_size=512"});
  EXPECT_NE(set.cells[0].id, plan.cells[0].id);
  fs::remove_all(dir);
}

TEST(RunPlan, UnknownSceneIsAnErrorAtItsKey) {
  const fs::path dir = scratch("scene");
  const fs::path config = write_config(dir, R"(name: t
scenes: [cornell-box, {scene: no-such-scene}]
techniques: [{technique: direct}]
)");
  try {
    plan_run(config, {});
    FAIL() << "no error for an unknown scene";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("config.yaml:2:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("scenes[1].scene"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

TEST(RunPlan, ATechniqueRunsOnlyOnTheScenesItNames) {
  const fs::path dir = scratch("only");
  const fs::path config = write_config(dir, R"(name: t
scenes: [cornell-box, pillars]
techniques:
  - technique: direct
    params: {shadow_map_size: [64, 256]}
    scenes: [pillars]
  - technique: tiled
)");
  std::multiset<std::string> cells;
  for (const Cell& cell : plan_run(config, {}).cells)
    cells.insert(cell.scene + "/" + cell.technique);
  EXPECT_EQ(cells, (std::multiset<std::string>{"pillars/direct", "pillars/direct",
                                               "cornell-box/tiled", "pillars/tiled"}));
  // A name the config's scenes do not list is an error at that name, before any work.
  const fs::path wrong = write_config(dir, R"(name: t
scenes: [cornell-box, pillars]
techniques:
  - technique: direct
    scenes: [pillars, cornell]
)");
  try {
    plan_run(wrong, {});
    FAIL() << "no error for a scene the config does not list";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("config.yaml:5:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("techniques[0].scenes[1]"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'cornell'"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

// The InputError plan_run throws for `yaml` ("" when it plans).
std::string plan_error(const fs::path& dir, const std::string& yaml) {
  try {
    plan_run(write_config(dir, yaml), {});
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// A technique's descriptor check runs in the plan, before any work: its error names the file, the
// line and the key it blames (where the config sets it, else the technique entry), and exits 2.
TEST(RunPlan, ATechniquesCheckRefusesValuesTogetherAtTheirKey) {
  const fs::path dir = scratch("check");
  const std::string head = "name: t\nscenes: [cornell-box, pillars]\ntechniques:\n";
  // AAPS: a density ceiling below the floor, the floor given on another line.
  std::string e = plan_error(dir, head + R"(  - technique: aaps
    params:
      density_min: 8
      density_max: 4
)");
  EXPECT_NE(e.find("config.yaml:7:"), std::string::npos) << e;
  EXPECT_NE(e.find("techniques[0].params.density_max: 4 is below density_min = 8"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("(aaps)"), std::string::npos) << e;
  // ... and a density texture that is not a power of two, in a sweep: the element's line.
  e = plan_error(dir, head + "  - technique: aaps\n    params: {density_resolution: [64, 48]}\n");
  EXPECT_NE(e.find("config.yaml:5:"), std::string::npos) << e;
  EXPECT_NE(e.find("techniques[0].params.density_resolution: 48 is not a power of two"),
            std::string::npos)
      << e;
  // The toolkit's: tiled's tile side, set by a scene's override.
  e = plan_error(dir,
                 "name: t\nscenes: [cornell-box, {scene: pillars, params: {tile_size: 20}}]\n"
                 "techniques:\n  - technique: tiled\n");
  EXPECT_NE(e.find("config.yaml:2:"), std::string::npos) << e;
  EXPECT_NE(e.find("scenes[1].params.tile_size: 20 is not a multiple of 8"), std::string::npos)
      << e;
  // Path verification through its chosen splatter (the toolkit's check again) ...
  e = plan_error(dir, head + "  - technique: path-verification\n    params: {tile_size: 36}\n");
  EXPECT_NE(e.find("techniques[0].params.tile_size: 36 is not a multiple of 8 (the 8x8"),
            std::string::npos)
      << e;
  EXPECT_EQ(plan_error(dir, head + "  - technique: path-verification\n    params: {tile_size: 36, "
                                   "splatter: cluster}\n"),
            "")
      << "cluster reads no tile_size";
  // ... and its photon map: the key it blames keeps its default, so the technique entry is named.
  e = plan_error(
      dir, head + "  - technique: path-verification\n    params: {max_photons_per_path: 2}\n");
  EXPECT_NE(e.find("config.yaml:4:"), std::string::npos) << e;
  EXPECT_NE(e.find("techniques[0].technique: max_bounces: 4 stores up to 3 photons per path, more "
                   "than max_photons_per_path = 2"),
            std::string::npos)
      << e;
  // Values that go together plan.
  EXPECT_EQ(plan_error(dir, head + "  - technique: aaps\n    params: {density_min: 4, "
                                   "density_max: 8, density_resolution: 64}\n  - technique: "
                                   "tiled\n    params: {tile_size: [16, 32]}\n"),
            "");
  fs::remove_all(dir);
}

Cell test_cell() {
  Cell cell;
  cell.id = "box__mine__0123abcd";
  cell.scene = "box";
  cell.technique = "mine";
  cell.params = {{"radius", "0.5"}};
  return cell;
}

TEST(CellRecord, WritesWhatTheCellReachedAndNothingElse) {
  const fs::path dir = scratch("record");
  CellRecord record(test_cell());
  record.fail({"technique plugin 'mine' failed to load: not found", std::nullopt});
  record.warn(std::nullopt, "a warning of the cell");
  write_cell_record(dir, record);
  const nlohmann::json j = nlohmann::json::parse(io::read_text(dir / "cell.json"));
  EXPECT_EQ(j["schema_version"], io::kResultsSchemaVersion);
  EXPECT_EQ(j["cell"], "box__mine__0123abcd");
  EXPECT_EQ(j["params"]["radius"], "0.5");
  EXPECT_EQ(j["params_resolved"], j["params"]) << "nothing resolved: the schema's values";
  EXPECT_EQ(j["status"], "failed");
  EXPECT_TRUE(j["failed_frame"].is_null());
  ASSERT_EQ(j["warnings"].size(), 1u);
  EXPECT_TRUE(j["warnings"][0]["frame"].is_null());
  for (const char* key : {"device", "timing", "metrics", "summary", "memory", "log_tail"})
    EXPECT_FALSE(j.contains(key)) << key << " written for a cell that never reached it";

  CellRecord ok(test_cell());
  ok.cell.params["blur_radius"] = "-1";
  ok.resolved_params["blur_radius"] = 16;  // a counter named as the parameter
  ok.device = "llvmpipe";
  ok.warn(3u, "frame warning");
  ok.log_tail = "";
  write_cell_record(dir, ok);
  const nlohmann::json k = nlohmann::json::parse(io::read_text(dir / "cell.json"));
  EXPECT_EQ(k["status"], "ok");
  EXPECT_EQ(k["device"], "llvmpipe");
  EXPECT_EQ(k["warnings"][0]["frame"], 3);
  EXPECT_EQ(k["params"]["blur_radius"], "-1");
  EXPECT_EQ(k["params_resolved"]["blur_radius"], "16");
  EXPECT_EQ(k["params_resolved"]["radius"], "0.5");
  EXPECT_TRUE(k.contains("log_tail"));
  size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir)) files += entry.is_regular_file();
  EXPECT_EQ(files, 1u) << "the atomic write left a temporary file";
  fs::remove_all(dir);
}

TEST(FrameLog, OverheadIsWallTimeLessTopLevelPasses) {
  const fs::path dir = scratch("log");
  {
    FrameLog log(dir);
    // A frame of 10 ms wall: "a" took 2 ms CPU + 3 ms GPU, its nested "a/b" 1 + 1 (inside a's
    // time, not counted again), "c" 1 ms CPU: the harness's share is 10 - 5 - 1 = 4 ms.
    FrameTiming frame;
    frame.frame = 4;
    frame.wall_ms = 10;
    frame.process_cpu_ms = 12;
    frame.passes = {{"a", 0, 3, 2, 6}, {"a/b", 1, 1, 1, 2}, {"c", 0, 0, 1, 1}};
    log.add(frame, {{"photons_stored", 1000}});
    frame.frame = 5;
    frame.wall_ms = 5;  // passes longer than the frame: no negative overhead
    log.add(frame, {});
    log.track_gpu_memory(100, 400);
    log.track_gpu_memory(50, 500);
    CellRecord record(test_cell());
    log.describe(record);
    EXPECT_EQ(record.frames_measured, 2u);
    EXPECT_DOUBLE_EQ((*record.summary)["harness_overhead_ms"]["median"].get<double>(), 2.0);
    EXPECT_DOUBLE_EQ((*record.summary)["frame_ms"]["median"].get<double>(), 7.5);
    EXPECT_DOUBLE_EQ((*record.summary)["pass_ms_median"]["a"].get<double>(), 3.0);  // max(gpu, cpu)
    EXPECT_EQ((*record.memory)["gpu_bytes_technique"], 100);
    EXPECT_EQ((*record.memory)["gpu_bytes_total"], 500);
  }
  const auto rows = io::read_csv(dir / "frames.csv");
  ASSERT_EQ(rows.size(), 1u + 2 * 5);  // header, then 3 passes + overhead + frame per frame
  EXPECT_EQ(rows[4], (std::vector<std::string>{"4", "harness-overhead", "", "4.0000", "5.0000"}));
  EXPECT_EQ(rows[5], (std::vector<std::string>{"4", "frame", "", "10.0000", "12.0000"}));
  EXPECT_EQ(rows[9][3], "0.0000");
  const auto counters = io::read_csv(dir / "counters.csv");
  ASSERT_EQ(counters.size(), 2u);
  EXPECT_EQ(counters[1], (std::vector<std::string>{"4", "photons_stored", "1000"}));
  fs::remove_all(dir);
}

}  // namespace run_flow_test
}  // namespace pb::run
