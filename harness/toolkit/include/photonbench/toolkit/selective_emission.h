// Selective photon emission, seed 001 Ch. 9 (Larsen's thesis, 2004, modified from its reference
// [35]): photons leave each light from fixed quasi-random emission points, the same every frame,
// split into groups; each frame one photon per group is traced again (a probe, round robin through
// the group) and compared with the path kept for it, and a group whose probe diverged is traced
// again whole. Every stored photon's power is kept per surface (the thesis keeps a photon map per
// surface), and a re-traced path's old photons leave their surfaces before its new ones arrive, so
// the per-surface sums stay those of the kept paths exactly. A policy for any technique: it names
// no technique and traces through the public PhotonTracer (an EmissionSampler with
// keep_light_paths).
//
// Emission (Ch. 9: groups of "similar initial directions" from a Halton sequence): photon j of a
// light sits at the Halton point (radical inverse of j in halton_bases[0], in halton_bases[1]) of
// the light's emission domain (photonbench/photons.h, EmissionDensity). The thesis does not state
// how it groups; here a group is a first-level Halton cell: the first digit of j's radical inverse
// in base b is j mod b, so photon j lies in cell (j mod b0, j mod b1), and for coprime bases (the
// Chinese remainder theorem) group g = j mod (b0 b1) is exactly the photons of cell (g mod b0,
// g mod b1). The defaults, bases 7 and 11 and 40 photons a group, give the thesis's 77 groups x 40
// (Ch. 14). Surface emitters (quad, disc, emissive objects) also need a direction: it comes from
// the radical inverses of j + 1 in the two smallest primes coprime with both bases (j + 1: the
// first photon would otherwise leave at grazing angle). Each light emits the same set
// (Ch. 9: "one photon per group per light").
//
// Divergence (Ch. 9: "if the newly traced path diverges from the previous path, all photons from
// the group will be marked for redistribution"; the thesis gives no tolerance): the probe's path
// diverged when its sequence of hit objects differs (length, escape included), a stored photon's
// triangle differs, or a vertex (the light's origin included) moved more than
// divergence_tolerance. A moving light thus invalidates all its groups every frame, as the thesis
// says. A light's power change, or a change in the number of lights, traces everything afresh.
//
// The bounces of path j draw the tracer's sample sequence of its emission index with a fixed seed
// (seed_per_frame off), so a path traced again in an unchanged scene is bit-identical, and a
// re-traced group equals a fresh trace of the same emission points.
//
//   SelectiveEmission selective(tracer, settings, surface_of_triangle);  // chart ids, or {}
//   each frame, after world.update: SelectiveEmissionStats s = selective.update();
//   selective.ledger().watts(surface), selective.changed_surfaces(), selective.photons()
#pragma once

#include <array>
#include <cstdint>
#include <glm/glm.hpp>
#include <glm/gtc/type_precision.hpp>
#include <span>
#include <string>
#include <vector>

#include "photonbench/param_table.h"
#include "photonbench/photons.h"
#include "photonbench/plugin.h"

namespace pb::toolkit {

// The radical inverse of i in `base` (>= 2): i's digits mirrored about the radix point.
double radical_inverse(uint64_t i, uint32_t base);

struct SelectiveEmissionSettings {
  std::array<uint32_t, 2> halton_bases{7, 11};  // coprime, each >= 2: the groups' Halton cells
  uint32_t group_size = 40;                     // photons per group (per light)
  float divergence_tolerance = 1e-3f;           // metres a probe's hit may move and still agree
  // max_bounces, store, rr_start and seed; the emission, keep_light_paths and seed_per_frame are
  // the policy's own, paths and photon_target are unused (an emission sampler's trace), and a
  // vertex policy is refused by the tracer (kept paths go with its own decisions).
  trace::TraceSettings trace;
};

// "" or "<key>: why" (keys halton_bases, group_size, divergence_tolerance).
std::string check_selective_emission(const SelectiveEmissionSettings& settings);

// The settings as a technique's parameter rows, declared once so that every technique offering
// the policy names and bounds them alike: its params struct derives from SelectiveEmissionParams
// and binds each row to the inherited field, e.g.
//   struct MyParams : pb::toolkit::SelectiveEmissionParams { ... };
//   pb::bind(tk::kGroupSizeParam,
//            pb::base_field<MyParams>(&tk::SelectiveEmissionParams::group_size))
// The docs' "selective:" marks rows read only while selective emission is on.
struct SelectiveEmissionParams {
  uint32_t halton_base_1 = 7;
  uint32_t halton_base_2 = 11;
  uint32_t group_size = 40;
  float divergence_tolerance = 1e-3f;

  // The policy's settings of these rows, tracing with `trace`.
  SelectiveEmissionSettings settings(const trace::TraceSettings& trace) const;
};
// clang-format off
inline constexpr auto kSelectiveEmissionParams = pb::params(
    pb::param("halton_base_1", &SelectiveEmissionParams::halton_base_1, 7, {2, 997}, "",
              "selective: the Halton base of the emission domain's first coordinate; with "
              "halton_base_2 coprime, the groups are its first-level cells (Ch. 9)"),
    pb::param("halton_base_2", &SelectiveEmissionParams::halton_base_2, 11, {2, 997}, "",
              "selective: the Halton base of the second coordinate (7 x 11 = the thesis's 77 "
              "groups, Ch. 14)"),
    pb::param("group_size", &SelectiveEmissionParams::group_size, 40, {1, 1e6}, "photons",
              "selective: photons per group and light; each is probed once in group_size frames "
              "(Ch. 14: 40)"),
    pb::param("divergence_tolerance", &SelectiveEmissionParams::divergence_tolerance, 1e-3,
              {0, 1e3}, "m",
              "selective: how far a probe's hit may move and its path still agree with the kept "
              "one (the thesis gives none)"));
// clang-format on
static_assert(kSelectiveEmissionParams.member_defaults_match());
inline constexpr pb_param_spec kHaltonBase1Param = kSelectiveEmissionParams.row("halton_base_1");
inline constexpr pb_param_spec kHaltonBase2Param = kSelectiveEmissionParams.row("halton_base_2");
inline constexpr pb_param_spec kGroupSizeParam = kSelectiveEmissionParams.row("group_size");
inline constexpr pb_param_spec kDivergenceToleranceParam =
    kSelectiveEmissionParams.row("divergence_tolerance");

// check_selective_emission of the rows' values, "<row>: why" naming the row at fault (of the two
// bases, the one below 2, else the second for bases that share a factor).
std::string check_selective_emission_params(const SelectiveEmissionParams& params);

// Per update; report() below emits them as a technique's counters.
struct SelectiveEmissionStats {
  uint64_t probes = 0;              // paths traced to test their group
  uint64_t groups_invalidated = 0;  // groups whose probe diverged
  uint64_t paths_retraced = 0;      // kept paths replaced (every member of an invalidated group)
  uint64_t probe_rays = 0;          // rays of the probes
  uint64_t retrace_rays = 0;        // rays of the invalidated groups' other members (or all paths)
  bool traced_all = false;          // the first update, or the lights' count or power changed
  uint64_t rays() const { return probe_rays + retrace_rays; }
};

// The counters report() emits, for a technique's descriptor (.counters).
// clang-format off
inline constexpr pb_counter_spec kProbesCounter = {
    "probes", PB_COUNTER_WORK, "paths", "selective emission: paths traced to test their group"};
inline constexpr pb_counter_spec kGroupsInvalidatedCounter = {
    "groups_invalidated", PB_COUNTER_WORK, "groups",
    "selective emission: groups whose probe diverged from its kept path"};
inline constexpr pb_counter_spec kPathsRetracedCounter = {
    "paths_retraced", PB_COUNTER_WORK, "paths",
    "selective emission: kept paths replaced (invalidated groups, or all on a full trace)"};
inline constexpr pb_counter_spec kSelectiveRaysCounter = {
    "selective_rays", PB_COUNTER_WORK, "rays", "selective emission: rays of probes and re-traces"};
// clang-format on
inline constexpr std::array kSelectiveEmissionCounters = {
    kProbesCounter, kGroupsInvalidatedCounter, kPathsRetracedCounter, kSelectiveRaysCounter};
inline void report(Context& ctx, const SelectiveEmissionStats& s) {
  count(ctx, kProbesCounter, double(s.probes));
  count(ctx, kGroupsInvalidatedCounter, double(s.groups_invalidated));
  count(ctx, kPathsRetracedCounter, double(s.paths_retraced));
  count(ctx, kSelectiveRaysCounter, double(s.rays()));
}

// The per-surface energy of stored photons (the thesis's per-surface photon maps, Ch. 9: "the total
// energy of a surface is easily maintained"): 64-bit fixed point per channel, each photon's power
// rounded once to whole units, so adding and removing the same photons is exact and the sums are
// independent of the order (they equal a recomputation from the same photons bit for bit).
class SurfaceEnergyLedger {
 public:
  // `surface_of_triangle`: the caller's surface of each scene triangle (PhotonRecord::triangle),
  // e.g. chart ids (charts.h); empty: each triangle is its own surface.
  SurfaceEnergyLedger(std::vector<uint32_t> surface_of_triangle, double units_per_watt);
  uint32_t surface_of(const trace::PhotonRecord& photon) const;
  glm::i64vec3 units_of(const trace::PhotonRecord& photon) const;
  void add(const trace::PhotonRecord& photon);
  void remove(const trace::PhotonRecord& photon);
  // Sums per surface (index: surface id; surfaces never lit may be missing at the end).
  std::span<const glm::i64vec3> units() const { return units_; }
  glm::dvec3 watts(uint32_t surface) const;
  double units_per_watt() const { return units_per_watt_; }

 private:
  std::vector<uint32_t> surface_of_triangle_;
  double units_per_watt_ = 1;
  std::vector<glm::i64vec3> units_;
};

// The fixed emission points as an EmissionSampler: light l's photon j is emission l * N + j (N =
// photons per light); only the selected emissions are traced (the others get photon density 0:
// no ray, no photon), so a path keeps its emission index, and its bounces' samples, whatever else
// is traced with it.
class HaltonGroupEmission : public trace::EmissionSampler {
 public:
  HaltonGroupEmission(std::array<uint32_t, 2> bases, uint32_t group_size);
  uint32_t group_count() const { return bases_[0] * bases_[1]; }  // per light
  uint32_t photons_per_light() const { return group_count() * group_size_; }
  // The group of emission i: light * group_count() + (j mod group_count()).
  uint32_t group_of(uint64_t emission) const;
  // Emission of member m (< group_size) of group g.
  uint64_t member(uint32_t group, uint32_t m) const;
  glm::vec2 point(uint64_t emission) const;  // in the emission domain
  // Which emissions the next trace emits (size: lights * photons_per_light(); empty: all).
  void select(std::vector<uint8_t> selected) { selected_ = std::move(selected); }
  uint64_t prepare(const trace::EmissionFrame& frame) override;
  trace::EmissionPoint emission(uint64_t i) const override;

 private:
  std::array<uint32_t, 2> bases_, direction_bases_;
  uint32_t group_size_;
  uint32_t lights_ = 0;
  std::vector<uint8_t> selected_;
};

class SelectiveEmission {
 public:
  // Throws InputError naming the key for bad settings. `tracer` must outlive this.
  SelectiveEmission(trace::PhotonTracer& tracer, const SelectiveEmissionSettings& settings,
                    std::vector<uint32_t> surface_of_triangle = {});
  // Brings the kept paths to the tracer's current frame (call after the world's update).
  SelectiveEmissionStats update();

  const HaltonGroupEmission& emission() const { return sampler_; }
  uint32_t group_count() const { return sampler_.group_count() * lights_; }  // all lights
  uint32_t path_count() const { return uint32_t(kept_.size()); }
  std::span<const trace::PathVertex> path_vertices(uint32_t path) const { return kept_[path].v; }
  std::span<const trace::PhotonRecord> path_photons(uint32_t path) const {
    return kept_[path].photons;
  }
  std::vector<trace::PhotonRecord> photons() const;  // every kept photon, in path order
  const SurfaceEnergyLedger& ledger() const { return ledger_; }
  // Surfaces that lost or gained photons in the last update (ascending; every lit one after a
  // full trace).
  std::span<const uint32_t> changed_surfaces() const { return changed_; }
  // The paths the last update probed (one per group, ascending).
  std::span<const uint32_t> probed_paths() const { return probed_; }
  // The groups the last update invalidated (ascending).
  std::span<const uint32_t> invalidated_groups() const { return invalidated_; }

 private:
  struct Kept {
    std::vector<trace::PathVertex> v;
    std::vector<trace::PhotonRecord> photons;
  };
  // Traces the selected emissions (all when `selected` is empty) into `out`.
  trace::TraceStats trace_selected(std::vector<uint8_t> selected, trace::PhotonBatch& out);
  Kept kept_path(const trace::PhotonBatch& batch, uint32_t path) const;
  bool diverged(const Kept& kept, const Kept& now) const;
  void replace(uint32_t path, Kept now, std::vector<uint32_t>& touched);
  SelectiveEmissionStats trace_all();

  trace::PhotonTracer& tracer_;
  SelectiveEmissionSettings settings_;
  std::vector<uint32_t> surface_of_triangle_;
  HaltonGroupEmission sampler_;
  SurfaceEnergyLedger ledger_;
  uint32_t lights_ = 0;
  std::vector<glm::vec3> light_power_;  // at the last full trace
  std::vector<Kept> kept_;
  uint64_t round_ = 0;  // probing updates so far: round_ mod group_size is the probes' member
  std::vector<uint32_t> changed_, probed_, invalidated_;
};

}  // namespace pb::toolkit
