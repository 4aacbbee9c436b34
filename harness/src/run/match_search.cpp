#include "run/match_search.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace pb::run {

const char* match_status_name(MatchStatus status) {
  switch (status) {
    case MatchStatus::matched:
      return "matched";
    case MatchStatus::unreachable:
      return "unreachable";
    case MatchStatus::not_converged:
      return "not_converged";
    case MatchStatus::below_floor:
      return "below_floor";
    case MatchStatus::failed:
      return "failed";
  }
  return "?";
}

namespace {

// The middle of [a, b] on the knob's scale.
double knob_middle(const KnobSpace& space, double a, double b) {
  return space.log ? std::sqrt(a * b) : (a + b) / 2;
}

// The index of the probe closest to the target (relative distance), among those measured.
std::optional<size_t> closest_probe(const std::vector<SearchProbe>& probes, double target) {
  std::optional<size_t> best;
  for (size_t i = 0; i < probes.size(); ++i) {
    if (!probes[i].measured.value) continue;
    const double d = std::abs(*probes[i].measured.value - target);
    if (!best || d < std::abs(*probes[*best].measured.value - target)) best = i;
  }
  return best;
}

std::string range_reached(const std::vector<SearchProbe>& probes) {
  double lo = INFINITY, hi = -INFINITY;
  std::string lo_knob, hi_knob;
  for (const SearchProbe& p : probes) {
    if (!p.measured.value) continue;
    if (*p.measured.value < lo) lo = *p.measured.value, lo_knob = p.knob_text;
    if (*p.measured.value > hi) hi = *p.measured.value, hi_knob = p.knob_text;
  }
  return fmt::format("{:.4g} (at {}) to {:.4g} (at {})", lo, lo_knob, hi, hi_knob);
}

}  // namespace

SearchResult search_knob(const KnobSpace& space, const SearchTarget& target, double start,
                         const std::function<Measured(const std::string& knob_text)>& measure) {
  SearchResult result;
  // The bracket: the probe whose knob is too low for the target (measured on the side a lower knob
  // gives) and the one too high, as indices into result.probes.
  std::optional<size_t> below, above;
  double x = std::stod(knob_text(space, start));
  // Toward the target the step grows: a factor of 2, then 4, 8, ... on a log knob; a sixteenth of
  // the range, then twice that, ... on a linear one.
  double step = (space.hi - space.lo) / 16, factor = 2;
  auto finish = [&](MatchStatus status, std::string reason) {
    result.status = status;
    result.reason = std::move(reason);
    if (status != MatchStatus::matched) result.best = closest_probe(result.probes, target.value);
    return result;
  };
  while (true) {
    const std::string text = knob_text(space, x);
    result.probes.push_back({std::stod(text), text, measure(text)});
    const SearchProbe& probe = result.probes.back();
    if (!probe.measured.value) return finish(probe.measured.stop, probe.measured.reason);
    const double y = *probe.measured.value;
    if (std::abs(y - target.value) <= target.tolerance * std::abs(target.value)) {
      result.best = result.probes.size() - 1;
      return finish(MatchStatus::matched, "");
    }
    // The knob must grow when the value is short of the target and grows with the knob.
    const bool knob_too_low = (y < target.value) == (target.direction > 0);
    (knob_too_low ? below : above) = result.probes.size() - 1;
    if (result.probes.size() >= target.max_probes)
      return finish(MatchStatus::not_converged,
                    fmt::format("{} probes, none within {:g}% of the target {:g}; the closest is "
                                "kept",
                                result.probes.size(), 100 * target.tolerance, target.value));
    double next;
    if (below && above) {
      next = knob_middle(space, result.probes[*below].knob, result.probes[*above].knob);
    } else {
      next = space.log ? (knob_too_low ? x * factor : x / factor)
                       : (knob_too_low ? x + step : x - step);
      step *= 2;
      factor *= 2;
    }
    next = std::stod(knob_text(space, next));
    // No untried value left toward the target: the range's end, or a bracket of adjacent values.
    const bool tried = std::any_of(result.probes.begin(), result.probes.end(),
                                   [&](const SearchProbe& p) { return p.knob == next; });
    if (tried) {
      if (below && above)
        return finish(
            MatchStatus::not_converged,
            fmt::format("the bracket [{}, {}] holds no untried value; the closest "
                        "probe is kept",
                        result.probes[*below].knob_text, result.probes[*above].knob_text));
      return finish(MatchStatus::unreachable,
                    fmt::format("no value in [{}, {}] reaches {:g}: the probes reached {}",
                                knob_text(space, space.lo), knob_text(space, space.hi),
                                target.value, range_reached(result.probes)));
    }
    x = next;
  }
}

}  // namespace pb::run
