// Scoring a cell's metric frames against references of the same frame and path class: metrics.csv,
// FLIP error maps, and per-class means for cell.json. Runs after the frames, never on the timed
// path.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "config/config.h"
#include "plan/plan.h"
#include "reference/reference.h"
#include "scene/scene.h"

namespace pb::run {

struct ScoreResult {
  // Against the full reference: {"<class>": {"flip": .., "flip_floor": .., ..., "frames": n}}.
  nlohmann::json means = nlohmann::json::object();
  // Against the bounce-matched reference, when scored: {"max_bounces": B, "<class>": {...}}.
  nlohmann::json bounce_matched_means;
  // One entry per reference image scored against: frame, class, reference, samples, error, ...
  nlohmann::json references = nlohmann::json::array();
  std::vector<std::string> warnings;
};

// The measured frames that are scored: every metrics_every-th, counted from the first measured
// frame, each with the metrics_window - 1 frames after it.
std::vector<uint32_t> metric_frames(const config::Config& config);
// The reference images a technique's cells need: combined, plus its own class.
uint32_t reference_classes(const std::string& technique_path_class);
// The reference options of the cells of config.scenes[scene_entry] (config::reference_settings).
trace::ReferenceOptions reference_options(const config::Config& config, size_t scene_entry);

// A reference a cell is scored against: "full" (as the config's reference block and the cell's
// scene entry set it) and, with reference.bounce_matched and a technique that has a max_bounces
// parameter, "bounce_matched" (truncated at trace::bounces_matching_photon_technique of the cell's
// max_bounces).
struct ScoredReference {
  std::string name;
  trace::ReferenceOptions options;
};
std::vector<ScoredReference> scored_references(const config::Config& config, const Cell& cell);
// The file (in a cell's images/) holding a technique's estimate of one path class alone at
// `frame`: its own class, when that class is not the whole output (an indirect class added to the
// shared direct light), or a class it handed back (Context::class_output).
std::string class_image_name(uint32_t frame, trace::PathClass path_class);

// Scores the combined output, the technique's own class (`path_class`) and each class of
// `class_outputs` (the images it handed back, Context::class_output), each against its class's
// reference.
ScoreResult score_cell(const config::Config& config, const Cell& cell, const scene::Scene& scene,
                       const std::vector<uint32_t>& metric_frames, const std::string& path_class,
                       const std::filesystem::path& cell_dir,
                       const std::vector<trace::PathClass>& class_outputs = {});

}  // namespace pb::run
