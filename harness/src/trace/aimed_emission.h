// Aimed emission, the photon tracer's density policy for techniques that keep only photons whose
// first interaction was specular (L S ...: caustic and caustic-indirect photons), where a light
// path whose first hit is diffuse is traced for nothing: the reference renderer's photon mapping
// (src/reference/README.md "Aimed emission") and any technique, through
// PhotonTracer::aimed_emission_densities (photonbench/photons.h).
// aimed_emission_densities gives each delta-origin emitter (point, spot, directional) an emission
// density (photons.h, EmissionDensity) that is 1 on every texel of its emission domain whose rays
// may reach a specular surface and 0 elsewhere; the photon tracer divides each photon's power by
// the density, so every path that can start with a specular hit keeps its expected power and only
// paths that cannot are dropped. "May reach" is decided conservatively, by bounding spheres of the
// specular triangles, never by sampling: a texel is dropped only when no ray of it can meet one,
// whatever lies in between. Area emitters (quad, disc, emissive mesh) draw directions apart from
// their domain's positions, so they keep uniform emission.
#pragma once

#include <optional>
#include <vector>

#include "photonbench/photons.h"
#include "trace/embree_scene.h"

namespace pb::trace {

// Texels per side of each aimed density.
inline constexpr int kAimResolution = 128;

// One entry per emitter, in LightSet order (the photon tracer's light indices): its aimed
// density, or nothing (uniform emission) for area emitters and for emitters from which no
// specular surface can be reached. Runs its texels in parallel (call it inside a task arena to
// bound the threads).
std::vector<std::optional<EmissionDensity>> aimed_emission_densities(const EmbreeScene& world);

}  // namespace pb::trace
