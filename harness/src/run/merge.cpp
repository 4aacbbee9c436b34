#include "run/merge.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "cell/cell_runner.h"
#include "io/results.h"
#include "photonbench/error.h"
#include "run/run_record.h"
#include "run/runner.h"

namespace pb::run {

using json = nlohmann::json;

namespace {

// One shard's run folder as merge reads it.
struct ShardRun {
  std::filesystem::path dir;
  json run;                        // run.json
  json shard;                      // run.json's "shard"
  std::set<std::string> complete;  // cells with a cell.json
  std::string label() const {
    return fmt::format("{} (shard {}/{})", dir.string(), shard.value("index", 0u),
                       shard.value("count", 0u));
  }
};

std::set<std::string> complete_cells(const std::filesystem::path& dir) {
  std::set<std::string> ids;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(dir / "cells", ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(".partial-", 0) != 0 && std::filesystem::exists(entry.path() / "cell.json"))
      ids.insert(name);
  }
  return ids;
}

// At most `limit` names, then how many more.
std::string name_some(const std::vector<std::string>& names, size_t limit = 12) {
  std::vector<std::string> shown(names.begin(), names.begin() + std::min(limit, names.size()));
  std::string text = fmt::format("{}", fmt::join(shown, ", "));
  if (names.size() > limit) text += fmt::format(" and {} more", names.size() - limit);
  return text;
}

// Reads every shard, collecting each problem instead of stopping at the first.
std::vector<ShardRun> read_shards(const std::vector<std::filesystem::path>& dirs,
                                  std::vector<std::string>& problems) {
  std::vector<ShardRun> shards;
  for (const auto& dir : dirs) {
    const std::filesystem::path file = dir / "run.json";
    if (!std::filesystem::exists(file)) {
      problems.push_back(fmt::format("{}: not a run folder (no run.json)", dir.string()));
      continue;
    }
    ShardRun shard{std::filesystem::absolute(dir).lexically_normal(),
                   json::parse(io::read_text(file)), json(), complete_cells(dir)};
    shard.shard = shard.run.value("shard", json());
    if (!shard.shard.is_object()) {
      problems.push_back(
          fmt::format("{}: not a shard (it was run without --shard I/N)", dir.string()));
      continue;
    }
    shards.push_back(std::move(shard));
  }
  return shards;
}

// The shards must be of one config, one shard count, one plan, each shard once.
void check_same_plan(const std::vector<ShardRun>& shards, std::vector<std::string>& problems) {
  std::map<std::string, std::vector<std::string>> by_hash, by_count;
  std::map<uint32_t, std::vector<std::string>> by_index;
  for (const ShardRun& s : shards) {
    by_hash[s.run.value("config_hash", "?")].push_back(s.dir.string());
    by_count[std::to_string(s.shard.value("count", 0u))].push_back(s.dir.string());
    by_index[s.shard.value("index", 0u)].push_back(s.dir.string());
  }
  auto differ = [&](const char* what, const auto& groups) {
    if (groups.size() < 2) return;
    std::vector<std::string> lines;
    for (const auto& [value, dirs] : groups)
      lines.push_back(fmt::format("{} {}: {}", what, value, fmt::join(dirs, ", ")));
    problems.push_back(
        fmt::format("the shards are of different runs ({})", fmt::join(lines, "; ")));
  };
  differ("config hash", by_hash);
  differ("shard count", by_count);
  for (const auto& [index, dirs] : by_index)
    if (dirs.size() > 1)
      problems.push_back(
          fmt::format("shard {} is given {} times: {}", index, dirs.size(), fmt::join(dirs, ", ")));
  for (const ShardRun& s : shards)
    if (s.shard.value("every_cell", json()) != shards.front().shard.value("every_cell", json()))
      problems.push_back(fmt::format(
          "{} planned other cells than {} from the same config (a different build or plugins?)",
          s.dir.string(), shards.front().dir.string()));
}

// Every cell of the plan complete in exactly one shard, and no cell outside the plan. Returns the
// shard holding each cell.
std::map<std::string, const ShardRun*> place_cells(const std::vector<ShardRun>& shards,
                                                   std::vector<std::string>& problems) {
  std::map<std::string, const ShardRun*> owner;
  if (shards.empty()) return owner;
  const std::vector<std::string> every =
      shards.front().shard.value("every_cell", std::vector<std::string>());
  const std::set<std::string> planned(every.begin(), every.end());
  std::map<std::string, std::vector<std::string>> duplicated;
  for (const ShardRun& s : shards)
    for (const std::string& id : s.complete) {
      if (!planned.count(id)) {
        problems.push_back(
            fmt::format("{}: cell {} is not in the config's plan", s.dir.string(), id));
        continue;
      }
      if (auto [it, inserted] = owner.emplace(id, &s); !inserted) {
        auto& dirs = duplicated[id];
        if (dirs.empty()) dirs.push_back(it->second->dir.string());
        dirs.push_back(s.dir.string());
      }
    }
  for (const auto& [id, dirs] : duplicated)
    problems.push_back(fmt::format("cell {} is complete in {} shards: {}", id, dirs.size(),
                                   fmt::join(dirs, ", ")));
  // A missing cell, with where it should have been: the given shard it was assigned to, else the
  // shard index that was not given.
  std::map<std::string, std::vector<std::string>> missing;  // where -> cells
  const uint32_t count = shards.front().shard.value("count", 0u);
  std::vector<std::string> absent_shards;
  for (uint32_t i = 1; i <= count; ++i)
    if (std::none_of(shards.begin(), shards.end(),
                     [&](const ShardRun& s) { return s.shard.value("index", 0u) == i; }))
      absent_shards.push_back(fmt::format("{}/{}", i, count));
  const std::string absent =
      fmt::format("shard {}, not given to merge", fmt::join(absent_shards, " or "));
  for (const std::string& id : every) {
    if (owner.count(id)) continue;
    std::string where;
    for (const ShardRun& s : shards)
      for (const auto& assigned : s.shard.value("cells", std::vector<std::string>()))
        if (assigned == id) where = s.label() + ", incomplete: resume it with run --resume";
    if (where.empty()) where = absent;
    missing[where].push_back(id);
  }
  for (const auto& [where, ids] : missing)
    problems.push_back(
        fmt::format("{} cell(s) missing, from {}: {}", ids.size(), where, name_some(ids)));
  return owner;
}

// Hard links where the filesystem allows (the files of a finished cell are never written again),
// else copies.
void link_or_copy(const std::filesystem::path& from, const std::filesystem::path& to) {
  std::filesystem::create_directories(to);
  for (const auto& entry : std::filesystem::recursive_directory_iterator(from)) {
    const std::filesystem::path target = to / std::filesystem::relative(entry.path(), from);
    if (entry.is_directory()) {
      std::filesystem::create_directories(target);
      continue;
    }
    std::error_code ec;
    std::filesystem::create_hard_link(entry.path(), target, ec);
    if (ec) std::filesystem::copy_file(entry.path(), target);
  }
}

// One value where every shard agrees; the distinct values joined by " | " where they differ.
json common_value(const std::vector<ShardRun>& shards, const std::string& key) {
  std::vector<json> values;
  for (const ShardRun& s : shards)
    if (std::find(values.begin(), values.end(), s.run.value(key, json())) == values.end())
      values.push_back(s.run.value(key, json()));
  if (values.size() == 1) return values.front();
  std::vector<std::string> texts;
  for (const json& v : values) texts.push_back(v.is_string() ? v.get<std::string>() : v.dump());
  const std::string joined = fmt::format("{}", fmt::join(texts, " | "));
  std::fprintf(stderr, "merge: warning: the shards differ in %s: %s\n", key.c_str(),
               joined.c_str());
  return joined;
}

json merged_run_record(const std::vector<ShardRun>& shards, size_t cells) {
  json run = shards.front().run;
  run.erase("shard");
  run.erase("resumed");
  for (const char* key :
       {"tool_version", "git_commit", "device", "driver", "cpu", "cpu_count", "os", "timing"})
    run[key] = common_value(shards, key);
  run["cells"] = cells;
  json start, end;
  bool all_ended = true;
  run["shards"] = json::array();
  for (const ShardRun& s : shards) {
    const json& r = s.run;
    if (r.value("start", json()).is_string() && (start.is_null() || r["start"] < start))
      start = r["start"];
    if (!r.value("end", json()).is_string())
      all_ended = false;
    else if (end.is_null() || r["end"] > end)
      end = r["end"];
    json entry = {{"index", s.shard["index"]},
                  {"count", s.shard["count"]},
                  {"dir", s.dir.string()},
                  {"cells", s.shard.value("cells", json::array()).size()},
                  {"estimated_share", s.shard.value("estimated_share", json())},
                  {"host", s.shard.value("host", json())}};
    for (const char* key :
         {"device", "driver", "cpu", "cpu_count", "os", "start", "end", "resumed"})
      if (r.contains(key)) entry[key] = r[key];
    if (s.shard.contains("slurm")) entry["slurm"] = s.shard["slurm"];
    run["shards"].push_back(entry);
  }
  std::sort(run["shards"].begin(), run["shards"].end(),
            [](const json& a, const json& b) { return a["index"] < b["index"]; });
  run["start"] = start;
  run["end"] = all_ended ? end : json();  // a shard stopped early: its own end is unknown
  run["merged"] = now_iso();
  return run;
}

}  // namespace

int merge_runs(const std::filesystem::path& out, const std::vector<std::filesystem::path>& dirs) {
  std::vector<std::string> problems;
  if (std::filesystem::exists(out / "run.json"))
    problems.push_back(
        fmt::format("{} already holds a run; merge into a new folder", out.string()));
  std::vector<ShardRun> shards = read_shards(dirs, problems);
  check_same_plan(shards, problems);
  const std::map<std::string, const ShardRun*> owner = place_cells(shards, problems);
  if (shards.empty() && problems.empty()) problems.push_back("no shard run folders given");
  if (!problems.empty())
    throw InputError(fmt::format("merge: nothing written to {}:\n  {}", out.string(),
                                 fmt::join(problems, "\n  ")));

  std::filesystem::create_directories(out / "cells");
  std::filesystem::create_directories(out / "logs");
  int failed = 0;
  std::vector<std::string> failures;
  for (const auto& [id, shard] : owner) {
    // Into a partial folder first, as a running cell is, so that an interrupted merge never leaves
    // a cell folder that looks complete.
    const std::filesystem::path partial = partial_cell_dir(out, id);
    std::filesystem::remove_all(partial);
    std::filesystem::remove_all(cell_dir(out, id));
    link_or_copy(cell_dir(shard->dir, id), partial);
    std::filesystem::rename(partial, cell_dir(out, id));
    const std::filesystem::path log = shard->dir / "logs" / (id + ".log");
    if (std::filesystem::exists(log))
      std::filesystem::copy_file(log, out / "logs" / (id + ".log"),
                                 std::filesystem::copy_options::overwrite_existing);
    const json record = json::parse(io::read_text(cell_dir(out, id) / "cell.json"));
    if (record.value("status", "") != "ok") {
      ++failed;
      failures.push_back(fmt::format("{}: {}", id, record.value("reason", "?")));
    }
  }
  io::write_text_atomic(out / "invocation.json",
                        io::read_text(shards.front().dir / "invocation.json"));
  write_summary(out);
  const json merged = merged_run_record(shards, owner.size());
  io::write_text_atomic(out / "run.json", merged.dump(2) + "\n");  // last: the merge is complete

  std::fprintf(stderr, "merge: %zu shards, %zu cells, %d failed -> %s\n", shards.size(),
               owner.size(), failed, out.string().c_str());
  auto text = [](const json& value) { return value.is_string() ? value.get<std::string>() : "?"; };
  for (const json& s : merged["shards"])
    std::fprintf(stderr, "  shard %s/%s on %s: %s cells, %s to %s\n", s["index"].dump().c_str(),
                 s["count"].dump().c_str(), text(s["host"]).c_str(), s["cells"].dump().c_str(),
                 text(s.value("start", json())).c_str(), text(s.value("end", json())).c_str());
  for (const std::string& f : failures) std::fprintf(stderr, "  FAILED %s\n", f.c_str());
  std::fprintf(stderr, "merge: summary %s\n", (out / "summary.csv").string().c_str());
  return failed ? 1 : 0;
}

}  // namespace pb::run
