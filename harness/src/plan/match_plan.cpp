#include "plan/match_plan.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "photonbench/error.h"

namespace pb::run {

namespace {

const pb_param_spec* match_param_spec(const pb_technique_descriptor& d, const std::string& name) {
  for (uint32_t i = 0; i < d.param_count; ++i)
    if (name == d.params[i].name) return &d.params[i];
  return nullptr;
}

std::string match_budget_names(const pb_technique_descriptor& d) {
  std::vector<std::string> names;
  for (uint32_t i = 0; i < d.budget_count; ++i) names.push_back(d.budget[i].param);
  return fmt::format("{}", fmt::join(names, ", "));
}

// A list of more than one value at params.<knob> of `params` (a technique or scene entry's): the
// search chooses the knob's values, so a sweep of it is bad input at that key.
void refuse_knob_sweep(const std::optional<config::YamlView>& params, const std::string& knob) {
  if (!params) return;
  if (auto value = params->get(knob); value && value->elements().size() > 1)
    value->fail(fmt::format(
        "'{}' is the knob this match searches: the search chooses its values; give one value "
        "(the first probe) or none (the default)",
        knob));
}

// The knob of technique entry `t`, each error at the key that named it.
std::string resolve_match_knob(const config::Config& config, size_t t,
                               const pb_technique_descriptor& d) {
  const config::TechniqueEntry& entry = config.techniques[t];
  const config::MatchSettings& match = *config.match;
  if (d.budget_count == 0)
    entry.node["technique"].fail(fmt::format(
        "technique '{}' declares no budget knob, so a match has nothing to turn (photonbench list "
        "techniques shows each technique's); give it `match: false` to run it at its config values "
        "as an unmatched baseline",
        d.name));
  std::optional<config::YamlView> named = entry.node.get("knob");
  if (!named) named = match.node.get("knob");
  if (!named) return d.budget[0].param;
  const std::string knob = named->as_string();
  if (!find_budget_knob(d, knob))
    named->fail(fmt::format("'{}' is not a budget knob of technique '{}' (its budget knobs: {})",
                            knob, d.name, match_budget_names(d)));
  return knob;
}

// The search space of the knob: the schema's range, narrowed by knob_range.
KnobSpace match_knob_space(const config::TechniqueEntry& entry, const pb_param_spec& spec,
                           const pb_budget_knob& knob) {
  KnobSpace space{spec.min_value, spec.max_value, spec.type == PB_PARAM_INT,
                  knob.scale == PB_SCALE_LOG};
  if (entry.knob_range.empty()) return space;
  if (entry.knob_range[0] < spec.min_value || entry.knob_range[1] > spec.max_value)
    entry.node["knob_range"].fail(fmt::format("[{}, {}] is outside the range of '{}', [{}, {}]",
                                              entry.knob_range[0], entry.knob_range[1], knob.param,
                                              spec.min_value, spec.max_value));
  space.lo = entry.knob_range[0];
  space.hi = entry.knob_range[1];
  if (space.integer && std::ceil(space.lo) > std::floor(space.hi))
    entry.node["knob_range"].fail("holds no whole number");
  return space;
}

}  // namespace

std::string knob_text(const KnobSpace& space, double value) {
  value = std::clamp(value, space.lo, space.hi);
  if (space.integer) {
    double whole = std::round(value);
    if (whole < space.lo) whole = std::ceil(space.lo);
    if (whole > space.hi) whole = std::floor(space.hi);
    return fmt::format("{}", int64_t(whole));
  }
  return fmt::format("{}", value);
}

Cell with_knob(const Cell& base, const std::string& knob, const std::string& value_text,
               uint32_t seeds) {
  std::map<std::string, std::string> params = base.params;
  params[knob] = value_text;
  Cell cell = make_cell(base.scene_file, base.technique, params);
  cell.entry = base.entry;
  cell.seed = base.seed;
  cell.seed_index = base.seed_index;
  cell.seed_group = cell.id;
  if (seeds > 1) cell.id = fmt::format("{}__seed{}", cell.id, cell.seed);
  return cell;
}

MatchPlan plan_matches(const RunPlan& plan) {
  MatchPlan out;
  const config::Config& config = plan.config;
  if (!config.match) return out;
  const bool quality = config.match->at == config::MatchSettings::At::quality;
  for (const Cell& cell : plan.cells) {
    const config::TechniqueEntry& entry = config.techniques[cell.entry];
    if (!entry.matched) {
      out.unmatched.push_back(cell);
      continue;
    }
    if (cell.seed_index != 0) continue;  // the search probes seed index 0; seeds come at the end
    MatchTarget target{cell, "", {}, 1};
    const Plugin* plugin = plan.plugins->find(cell.technique);
    if (!plugin || !plugin->loaded()) {  // its start cell fails with the loader's error
      out.matches.push_back(std::move(target));
      continue;
    }
    const pb_technique_descriptor& d = *plugin->descriptor;
    target.knob = resolve_match_knob(config, cell.entry, d);
    const pb_budget_knob& knob = *find_budget_knob(d, target.knob);
    if (quality && knob.error == PB_BUDGET_MIXED)
      (entry.node.get("knob") ? entry.node["knob"] : config.match->node["at"])
          .fail(fmt::format(
              "the error of technique '{}' is not monotone in '{}' (it trades variance for bias), "
              "so no search can match it at a quality; name another budget knob ({})",
              d.name, target.knob, match_budget_names(d)));
    refuse_knob_sweep(entry.node.get("params"), target.knob);
    for (const config::SceneEntry& scene : config.scenes)
      if (scene.node.is_map()) refuse_knob_sweep(scene.node.get("params"), target.knob);
    target.space = match_knob_space(entry, *match_param_spec(d, target.knob), knob);
    target.direction = (quality ? knob.error : knob.cost) == PB_BUDGET_GROWS ? 1 : -1;
    // The first probe: the config's value (or the default), moved inside knob_range.
    const double value = std::stod(cell.params.at(target.knob));
    target.start = with_knob(cell, target.knob, knob_text(target.space, value), config.seeds);
    out.matches.push_back(std::move(target));
  }
  return out;
}

}  // namespace pb::run
