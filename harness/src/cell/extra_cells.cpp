#include "cell/extra_cells.h"

#include <nlohmann/json.hpp>

#include "io/results.h"

namespace pb::run {

namespace {

std::filesystem::path extra_cells_file(const std::filesystem::path& run_dir) {
  return run_dir / "match" / "cells.json";
}

nlohmann::json extra_cell_json(const ExtraCell& extra) {
  const Cell& c = extra.cell;
  return {{"id", c.id},
          {"scene", c.scene},
          {"scene_file", c.scene_file.string()},
          {"technique", c.technique},
          {"params", c.params},
          {"seed", c.seed},
          {"seed_index", c.seed_index},
          {"seed_group", c.seed_group},
          {"entry", c.entry},
          {"role", extra.role}};
}

}  // namespace

std::vector<ExtraCell> read_extra_cells(const std::filesystem::path& run_dir) {
  std::vector<ExtraCell> cells;
  const std::filesystem::path file = extra_cells_file(run_dir);
  if (!std::filesystem::exists(file)) return cells;
  for (const nlohmann::json& j : nlohmann::json::parse(io::read_text(file))) {
    ExtraCell extra;
    extra.cell.id = j.at("id").get<std::string>();
    extra.cell.scene = j.at("scene").get<std::string>();
    extra.cell.scene_file = j.at("scene_file").get<std::string>();
    extra.cell.technique = j.at("technique").get<std::string>();
    extra.cell.params = j.at("params").get<std::map<std::string, std::string>>();
    extra.cell.seed = j.at("seed").get<uint64_t>();
    extra.cell.seed_index = j.at("seed_index").get<uint32_t>();
    extra.cell.seed_group = j.at("seed_group").get<std::string>();
    extra.cell.entry = j.at("entry").get<size_t>();
    extra.role = j.at("role").get<std::string>();
    cells.push_back(std::move(extra));
  }
  return cells;
}

void add_extra_cell(const std::filesystem::path& run_dir, const Cell& cell,
                    const std::string& role) {
  std::vector<ExtraCell> cells = read_extra_cells(run_dir);
  for (const ExtraCell& extra : cells)
    if (extra.cell.id == cell.id) return;
  cells.push_back({cell, role});
  nlohmann::json all = nlohmann::json::array();
  for (const ExtraCell& extra : cells) all.push_back(extra_cell_json(extra));
  std::filesystem::create_directories(extra_cells_file(run_dir).parent_path());
  io::write_text_atomic(extra_cells_file(run_dir), all.dump(1) + "\n");
}

std::optional<Cell> find_extra_cell(const std::filesystem::path& run_dir, const std::string& id) {
  for (ExtraCell& extra : read_extra_cells(run_dir))
    if (extra.cell.id == id) return std::move(extra.cell);
  return std::nullopt;
}

}  // namespace pb::run
