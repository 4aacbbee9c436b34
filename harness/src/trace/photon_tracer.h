// The photon tracer over an EmbreeScene (the public interface is photonbench/photons.h).
//
// Emission: paths are shared among emitters in proportion to their power (largest remainder, so the
// split is exact and deterministic); path j of emitter l uses Sobol sample j scrambled with
// hash(seed, l): dimension group 0 picks the point of the emission domain (through the emitter's
// density texture, if any) and the direction of surface emitters, group 1 + k drives interaction k
// (two dimensions for the direction, one for the lobe, one for Russian roulette).
//
// Scattering: importance-sampled BSDF (bsdf.h, importance transport), flux update
// Phi' = Phi f cos / p (Paper I eq. 1), then Russian roulette with survival probability
// R = min(1, max(Phi') / max(Phi)) and Phi <- Phi' / R, which keeps the expected power and keeps
// the stored photons at roughly equal power (Paper I §5).
//
// Footprints: photon differentials (Schjoth et al. 2007; Igehy 1999 for the transfer, reflection
// and refraction formulas) with respect to the two emission-domain coordinates, scaled by the
// photon spacing 1 / sqrt(N density). Through specular chains they follow the surface curvature
// (the derivative of the interpolated normal); after a diffuse bounce the derivatives restart from
// the cosine-sampling map of that bounce with spacing 1 / sqrt(N) -- a coarse estimate, as the
// position a diffusely scattered photon came from no longer determines where it lands.
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include "photonbench/photons.h"
#include "trace/embree_scene.h"
#include "trace/sampling.h"

namespace pb::trace {

namespace detail {
struct TracerScratch;  // photon_paths.h
struct Context;
}  // namespace detail
class LightSet;

class EmbreePhotonTracer final : public PhotonTracer {
 public:
  // With `seed_scramble`, every trace's seed is hash_combine(settings.seed, *seed_scramble): a seed
  // axis' cell (cell/world.cpp) traces photons independent of the other seeds' while the techniques
  // keep their own settings. Without, settings.seed is used as it is.
  explicit EmbreePhotonTracer(const EmbreeScene& world,
                              std::optional<uint32_t> seed_scramble = std::nullopt);
  ~EmbreePhotonTracer() override;
  uint32_t light_count() const override;
  glm::vec3 light_power(uint32_t light) const override;
  EmitterInfo light(uint32_t light) const override;
  void set_emission_density(uint32_t light, const EmissionDensity* density) override;
  std::vector<std::optional<EmissionDensity>> aimed_emission_densities() const override;
  TraceStats trace(const TraceSettings& settings, PhotonBatch& out) override;
  TraceStats retrace_invalid(const TraceSettings& settings, PhotonBatch& batch) override;
  TraceStats verify_paths(const TraceSettings& settings, const ReuseSettings& reuse,
                          PhotonBatch& batch) override;
  TraceStats update_origins(const TraceSettings& settings, const ReuseSettings& reuse,
                            PhotonBatch& batch) override;
  TraceStats retrace_marked(const TraceSettings& settings, PhotonBatch& batch) override;

  // Paths per emitter for `paths` in total: proportional to power by largest remainder, at least
  // one for every emitter with power when there are enough paths.
  static std::vector<uint32_t> split_paths(const std::vector<float>& powers, uint32_t paths);

 private:
  // The seed light paths are traced with (before the per-frame hash of seed_per_frame).
  uint32_t path_seed(const TraceSettings& settings) const;
  // The seed of this frame's paths: path_seed, hashed with the frame where seed_per_frame.
  uint32_t frame_seed(const TraceSettings& settings) const;
  // The paths' shared context, its per-light sample seeds prepared.
  detail::Context trace_context(const TraceSettings& settings, const LightSet& lights,
                                uint32_t seed, const std::vector<uint32_t>& emission_count) const;
  const EmbreeScene& world_;
  std::optional<uint32_t> seed_scramble_;
  std::unique_ptr<detail::TracerScratch> scratch_;
  std::vector<std::shared_ptr<const Distribution2D>> densities_;
  std::vector<uint32_t> density_version_;
  // A trace whose emissions an EmissionSampler lists (TraceSettings::emission).
  TraceStats trace_sampled(const TraceSettings& settings, PhotonBatch& out);
};

std::unique_ptr<PhotonTracer> make_photon_tracer(
    const EmbreeScene& world, std::optional<uint32_t> seed_scramble = std::nullopt);

}  // namespace pb::trace
