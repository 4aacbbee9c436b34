// photon-differentials' one binding list and push block (every pass declares all of them, so the
// C++ side binds one resource list), and the helpers footprint.h mirrors on the CPU. Bindings
// PD_BVH_BINDING .. + 3 are the toolkit BVH's walk (BoxBvh::walk_resources over `boxes`): the
// query includes toolkit/bvh/bvh_walk.glsl there.
#include "../pd_layout.h"
#include "photonbench/photon_layout.h"
#include "photonbench/scene_layout.h"
#include "photonbench/toolkit/box_bvh_layout.h"
#include "photonbench/toolkit/limits.h"

layout(std430, binding = 0) readonly buffer Photons { PhotonRecord photons[]; };
layout(std430, binding = 1) buffer Footprints { PdFootprint footprints[]; };  // photon order
layout(std430, binding = 2) buffer Boxes { BvhBox boxes[]; };  // photon order: the BVH's items
layout(std430, binding = 3) coherent buffer Control { uint control[]; };
layout(std430, binding = 4) buffer Partials { float partials[]; };  // footprint area per group
// The footprints in the BVH's Morton order (BoxBvh::items()), so a leaf's are read in sequence.
layout(std430, binding = 5) buffer Sorted { PdFootprint sorted_footprints[]; };
#define PD_BVH_BINDING 6
#define PB_GBUFFER_BINDING 10
#include "toolkit/gbuffer.glsl"
layout(binding = 13, rgba32f) writeonly uniform image2D radiance;

layout(push_constant) uniform Push { PdPush push; };

#define PD_PI 3.14159265358979
