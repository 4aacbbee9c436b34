#version 460
// gather: classic photon mapping's density estimate per view sample (seed 003 §3.1; Jensen 1996).
// The k nearest photons within r_max that arrive from above the sample's tangent plane are found
// by searching the uniform grid in growing shells of cells around the sample's cell (search:
// grid), or seed 003's baseline, a balanced kd-tree walked near child first, far children only
// while their splitting plane lies within the bound (search: kdtree, Jensen's locate_photons),
// keeping the candidates in a fixed-size max-heap of k entries (the heap's top is the current
// k-th distance, which bounds the search once k are held: seed 003's "temporary set of k
// candidate hits ... updated as closer ones are found"), in the invocation's own array (heap:
// private) or in a storage buffer (heap: global, §7's "residing in slow global memory"). The
// bandwidth r is the radius of the found photons' bounding sphere around x, i.e. the k-th
// distance (fewer than k within r_max: r_max, or the farthest found, by `sparse`); L = (albedo /
// pi) * sum(Phi_i K_i) with K = 1 / (pi r^2) (uniform) or 2 / (pi r^2) (1 - d_i^2 / r^2)
// (Epanechnikov).
//
// Every loop step counts against push.budget (llvmpipe ends an invocation's loops after 65535
// iterations in all, silently): a query that reaches it stops where it is, is counted
// (KNN_STAT_TRUNCATED) and estimates from what it holds.
#define KNN_GATHER
#include "knn_common.glsl"
#include "toolkit/atomics.glsl"
layout(local_size_x = 8, local_size_y = 8) in;

float heap_d[KNN_MAX_K];  // squared distances; a max-heap on them (heap: private)
uint heap_i[KNN_MAX_K];   // the photons' places in `compact`
uint heap_n = 0u;
uint heap_base = 0u;     // heap: global, this query's first entry in heap_global
uint heap_touched = 0u;  // entries read or written (the heap's memory traffic)
uint steps = 0u;

// The heap's entries wherever they live.
float heap_distance(uint j) {
  ++heap_touched;
  return push.heap == KNN_HEAP_GLOBAL ? uintBitsToFloat(heap_global[heap_base + j].x) : heap_d[j];
}
uint heap_place(uint j) {
  ++heap_touched;
  return push.heap == KNN_HEAP_GLOBAL ? heap_global[heap_base + j].y : heap_i[j];
}
void heap_set(uint j, float d, uint at) {
  ++heap_touched;
  if (push.heap == KNN_HEAP_GLOBAL) {
    heap_global[heap_base + j] = uvec2(floatBitsToUint(d), at);
  } else {
    heap_d[j] = d;
    heap_i[j] = at;
  }
}

void heap_push(float d, uint at) {
  uint j = heap_n++;
  while (j > 0u) {
    ++steps;
    uint parent = (j - 1u) / 2u;
    float parent_d = heap_distance(parent);
    if (parent_d >= d) break;
    heap_set(j, parent_d, heap_place(parent));
    j = parent;
  }
  heap_set(j, d, at);
}

// Replaces the farthest entry (the top) and sifts the new one down.
void heap_replace_top(float d, uint at) {
  uint j = 0u;
  while (true) {
    ++steps;
    uint l = 2u * j + 1u;
    if (l >= heap_n) break;
    uint r = l + 1u;
    float dl = heap_distance(l);
    uint m = l;
    float dm = dl;
    if (r < heap_n) {
      float dr = heap_distance(r);
      if (dr > dl) m = r, dm = dr;
    }
    if (dm <= d) break;
    heap_set(j, dm, heap_place(m));
    j = m;
  }
  heap_set(j, d, at);
}

// One candidate photon (at place i of `compact`) for the query at x with normal n: kept when it
// arrives from the side the normal faces (the tangent-plane test) and lies within the bound,
// which becomes the k-th distance once k are held.
void consider(KnnPhoton p, uint i, vec3 x, vec3 n, inout float bound2) {
  vec3 d = p.position - x;
  float d2 = dot(d, d);
  if (d2 > bound2 || dot(n, p.direction) >= 0.0) return;
  if (heap_n < push.k) {
    heap_push(d2, i);
    if (heap_n == push.k) bound2 = heap_distance(0u);
  } else if (d2 < heap_distance(0u)) {
    heap_replace_top(d2, i);
    bound2 = heap_distance(0u);
  }
}

shared uint group_visited, group_cells, group_found, group_queries, group_short, group_truncated,
    group_heap;

void main() {
  if (gl_LocalInvocationIndex == 0u) {
    group_visited = 0u;
    group_cells = 0u;
    group_found = 0u;
    group_queries = 0u;
    group_short = 0u;
    group_truncated = 0u;
    group_heap = 0u;
  }
  barrier();

  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (pb_in_frame(pixel, uvec2(push.width, push.height))) {
    vec3 x, n, albedo, radiance = vec3(0.0);
    float radius = 0.0;
    if (pb_lit_sample(pixel, x, n, albedo)) {
      uint visited = 0u, opened = 0u;
      bool stop = false;
      float r_max2 = push.r_max * push.r_max;
      float bound2 = r_max2;  // r_max^2 until k are held, then the k-th squared distance
      heap_base = (uint(pixel.y) * push.width + uint(pixel.x)) * push.k;
      // Nothing within r_max when x is farther than r_max from the photons' box.
      vec3 outside = max(max(push.origin - x, x - push.grid_max), vec3(0.0));
      if (push.search == KNN_SEARCH_KDTREE && dot(outside, outside) <= r_max2) {
        // Jensen's search: from the root, the child on x's side of the splitting plane first;
        // the other child waits on the stack with its plane's squared distance and is entered
        // only if that is still within the bound when it comes off.
        uint stack_node[64];
        float stack_plane[64];
        uint top = 0u;
        stack_node[top] = 0u;
        stack_plane[top++] = 0.0;
        while (top > 0u) {
          if (++steps >= push.budget) {
            stop = true;
            break;
          }
          --top;
          uint i = stack_node[top];
          if (i >= push.photon_count || stack_plane[top] > bound2) continue;
          ++visited;
          KnnPhoton p = compact[i];
          float delta = x[p.axis] - p.position[p.axis];
          uint near_child = delta < 0.0 ? 2u * i + 1u : 2u * i + 2u;
          if (top + 2u > 64u) {
            stop = true;
            break;
          }
          stack_node[top] = delta < 0.0 ? 2u * i + 2u : 2u * i + 1u;
          stack_plane[top++] = delta * delta;
          stack_node[top] = near_child;
          stack_plane[top++] = 0.0;
          consider(p, i, x, n, bound2);
        }
      } else if (dot(outside, outside) <= r_max2) {
        ivec3 dims = ivec3(knn_dims());
        vec3 rel = (x - push.origin) / push.cell;
        ivec3 c0 = ivec3(floor(rel));
        vec3 f = rel - vec3(c0);
        // Distance from x to the nearest wall of its own cell: shell s >= 1 lies at least
        // (s - 1) cells plus this far away.
        float d0 = min(min(min(f.x, f.y), f.z), min(min(1.0 - f.x, 1.0 - f.y), 1.0 - f.z));
        d0 = clamp(d0, 0.0, 1.0) * push.cell;
        int shells = int(ceil(push.r_max / push.cell)) + 1;
        for (int s = 0; s <= shells && !stop; ++s) {
          ++steps;
          if (s > 0) {
            float lower = float(s - 1) * push.cell + d0;
            if (lower * lower > bound2) break;
          }
          for (int dz = -s; dz <= s && !stop; ++dz) {
            ++steps;
            int cz = c0.z + dz;
            if (cz < 0 || cz >= dims.z) continue;
            for (int dy = -s; dy <= s && !stop; ++dy) {
              ++steps;
              int cy = c0.y + dy;
              if (cy < 0 || cy >= dims.y) continue;
              // The shell's cells only: whole rows on its faces, the two ends elsewhere.
              bool face = s == 0 || abs(dz) == s || abs(dy) == s;
              int stride = face ? 1 : 2 * s;
              for (int dx = -s; dx <= s; dx += stride) {
                if (++steps >= push.budget) {
                  stop = true;
                  break;
                }
                int cx = c0.x + dx;
                if (cx < 0 || cx >= dims.x) continue;
                vec3 lo = push.origin + vec3(cx, cy, cz) * push.cell;
                vec3 gap = max(max(lo - x, x - (lo + push.cell)), vec3(0.0));
                if (dot(gap, gap) > bound2) continue;
                ++opened;
                uvec2 range = cells[knn_cell_index(uvec3(cx, cy, cz))];
                for (uint i = range.x; i < range.y; ++i) {
                  if (++steps >= push.budget) {
                    stop = true;
                    break;
                  }
                  ++visited;
                  consider(compact[i], i, x, n, bound2);
                }
              }
            }
          }
        }
      }

      // ---- the estimate over what was found ----
      float r2 = 0.0;
      if (heap_n > 0u) {
        bool full = heap_n == push.k || push.sparse == KNN_SPARSE_FARTHEST;
        r2 = full ? heap_distance(0u) : r_max2;
        r2 = max(r2, 1e-12);
        vec3 flux = vec3(0.0);
        for (uint j = 0u; j < heap_n; ++j) {
          float w =
              push.kernel == KNN_KERNEL_EPANECHNIKOV ? 2.0 * (1.0 - heap_distance(j) / r2) : 1.0;
          flux += compact[heap_place(j)].power * w;
        }
        radiance = albedo * PB_INV_PI * flux / (PB_PI * r2);
        radius = sqrt(r2);
        uint bin = uint(min(radius / push.bin_width, float(KNN_RADIUS_BINS - 1u)));
        atomicAdd(stats[KNN_STAT_HISTOGRAM + bin], 1u);
      }
      atomicAdd(group_visited, visited);
      atomicAdd(group_cells, opened);
      atomicAdd(group_found, heap_n);
      atomicAdd(group_queries, 1u);
      if (heap_n < push.k) atomicAdd(group_short, 1u);
      if (stop) atomicAdd(group_truncated, 1u);
      atomicAdd(group_heap, heap_touched);

      if (push.debug != 0u) {
        uint base = (uint(pixel.y) * push.width + uint(pixel.x)) * push.debug_stride;
        debug_words[base] = heap_n;
        debug_words[base + 1u] = floatBitsToUint(radius);
        for (uint j = 0u; j < heap_n; ++j)
          debug_words[base + 2u + j] = compact[heap_place(j)].index;
      }
    }
    imageStore(indirect_out, pixel, vec4(radiance, 1.0));
  }

  barrier();
  if (gl_LocalInvocationIndex == 0u) {
    PB_ADD64(stats, KNN_STAT_VISITED, group_visited);
    PB_ADD64(stats, KNN_STAT_CELLS, group_cells);
    PB_ADD64(stats, KNN_STAT_FOUND, group_found);
    atomicAdd(stats[KNN_STAT_QUERIES], group_queries);
    atomicAdd(stats[KNN_STAT_SHORT], group_short);
    atomicAdd(stats[KNN_STAT_TRUNCATED], group_truncated);
    PB_ADD64(stats, KNN_STAT_HEAP, group_heap);
  }
}
