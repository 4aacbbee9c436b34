// Scoring a cell's metric frames against references of the same frame and path class: metrics.csv, FLIP
// error maps, and per-class means for cell.json. Runs after the frames, never on the timed path.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "config/config.h"
#include "scene/scene.h"

namespace pb::run {

struct ScoreResult {
  nlohmann::json means = nlohmann::json::object();  // {"<class>": {"flip": .., "ssim": .., ...}}
  std::vector<std::string> warnings;
};

ScoreResult score_cell(const config::Config& config, const config::Cell& cell, const scene::Scene& scene,
                       const std::vector<uint32_t>& metric_frames, const std::string& path_class,
                       const std::filesystem::path& cell_dir);

}  // namespace pb::run
