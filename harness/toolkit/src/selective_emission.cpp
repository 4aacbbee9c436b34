// Selective photon emission (seed 001 Ch. 9): selective_emission.h says what and why.
#include "photonbench/toolkit/selective_emission.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "photonbench/error.h"

namespace pb::toolkit {

double radical_inverse(uint64_t i, uint32_t base) {
  const double inv = 1.0 / base;
  double scale = inv, result = 0;
  for (; i > 0; i /= base, scale *= inv) result += double(i % base) * scale;
  return result;
}

std::string check_selective_emission(const SelectiveEmissionSettings& s) {
  const auto [b0, b1] = s.halton_bases;
  if (b0 < 2 || b1 < 2)
    return fmt::format("halton_bases: [{}, {}]: each base must be at least 2", b0, b1);
  if (std::gcd(b0, b1) != 1)
    return fmt::format(
        "halton_bases: [{}, {}] share the factor {}; the bases must be coprime, so that each "
        "group is one first-level Halton cell",
        b0, b1, std::gcd(b0, b1));
  if (s.group_size < 1) return "group_size: must be at least 1";
  if (uint64_t(b0) * b1 * s.group_size > (1u << 24))
    return fmt::format("group_size: {} groups of {} photons exceed 2^24 photons a light",
                       uint64_t(b0) * b1, s.group_size);
  if (!(s.divergence_tolerance >= 0) || !std::isfinite(s.divergence_tolerance))
    return fmt::format("divergence_tolerance: {} must be a finite number of metres >= 0",
                       s.divergence_tolerance);
  return "";
}

SelectiveEmissionSettings SelectiveEmissionParams::settings(
    const trace::TraceSettings& trace) const {
  SelectiveEmissionSettings s;
  s.halton_bases = {halton_base_1, halton_base_2};
  s.group_size = group_size;
  s.divergence_tolerance = divergence_tolerance;
  s.trace = trace;
  return s;
}

std::string check_selective_emission_params(const SelectiveEmissionParams& params) {
  std::string why = check_selective_emission(params.settings({}));
  // The settings' halton_bases are two rows here.
  const std::string_view bases = "halton_bases: ";
  if (why.starts_with(bases))
    why = std::string(params.halton_base_1 < 2 ? "halton_base_1: " : "halton_base_2: ") +
          why.substr(bases.size());
  return why;
}

// ---- SurfaceEnergyLedger

SurfaceEnergyLedger::SurfaceEnergyLedger(std::vector<uint32_t> surface_of_triangle,
                                         double units_per_watt)
    : surface_of_triangle_(std::move(surface_of_triangle)), units_per_watt_(units_per_watt) {}

uint32_t SurfaceEnergyLedger::surface_of(const trace::PhotonRecord& photon) const {
  if (surface_of_triangle_.empty()) return photon.triangle;
  if (photon.triangle >= surface_of_triangle_.size())
    throw Error(fmt::format(
        "surface energy ledger: a photon on triangle {}, but the surface map covers {} triangles",
        photon.triangle, surface_of_triangle_.size()));
  return surface_of_triangle_[photon.triangle];
}

glm::i64vec3 SurfaceEnergyLedger::units_of(const trace::PhotonRecord& photon) const {
  glm::i64vec3 u;
  for (int c = 0; c < 3; ++c) u[c] = std::llround(double(photon.power[c]) * units_per_watt_);
  return u;
}

void SurfaceEnergyLedger::add(const trace::PhotonRecord& photon) {
  const uint32_t s = surface_of(photon);
  if (s >= units_.size()) units_.resize(size_t(s) + 1, glm::i64vec3(0));
  units_[s] += units_of(photon);
}

void SurfaceEnergyLedger::remove(const trace::PhotonRecord& photon) {
  const uint32_t s = surface_of(photon);
  if (s >= units_.size())
    throw Error(fmt::format("surface energy ledger: no photon was added to surface {}", s));
  units_[s] -= units_of(photon);
}

glm::dvec3 SurfaceEnergyLedger::watts(uint32_t surface) const {
  return surface < units_.size() ? glm::dvec3(units_[surface]) / units_per_watt_ : glm::dvec3(0);
}

// ---- HaltonGroupEmission

namespace {
// The two smallest primes coprime with both bases: the direction's dimensions.
std::array<uint32_t, 2> direction_bases(std::array<uint32_t, 2> bases) {
  std::array<uint32_t, 2> out{0, 0};
  int found = 0;
  for (uint32_t p = 2; found < 2; ++p) {
    bool prime = true;
    for (uint32_t d = 2; d * d <= p && prime; ++d) prime = p % d != 0;
    if (prime && std::gcd(p, bases[0]) == 1 && std::gcd(p, bases[1]) == 1) out[found++] = p;
  }
  return out;
}
}  // namespace

HaltonGroupEmission::HaltonGroupEmission(std::array<uint32_t, 2> bases, uint32_t group_size)
    : bases_(bases), direction_bases_(direction_bases(bases)), group_size_(group_size) {}

uint32_t HaltonGroupEmission::group_of(uint64_t emission) const {
  const uint64_t n = photons_per_light();
  return uint32_t(emission / n) * group_count() + uint32_t(emission % n % group_count());
}

uint64_t HaltonGroupEmission::member(uint32_t group, uint32_t m) const {
  const uint32_t light = group / group_count(), cell = group % group_count();
  return uint64_t(light) * photons_per_light() + cell + uint64_t(m) * group_count();
}

glm::vec2 HaltonGroupEmission::point(uint64_t emission) const {
  const uint64_t j = emission % photons_per_light();
  return {float(radical_inverse(j, bases_[0])), float(radical_inverse(j, bases_[1]))};
}

uint64_t HaltonGroupEmission::prepare(const trace::EmissionFrame& frame) {
  lights_ = uint32_t(frame.emitters.size());
  const uint64_t total = uint64_t(lights_) * photons_per_light();
  if (!selected_.empty() && selected_.size() != total)
    throw Error(fmt::format("Halton group emission: a selection of {} emissions for {} lights x {}",
                            selected_.size(), lights_, photons_per_light()));
  return total;
}

trace::EmissionPoint HaltonGroupEmission::emission(uint64_t i) const {
  const uint64_t j = i % photons_per_light();
  trace::EmissionPoint p;
  p.light = uint32_t(i / photons_per_light());
  p.uv = point(i);
  p.direction = {float(radical_inverse(j + 1, direction_bases_[0])),
                 float(radical_inverse(j + 1, direction_bases_[1]))};
  const bool emitted = selected_.empty() || selected_[i];
  p.photon_density = emitted ? float(photons_per_light()) : 0.f;
  p.id = uint32_t(i);
  return p;
}

// ---- SelectiveEmission

namespace {
const SelectiveEmissionSettings& checked(const SelectiveEmissionSettings& s) {
  if (std::string why = check_selective_emission(s); !why.empty())
    throw InputError("selective emission: " + why);
  return s;
}
}  // namespace

SelectiveEmission::SelectiveEmission(trace::PhotonTracer& tracer,
                                     const SelectiveEmissionSettings& settings,
                                     std::vector<uint32_t> surface_of_triangle)
    : tracer_(tracer),
      settings_(checked(settings)),
      surface_of_triangle_(std::move(surface_of_triangle)),
      sampler_(settings.halton_bases, settings.group_size),
      ledger_(surface_of_triangle_, 1.0) {}

trace::TraceStats SelectiveEmission::trace_selected(std::vector<uint8_t> selected,
                                                    trace::PhotonBatch& out) {
  sampler_.select(std::move(selected));
  trace::TraceSettings s = settings_.trace;
  s.emission = &sampler_;
  s.keep_light_paths = true;
  s.seed_per_frame = false;  // a path's bounces draw the same samples every frame
  return tracer_.trace(s, out);
}

SelectiveEmission::Kept SelectiveEmission::kept_path(const trace::PhotonBatch& batch,
                                                     uint32_t path) const {
  const trace::LightPath& p = batch.paths.paths.at(path);
  Kept k;
  auto v = batch.paths.vertices.begin() + p.first_vertex;
  k.v.assign(v, v + p.vertex_count);
  auto ph = batch.photons.begin() + p.first_photon;
  k.photons.assign(ph, ph + p.photon_count);
  return k;
}

bool SelectiveEmission::diverged(const Kept& kept, const Kept& now) const {
  if (kept.v.size() != now.v.size() || kept.photons.size() != now.photons.size()) return true;
  for (size_t k = 0; k < kept.v.size(); ++k) {
    const trace::PathVertex &a = kept.v[k], &b = now.v[k];
    if (a.object != b.object || ((a.flags ^ b.flags) & trace::PathVertex::kEscapes)) return true;
    if (glm::distance(a.position, b.position) > settings_.divergence_tolerance) return true;
  }
  for (size_t i = 0; i < kept.photons.size(); ++i)
    if (kept.photons[i].triangle != now.photons[i].triangle) return true;
  return false;
}

void SelectiveEmission::replace(uint32_t path, Kept now, std::vector<uint32_t>& touched) {
  for (const auto& ph : kept_[path].photons) {
    ledger_.remove(ph);
    touched.push_back(ledger_.surface_of(ph));
  }
  for (const auto& ph : now.photons) {
    ledger_.add(ph);
    touched.push_back(ledger_.surface_of(ph));
  }
  kept_[path] = std::move(now);
}

SelectiveEmissionStats SelectiveEmission::trace_all() {
  lights_ = tracer_.light_count();
  light_power_.resize(lights_);
  float largest = 0;  // the largest channel an emitted photon carries
  for (uint32_t l = 0; l < lights_; ++l) {
    light_power_[l] = tracer_.light_power(l);
    const glm::vec3 p = light_power_[l];
    largest = std::max(largest, std::max(p.x, std::max(p.y, p.z)) / sampler_.photons_per_light());
  }
  trace::PhotonBatch batch;
  const trace::TraceStats traced = trace_selected({}, batch);
  // A photon's largest channel never exceeds its emitted one (roulette divides by the survival
  // ratio of the largest channel), so 2^40 units for it leaves 2^23 photons a surface before
  // the 64-bit sums could overflow, and resolves each photon to 2^-40 of its power.
  ledger_ =
      SurfaceEnergyLedger(surface_of_triangle_, largest > 0 ? std::ldexp(1.0, 40) / largest : 1.0);
  kept_.assign(batch.paths.paths.size(), {});
  changed_.clear();
  for (uint32_t i = 0; i < kept_.size(); ++i) replace(i, kept_path(batch, i), changed_);
  std::sort(changed_.begin(), changed_.end());
  changed_.erase(std::unique(changed_.begin(), changed_.end()), changed_.end());
  probed_.clear();
  invalidated_.clear();
  SelectiveEmissionStats stats;
  stats.traced_all = true;
  stats.paths_retraced = kept_.size();
  stats.retrace_rays = traced.rays;
  return stats;
}

SelectiveEmissionStats SelectiveEmission::update() {
  const uint32_t lights = tracer_.light_count();
  bool fresh = kept_.empty() || lights != lights_;
  for (uint32_t l = 0; !fresh && l < lights; ++l) fresh = tracer_.light_power(l) != light_power_[l];
  if (fresh) return trace_all();

  SelectiveEmissionStats stats;
  const uint32_t groups = group_count(), size = settings_.group_size;
  const uint32_t probe_member = uint32_t(round_++ % size);
  std::vector<uint8_t> selected(kept_.size(), 0);
  probed_.resize(groups);
  for (uint32_t g = 0; g < groups; ++g) {
    probed_[g] = uint32_t(sampler_.member(g, probe_member));
    selected[probed_[g]] = 1;
  }
  trace::PhotonBatch probes;
  stats.probes = groups;
  stats.probe_rays = trace_selected(selected, probes).rays;

  invalidated_.clear();
  for (uint32_t g = 0; g < groups; ++g)
    if (diverged(kept_[probed_[g]], kept_path(probes, probed_[g]))) invalidated_.push_back(g);
  stats.groups_invalidated = invalidated_.size();

  changed_.clear();
  if (!invalidated_.empty()) {
    // The probe's path is already fresh: trace the group's other members.
    trace::PhotonBatch others;
    if (size > 1) {
      std::fill(selected.begin(), selected.end(), 0);
      for (uint32_t g : invalidated_)
        for (uint32_t m = 0; m < size; ++m)
          if (m != probe_member) selected[sampler_.member(g, m)] = 1;
      stats.retrace_rays = trace_selected(selected, others).rays;
    }
    for (uint32_t g : invalidated_)
      for (uint32_t m = 0; m < size; ++m) {
        const uint32_t path = uint32_t(sampler_.member(g, m));
        replace(path, kept_path(m == probe_member ? probes : others, path), changed_);
      }
    stats.paths_retraced = uint64_t(invalidated_.size()) * size;
  }
  std::sort(changed_.begin(), changed_.end());
  changed_.erase(std::unique(changed_.begin(), changed_.end()), changed_.end());
  return stats;
}

std::vector<trace::PhotonRecord> SelectiveEmission::photons() const {
  std::vector<trace::PhotonRecord> out;
  for (const Kept& k : kept_) out.insert(out.end(), k.photons.begin(), k.photons.end());
  return out;
}

}  // namespace pb::toolkit
