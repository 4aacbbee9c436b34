#include "run/match.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "cell/cell_runner.h"
#include "cell/extra_cells.h"
#include "cell/stats.h"
#include "io/results.h"
#include "run/match_search.h"
#include "run/run_record.h"

namespace pb::run {

using json = nlohmann::json;

namespace {

// A cell the matches ran, and what it is to them.
struct MatchCell {
  Cell cell;
  std::string role;  // "probe", "seed", "round" or "baseline"
  json record;
};

// One match (or one baseline: no target) and the cells it ran.
struct MatchRecord {
  const MatchTarget* target = nullptr;  // null: a baseline (match: false)
  SearchResult search;
  std::vector<MatchCell> probes;   // in the order probed
  std::optional<MatchCell> found;  // the kept probe (or a baseline's cell), seed index 0
  std::vector<MatchCell> seeds;    // the found cell at the other seeds
  std::vector<MatchCell> rounds;   // its re-measurements
  std::string scene() const { return target ? target->start.scene : found->cell.scene; }
};

std::optional<double> json_number(const json& j) {
  if (j.is_number()) return j.get<double>();
  return std::nullopt;
}

// record[a][b]...: null where any step is missing or not an object (a failed cell's record).
json json_path(const json& record, std::initializer_list<const char*> keys) {
  const json* at = &record;
  for (const char* key : keys) {
    if (!at->is_object() || !at->contains(key)) return json();
    at = &(*at)[key];
  }
  return *at;
}

std::optional<double> combined_metric(const json& record, const std::string& name) {
  return json_number(json_path(record, {"metrics", "combined", name.c_str()}));
}

std::optional<double> frame_ms(const json& record, const char* statistic) {
  return json_number(json_path(record, {"summary", "frame_ms", statistic}));
}

std::string match_number_text(std::optional<double> value) {
  return value ? fmt::format("{:.6g}", *value) : "";
}

// Runs `cell` (an extra cell of the run unless the plan has it) as `role`.
MatchCell run_match_cell(const RunPlan& plan, CellRuns& runs, const Cell& cell,
                         const std::string& role) {
  if (!plan.find(cell.id)) add_extra_cell(runs.run_dir(), cell, role);
  return MatchCell{cell, role, runs.run(cell)};
}

// What a probe's record measured for the match: its median frame time, or its mean error (the
// target refused when it lies below kResolveFactor times that error's noise floor: a score there
// is not resolved from the reference's own noise).
Measured measure_probe(const config::MatchSettings& match, const MatchCell& probe) {
  const json& record = probe.record;
  if (record.value("status", "") != "ok")
    return {std::nullopt, MatchStatus::failed,
            fmt::format("probe cell {} failed: {}", probe.cell.id, record.value("reason", "?"))};
  if (match.at == config::MatchSettings::At::time) {
    if (auto median = frame_ms(record, "median")) return {median, MatchStatus::matched, ""};
    return {std::nullopt, MatchStatus::failed,
            fmt::format("probe cell {} measured no frame time", probe.cell.id)};
  }
  const std::optional<double> error = combined_metric(record, match.metric);
  if (!error)
    return {std::nullopt, MatchStatus::failed,
            fmt::format("probe cell {} scored no {}", probe.cell.id, match.metric)};
  const std::optional<double> floor = combined_metric(record, match.metric + "_floor");
  if (floor && match.value < kResolveFactor * *floor)
    return {std::nullopt, MatchStatus::below_floor,
            fmt::format("the target {} {:g} is below {:g}x the reference's noise floor {:.4g} "
                        "({:g}x = {:.4g}): a score there is not resolved from the reference's own "
                        "noise; aim at {:.4g} or above, or render the reference longer",
                        match.metric, match.value, kResolveFactor, *floor, kResolveFactor,
                        kResolveFactor * *floor, kResolveFactor * *floor)};
  return {error, MatchStatus::matched, ""};
}

MatchRecord search_match(const RunPlan& plan, CellRuns& runs, const MatchTarget& target) {
  const config::MatchSettings& match = *plan.config.match;
  MatchRecord m;
  m.target = &target;
  if (target.knob.empty()) {  // the plugin did not load: its start cell fails, saying why
    m.probes.push_back(run_match_cell(plan, runs, target.start, "probe"));
    m.search.status = MatchStatus::failed;
    m.search.reason = fmt::format("probe cell {} failed: {}", target.start.id,
                                  m.probes.back().record.value("reason", "?"));
    return m;
  }
  const bool time = match.at == config::MatchSettings::At::time;
  const SearchTarget goal{time ? match.frame_ms : match.value, match.tolerance, target.direction,
                          match.max_probes};
  m.search = search_knob(target.space, goal, std::stod(target.start.params.at(target.knob)),
                         [&](const std::string& value) {
                           const Cell cell =
                               with_knob(target.start, target.knob, value, plan.config.seeds);
                           m.probes.push_back(run_match_cell(plan, runs, cell, "probe"));
                           return measure_probe(match, m.probes.back());
                         });
  if (m.search.best && m.search.status != MatchStatus::below_floor &&
      m.search.status != MatchStatus::failed)
    m.found = m.probes[*m.search.best];
  std::fprintf(
      stderr, "[match] %s %s: %s %s after %zu probes%s%s\n", target.start.scene.c_str(),
      target.start.technique.c_str(), match_status_name(m.search.status),
      m.found ? fmt::format("at {} = {}", target.knob, m.found->cell.params.at(target.knob)).c_str()
              : "",
      m.probes.size(), m.search.reason.empty() ? "" : ": ", m.search.reason.c_str());
  return m;
}

// The found cell at seed indices 1 .. seeds - 1 (seed index 0 is the probe itself).
void run_found_seeds(const RunPlan& plan, CellRuns& runs, MatchRecord& m) {
  const uint32_t seeds = plan.config.seeds;
  if (!m.found || seeds <= 1) return;
  for (uint32_t i = 1; i < seeds; ++i) {
    Cell cell = m.found->cell;
    cell.seed_index = i;
    cell.seed = plan.config.seed + i;
    cell.id = fmt::format("{}__seed{}", cell.seed_group, cell.seed);
    if (const Cell* planned = plan.find(cell.id)) cell = *planned;
    m.seeds.push_back(run_match_cell(plan, runs, cell, "seed"));
  }
}

// Each scene's found cells and baselines, `rounds` times, forward then backward: round r runs
// "<found id>__round<r>", the same values again.
void run_rounds(const RunPlan& plan, CellRuns& runs, std::vector<MatchRecord>& records) {
  std::vector<std::string> scenes;
  for (const MatchRecord& m : records)
    if (m.found && std::find(scenes.begin(), scenes.end(), m.scene()) == scenes.end())
      scenes.push_back(m.scene());
  for (const std::string& scene : scenes) {
    std::vector<MatchRecord*> order;
    for (MatchRecord& m : records)
      if (m.found && m.scene() == scene) order.push_back(&m);
    for (uint32_t r = 1; r <= plan.config.match->rounds; ++r) {
      for (size_t k = 0; k < order.size(); ++k) {
        MatchRecord& m = *order[r % 2 == 1 ? k : order.size() - 1 - k];
        Cell cell = m.found->cell;
        cell.id = fmt::format("{}__round{}", m.found->cell.id, r);
        cell.seed_group = cell.id;  // the found cell's seed again: a re-measurement, not a seed
        m.rounds.push_back(run_match_cell(plan, runs, cell, "round"));
      }
    }
  }
}

// Every measured frame's time of a cell (frames.csv's "frame" rows).
std::vector<double> frame_times(const std::filesystem::path& run_dir, const std::string& id) {
  std::vector<double> times;
  const std::filesystem::path file = cell_dir(run_dir, id) / "frames.csv";
  if (!std::filesystem::exists(file)) return times;
  const auto rows = io::read_csv(file);
  for (size_t i = 1; i < rows.size(); ++i)
    if (rows[i].size() >= 4 && rows[i][1] == "frame" && !rows[i][3].empty())
      times.push_back(std::stod(rows[i][3]));
  return times;
}

// The achieved time: every frame of the ok rounds pooled (median, p5, p95, n); the found probe's
// own frames when there are no rounds.
json achieved_time(const std::filesystem::path& run_dir, const MatchRecord& m) {
  std::vector<double> times;
  for (const MatchCell& round : m.rounds)
    if (round.record.value("status", "") == "ok") {
      std::vector<double> t = frame_times(run_dir, round.cell.id);
      times.insert(times.end(), t.begin(), t.end());
    }
  if (m.rounds.empty() && m.found) times = frame_times(run_dir, m.found->cell.id);
  return describe(times);
}

std::vector<std::string> match_header(const config::Config& config) {
  std::vector<std::string> h = {"scene",
                                "technique",
                                "at",
                                "target",
                                "tolerance",
                                "knob",
                                "knob_value",
                                "status",
                                "probes",
                                "cell",
                                "wall_ms_median",
                                "wall_ms_p5",
                                "wall_ms_p95",
                                "wall_ms_n",
                                "rounds",
                                "probe_wall_ms_median"};
  for (const std::string& metric : config.metrics) {
    h.push_back(metric);
    h.push_back(metric + "_floor");
  }
  h.push_back("seeds");
  for (const std::string& metric : config.metrics) h.push_back(metric + "_seed_sd");
  h.push_back("reason");
  return h;
}

// The sample standard deviation of `metric` over the found cell's seeds (empty with one seed).
std::string seed_spread(const MatchRecord& m, const std::string& metric) {
  if (m.seeds.empty()) return "";
  std::vector<double> values;
  if (auto v = combined_metric(m.found->record, metric)) values.push_back(*v);
  for (const MatchCell& seed : m.seeds)
    if (auto v = combined_metric(seed.record, metric)) values.push_back(*v);
  if (values.size() < 2) return "";
  double mean = 0, sum = 0;
  for (double v : values) mean += v / double(values.size());
  for (double v : values) sum += (v - mean) * (v - mean);
  return match_number_text(std::sqrt(sum / double(values.size() - 1)));
}

std::vector<std::string> match_row(const config::Config& config,
                                   const std::filesystem::path& run_dir, const MatchRecord& m) {
  const config::MatchSettings& match = *config.match;
  const bool time = match.at == config::MatchSettings::At::time;
  const json achieved = achieved_time(run_dir, m);
  const std::string technique = m.target ? m.target->start.technique : m.found->cell.technique;
  std::vector<std::string> row = {
      m.scene(),
      technique,
      m.target ? (time ? "time" : "quality") : "baseline",
      m.target ? fmt::format("{:g}", time ? match.frame_ms : match.value) : "",
      m.target ? fmt::format("{:g}", match.tolerance) : "",
      m.target ? m.target->knob : "",
      m.found && m.target && !m.target->knob.empty() ? m.found->cell.params.at(m.target->knob) : "",
      m.target ? match_status_name(m.search.status) : "baseline",
      std::to_string(m.probes.size()),
      m.found ? m.found->cell.id : "",
      match_number_text(json_number(achieved.value("median", json()))),
      match_number_text(json_number(achieved.value("p5", json()))),
      match_number_text(json_number(achieved.value("p95", json()))),
      achieved.value("n", json(0)).dump(),
      std::to_string(m.rounds.size()),
      m.found ? match_number_text(frame_ms(m.found->record, "median")) : ""};
  for (const std::string& metric : config.metrics) {
    row.push_back(m.found ? match_number_text(combined_metric(m.found->record, metric)) : "");
    row.push_back(m.found ? match_number_text(combined_metric(m.found->record, metric + "_floor"))
                          : "");
  }
  row.push_back(std::to_string(m.found ? 1 + m.seeds.size() : 0));
  for (const std::string& metric : config.metrics) row.push_back(seed_spread(m, metric));
  row.push_back(m.search.reason);
  return row;
}

void write_match_csv(const config::Config& config, const std::filesystem::path& run_dir,
                     const std::vector<MatchRecord>& records) {
  std::string text = io::csv_row(match_header(config));
  for (const MatchRecord& m : records) text += io::csv_row(match_row(config, run_dir, m));
  io::write_text_atomic(run_dir / "match.csv", text);
}

// One row per cell the matches ran: the probes in order, then seeds and rounds.
void write_probes_csv(const config::Config& config, const std::filesystem::path& run_dir,
                      const std::vector<MatchRecord>& records) {
  std::vector<std::string> header = {"scene",          "technique",  "knob",       "role",
                                     "index",          "knob_value", "cell",       "status",
                                     "wall_ms_median", "wall_ms_p5", "wall_ms_p95"};
  for (const std::string& metric : config.metrics) {
    header.push_back(metric);
    header.push_back(metric + "_floor");
  }
  std::string text = io::csv_row(header);
  for (const MatchRecord& m : records) {
    const std::string knob = m.target ? m.target->knob : "";
    std::vector<const MatchCell*> cells;
    for (const MatchCell& c : m.probes) cells.push_back(&c);
    if (!m.target && m.found) cells.push_back(&*m.found);
    for (const MatchCell& c : m.seeds) cells.push_back(&c);
    for (const MatchCell& c : m.rounds) cells.push_back(&c);
    std::map<std::string, int> index;
    for (const MatchCell* c : cells) {
      std::vector<std::string> row = {c->cell.scene,
                                      c->cell.technique,
                                      knob,
                                      c->role,
                                      std::to_string(index[c->role]++),
                                      knob.empty() ? "" : c->cell.params.at(knob),
                                      c->cell.id,
                                      c->record.value("status", ""),
                                      match_number_text(frame_ms(c->record, "median")),
                                      match_number_text(frame_ms(c->record, "p5")),
                                      match_number_text(frame_ms(c->record, "p95"))};
      for (const std::string& metric : config.metrics) {
        row.push_back(match_number_text(combined_metric(c->record, metric)));
        row.push_back(match_number_text(combined_metric(c->record, metric + "_floor")));
      }
      text += io::csv_row(row);
    }
  }
  io::write_text_atomic(run_dir / "match_probes.csv", text);
}

}  // namespace

size_t match_cell_bound(const config::Config& config, const MatchPlan& matches) {
  if (!config.match) return 0;
  const size_t per_found = config.seeds - 1 + config.match->rounds;
  return matches.matches.size() * (config.match->max_probes + per_found) +
         matches.unmatched.size() * (1 + config.match->rounds);
}

MatchOutcome run_matches(const RunPlan& plan, const MatchPlan& matches, CellRuns& runs) {
  std::vector<MatchRecord> records;
  // Baselines first (match: false): at their config values, every seed of the plan.
  for (const Cell& cell : matches.unmatched) {
    MatchCell run = run_match_cell(plan, runs, cell, "baseline");
    if (cell.seed_index == 0) {
      MatchRecord m;
      m.found = std::move(run);
      records.push_back(std::move(m));
    } else {
      for (MatchRecord& m : records)
        if (!m.target && m.found->cell.seed_group == cell.seed_group)
          m.seeds.push_back(std::move(run));
    }
  }
  for (const MatchTarget& target : matches.matches) {
    records.push_back(search_match(plan, runs, target));
    run_found_seeds(plan, runs, records.back());
    write_match_csv(plan.config, runs.run_dir(), records);
    write_probes_csv(plan.config, runs.run_dir(), records);
  }
  run_rounds(plan, runs, records);
  write_match_csv(plan.config, runs.run_dir(), records);
  write_probes_csv(plan.config, runs.run_dir(), records);
  MatchOutcome outcome{runs.tally(), 0};
  for (const MatchRecord& m : records)
    outcome.unmatched += m.target && m.search.status != MatchStatus::matched;
  return outcome;
}

}  // namespace pb::run
