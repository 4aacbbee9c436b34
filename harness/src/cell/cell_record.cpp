#include "cell/cell_record.h"

#include <fmt/format.h>

#include "io/results.h"

namespace pb::run {

using json = nlohmann::json;

CellRecord::CellRecord(const Cell& cell) : cell(cell) {}

void CellRecord::fail(const CellFailure& failure) {
  status = "failed";
  reason = failure.reason;
  failed_frame = failure.frame;
}

void CellRecord::warn(std::optional<uint32_t> frame, const std::string& message) {
  warnings.push_back({{"frame", frame ? json(*frame) : json(nullptr)}, {"message", message}});
}

json to_json(const CellRecord& r) {
  std::map<std::string, std::string> resolved = r.cell.params;
  for (const auto& [name, value] : r.resolved_params) resolved[name] = fmt::format("{}", value);
  json j = {{"schema_version", io::kResultsSchemaVersion},
            {"cell", r.cell.id},
            {"scene", r.cell.scene},
            {"technique", r.cell.technique},
            {"params", r.cell.params},
            {"params_resolved", resolved},
            {"seed", r.cell.seed},
            {"seed_index", r.cell.seed_index},
            {"seed_group", r.cell.seed_group},
            {"status", r.status},
            {"reason", r.reason},
            {"failed_frame", r.failed_frame ? json(*r.failed_frame) : json(nullptr)},
            {"warnings", r.warnings}};
  auto put = [&j](const char* key, const auto& value) {
    if (value) j[key] = *value;
  };
  put("path_class", r.path_class);
  put("device", r.device);
  put("timing", r.timing);
  put("metrics", r.metrics);
  put("metrics_bounce_matched", r.metrics_bounce_matched);
  put("references", r.references);
  put("frames_measured", r.frames_measured);
  put("counters", r.counters);
  put("summary", r.summary);
  put("memory", r.memory);
  put("validation", r.validation);
  put("log_tail", r.log_tail);
  if (!r.stages_ms.empty()) j["stages_ms"] = r.stages_ms;
  return j;
}

void write_cell_record(const std::filesystem::path& dir, const CellRecord& record) {
  io::write_text_atomic(dir / "cell.json", to_json(record).dump(2) + "\n");
}

}  // namespace pb::run
