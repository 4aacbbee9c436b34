// cluster: Paper I's photon splatting with a view-sample cluster hierarchy (Moreau et al. 2016,
// §4), in three variants: plain, cone (normal-cone rejection, §4.5) and trivial (per-node flux for
// photons that enclose a node and arrive above all its samples, §4.6).
//
// Per frame: photons are traced on the CPU exactly as `tiled` does (same settings, same seed, so
// the two techniques splat the same photons) and uploaded; after the shared G-buffer and direct
// light the hierarchy is rebuilt from the G-buffer (hierarchy.h, pass "cluster-build"); the splat
// runs the top pass (photon -> first 3 levels, emitting (photon, node) jobs), regroups the jobs by
// node, then the leaf passes twice (count, prefix sum, insert into per-node lists; §4.3); the
// radiance estimate walks each sample's leaf and ancestors (L = f I / (pi r^2), §4.4, the estimator
// of tiled); the shared shade pass adds that indirect radiance to the direct light.
//
// Capacities (jobs, list entries) are parameters: overflowing entries are dropped on the GPU,
// counted ("overflows") and warned about, never written out of bounds.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <glm/glm.hpp>

#include "cluster_shaders.h"
#include "hierarchy.h"
#include "photonbench/context.h"
#include "photonbench/error.h"
#include "photonbench/plugin.h"

namespace {

using pb::gpu::Binding;
using pb::gpu::Buffer;
using pb::gpu::Memory;
using U = vk::BufferUsageFlagBits;

// `layout` names one of the hierarchy's layouts (HierarchyOptions::named_layout in hierarchy.h). Each
// keeps the level above the leaves at 32x32 pixels (Paper I's "leaf node at most contains 32x32 view
// samples" of directional).
const pb_param_spec kParams[] = {
    {"photons", PB_PARAM_INT, 100000, 1, 5e7, nullptr, "paths",
     "light paths traced per frame (as tiled; Paper I counts stored photons)"},
    {"radius", PB_PARAM_FLOAT, 0.05, 1e-5, 1e4, nullptr, "m", "photon sphere radius; default 0.05"},
    {"max_bounces", PB_PARAM_INT, 4, 2, 31, nullptr, "hits",
     "surface interactions per light path; Paper I §4.2 limits tracing to four bounces"},
    {"shadow_map_size", PB_PARAM_INT, 512, 16, 4096, nullptr, "texels",
     "shadow-map tile side of the direct light"},
    {"variant", PB_PARAM_ENUM, 0, 0, 2, "plain|cone|trivial", "",
     "plain; cone: normal-cone rejection (Paper I §4.5); trivial: cone + per-node flux (§4.6)"},
    {"layout", PB_PARAM_ENUM, 0, 0, 2, "default|shallow|deep", "",
     "hierarchy levels: default 256:2x2x8,2x2x8,2x2x8,4x4x2; shallow 128:2x2x8,2x2x8,4x4x2; deep "
     "512:2x2x4,2x2x4,2x2x4,2x2x4,4x4x2"},
    {"top_levels", PB_PARAM_INT, 3, 0, 5, nullptr, "levels",
     "levels the top splat pass traverses below the roots before emitting jobs (Paper I §4.3: 3); "
     "at most levels - 2"},
    {"max_jobs", PB_PARAM_INT, 1 << 22, 1, 1 << 24, nullptr, "jobs",
     "capacity of the (photon, node) job list of the top pass; overflowing jobs are dropped and "
     "counted"},
    {"max_list_entries", PB_PARAM_INT, 1 << 22, 1, 1 << 25, nullptr, "entries",
     "capacity of all per-node photon lists together; overflowing entries are dropped and counted"},
};

// Mirrors the push block of shaders/cluster_common.h.
struct Push {
  glm::mat4 view;
  uint32_t photon_count = 0;
  float radius = 0;
  uint32_t variant = 0, top_level = 0;
  uint32_t job_capacity = 0, list_capacity = 0, jobs_per_thread = 0, mode = 0;
  float flux_scale = 1;
  uint32_t list_first = 0, list_slice = 0, scan_count = 0;
};
static_assert(sizeof(Push) == 112);

// Words of the stats buffer (shaders/cluster_common.h).
constexpr uint32_t kStatEntries = 0, kStatDropped = 1, kStatRead = 2, kStatRejected = 4,
                   kStatJobs = 6, kStatJobsDropped = 7, kStatTrivial = 8, kStatCone = 9,
                   kStatTruncated = 10, kStatJobArgs = 12, kStatLeafArgs = 16, kStatWords = 24;
// List entries one radiance-estimate dispatch reads per sample at most (llvmpipe's loop limit).
constexpr uint32_t kListSlice = 32768;
// Jobs one leaf-pass invocation takes (Paper I's persistent threads loop until the list is empty;
// bounded here so that no invocation runs into llvmpipe's 65535-iteration loop limit).
constexpr uint32_t kJobsPerThread = 16;
constexpr uint32_t kScanBlock = 4096;  // words per scan_blocks group (shaders/scan.h)
enum Variant : uint32_t { kPlain = 0, kCone = 1, kTrivial = 2 };

class Cluster final : public pb::Technique {
 public:
  void setup(pb::Context& ctx, const pb::Params& params) override {
    paths_ = uint32_t(params.integer("photons"));
    radius_ = float(params.number("radius"));
    max_bounces_ = uint32_t(params.integer("max_bounces"));
    const std::string& variant = params.choice("variant");
    variant_ = variant == "trivial" ? kTrivial : variant == "cone" ? kCone : kPlain;
    const std::string& layout = params.choice("layout");
    top_levels_ = uint32_t(params.integer("top_levels"));
    job_capacity_ = uint32_t(params.integer("max_jobs"));
    list_capacity_ = uint32_t(params.integer("max_list_entries"));
    ctx.shared().configure_shadows(uint32_t(params.integer("shadow_map_size")), 0.01f, 0.01f);

    // One storage-buffer binding each: lavapipe allows 128 MiB per binding (maxStorageBufferRange).
    uint64_t limit = ctx.gpu().physical().getProperties().limits.maxStorageBufferRange;
    if (uint64_t(job_capacity_) * 8 > limit || uint64_t(list_capacity_) * 4 > limit)
      throw pb::InputError(fmt::format(
          "cluster: max_jobs = {} (8 bytes each) or max_list_entries = {} (4 bytes each) exceeds "
          "the device's maxStorageBufferRange of {} bytes",
          job_capacity_, list_capacity_, limit));
    auto options = pb::cluster::HierarchyOptions::named_layout(layout);
    options.normal_cones = variant_ != kPlain;
    hierarchy_.setup(ctx.gpu(), options);
    if (top_levels_ > hierarchy_.accumulation_level())
      throw pb::InputError(fmt::format(
          "cluster: top_levels = {} must be at most {} (the level above the leaves) for layout {}",
          top_levels_, hierarchy_.accumulation_level(), layout));

    auto& gpu = ctx.gpu();
    auto B = Binding::storage_buffer;
    auto I = Binding::storage_image;
    std::vector<Binding> bindings(pb::cluster::Hierarchy::kBindingCount + 13, B);
    for (int k = 0; k < 4; ++k) bindings.push_back(I);
    constexpr uint32_t kPush = sizeof(Push);
    top_ = gpu.create_compute_pipeline("splat/top", ksplat_top_comp_spv, bindings, kPush);
    job_args_ = gpu.create_compute_pipeline("splat/job-args", kjob_args_comp_spv, bindings, kPush);
    regroup_ = gpu.create_compute_pipeline("splat/regroup", kregroup_comp_spv, bindings, kPush);
    leaf_ = gpu.create_compute_pipeline("splat/leaf", ksplat_leaf_comp_spv, bindings, kPush);
    scan_blocks_pipeline_ =
        gpu.create_compute_pipeline("prefix-sum/blocks", kscan_blocks_comp_spv, bindings, kPush);
    scan_top_ = gpu.create_compute_pipeline("prefix-sum/top", kscan_top_comp_spv, bindings, kPush);
    scan_add_ = gpu.create_compute_pipeline("prefix-sum/add", kscan_add_comp_spv, bindings, kPush);
    estimate_ = gpu.create_compute_pipeline("radiance-estimate", kradiance_estimate_comp_spv,
                                            bindings, kPush);
  }

  void render(pb::Context& ctx) override {
    auto& gpu = ctx.gpu();
    const auto& frame = ctx.frame();
    pb::trace::TraceSettings settings;
    settings.paths = paths_;
    settings.max_bounces = max_bounces_;
    // As tiled: every hit but the first, of the `indirect` class (README: deviations).
    settings.store = pb::trace::kIndirectPhotons | pb::trace::kCausticIndirectPhotons;
    const uint32_t photon_count =
        pb::trace_and_upload_photons(ctx, settings, batch_, photons_, "cluster/photons");
    float flux_scale = 1;
    {
      // Node flux is summed with 32-bit integer atomics (no float atomics on the device): fixed
      // point scaled so that all photons' flux together fits, per channel, in 2^31 units.
      glm::dvec3 total(0.0);
      for (const auto& p : batch_.photons) total += glm::dvec3(p.power);
      double most = std::max({total.x, total.y, total.z, 1e-30});
      flux_scale = float(2147483648.0 / most);
    }
    ctx.shared().gbuffer();
    ctx.shared().direct_light();
    hierarchy_.build(ctx);
    ensure_resources(ctx);

    Push push{};
    push.view = frame.camera.view;
    push.photon_count = photon_count;
    push.radius = radius_;
    push.variant = variant_;
    push.top_level = top_levels_;
    push.job_capacity = job_capacity_;
    push.list_capacity = list_capacity_;
    push.jobs_per_thread = kJobsPerThread;
    push.flux_scale = flux_scale;
    push.scan_count = hierarchy_.node_capacity();

    auto gbuf = ctx.shared().gbuffer_images();
    auto h = hierarchy_.bindings();
    auto bind = [&](const pb::gpu::Pipeline& pipeline, vk::CommandBuffer cmd) {
      pipeline.bind(
          cmd,
          {h[0],          h[1],          h[2],           h[3],           h[4],        h[5],
           h[6],          &photons_,     &jobs_a_,       &jobs_b_,       &job_bins_,  &job_offsets_,
           &job_cursors_, &list_counts_, &list_offsets_, &list_cursors_, &lists_,     &node_flux_,
           &stats_,       &scan_blocks_, gbuf.position,  gbuf.normal,    gbuf.albedo, &indirect_},
          push);
    };
    auto scan = [&](vk::CommandBuffer cmd, uint32_t mode) {
      push.mode = mode;
      uint32_t blocks = pb::gpu::groups_for(push.scan_count, kScanBlock);
      bind(scan_blocks_pipeline_, cmd);
      cmd.dispatch(blocks, 1, 1);
      pb::gpu::full_barrier(cmd);
      bind(scan_top_, cmd);
      cmd.dispatch(1, 1, 1);
      pb::gpu::full_barrier(cmd);
      bind(scan_add_, cmd);
      cmd.dispatch(blocks, 1, 1);
    };

    // ctx.cmd() is fetched anew in every pass: with fenced timing (lavapipe) a pass scope submits
    // and continues in a fresh command buffer.
    pb::gpu::full_barrier(ctx.cmd());
    {
      auto splat = ctx.pass("splat");
      {
        auto scope = ctx.pass("top");
        auto cmd = ctx.cmd();
        for (const Buffer* b :
             {&stats_, &job_bins_, &job_cursors_, &list_counts_, &list_cursors_, &node_flux_})
          cmd.fillBuffer(b->handle(), 0, VK_WHOLE_SIZE, 0u);
        pb::gpu::full_barrier(cmd);
        bind(top_, cmd);
        cmd.dispatch(std::max<uint32_t>(1, pb::gpu::groups_for(photon_count, 64)), 1, 1);
        pb::gpu::full_barrier(cmd);
        bind(job_args_, cmd);
        cmd.dispatch(1, 1, 1);
      }
      pb::gpu::full_barrier(ctx.cmd());
      {
        auto scope = ctx.pass("regroup");
        auto cmd = ctx.cmd();
        push.mode = 0;  // MODE_COUNT
        bind(regroup_, cmd);
        cmd.dispatchIndirect(stats_.handle(), kStatJobArgs * 4);
        pb::gpu::full_barrier(cmd);
        scan(cmd, 0);  // SCAN_JOBS
        pb::gpu::full_barrier(cmd);
        push.mode = 1;  // MODE_INSERT
        bind(regroup_, cmd);
        cmd.dispatchIndirect(stats_.handle(), kStatJobArgs * 4);
      }
      pb::gpu::full_barrier(ctx.cmd());
      {
        auto scope = ctx.pass("count");
        auto cmd = ctx.cmd();
        push.mode = 0;
        bind(leaf_, cmd);
        cmd.dispatchIndirect(stats_.handle(), kStatLeafArgs * 4);
      }
      pb::gpu::full_barrier(ctx.cmd());
      {
        auto scope = ctx.pass("prefix-sum");
        scan(ctx.cmd(), 1);  // SCAN_LISTS
      }
      pb::gpu::full_barrier(ctx.cmd());
      {
        auto scope = ctx.pass("insert");
        auto cmd = ctx.cmd();
        push.mode = 1;
        bind(leaf_, cmd);
        cmd.dispatchIndirect(stats_.handle(), kStatLeafArgs * 4);
      }
    }
    pb::gpu::full_barrier(ctx.cmd());
    {
      auto scope = ctx.pass("radiance-estimate");
      auto cmd = ctx.cmd();
      // A sample's lists hold each photon at most once, so photon_count bounds their total length.
      uint32_t slices = std::max<uint32_t>(1, pb::gpu::groups_for(photon_count, kListSlice));
      push.list_slice = kListSlice;
      for (uint32_t slice = 0; slice < slices; ++slice) {
        if (slice > 0) pb::gpu::full_barrier(cmd);
        push.list_first = slice * kListSlice;
        bind(estimate_, cmd);
        cmd.dispatch(pb::gpu::groups_for(frame.width, 8), pb::gpu::groups_for(frame.height, 8), 1);
      }
    }
    pb::gpu::full_barrier(ctx.cmd());
    ctx.shared().shade(&indirect_);

    // The counters live on the GPU: wait for the frame's work (flush makes them host-visible).
    ctx.flush();
    report(ctx, photon_count);
  }

 private:
  // Per-resolution resources (sized by the hierarchy's node capacity), made on the first frame.
  void ensure_resources(pb::Context& ctx) {
    const auto& frame = ctx.frame();
    if (indirect_.extent().width == frame.width && indirect_.extent().height == frame.height)
      return;
    auto& gpu = ctx.gpu();
    uint64_t nodes = hierarchy_.node_capacity();
    auto storage = U::eStorageBuffer | U::eTransferDst;
    auto make = [&](const char* name, uint64_t bytes) {
      return gpu.create_buffer(std::string("cluster/") + name, std::max<uint64_t>(bytes, 16),
                               storage, Memory::device_local);
    };
    jobs_a_ = make("jobs", uint64_t(job_capacity_) * 8);
    jobs_b_ = make("jobs-regrouped", uint64_t(job_capacity_) * 8);
    job_bins_ = make("job-bins", nodes * 4);
    job_offsets_ = make("job-offsets", nodes * 4);
    job_cursors_ = make("job-cursors", nodes * 4);
    list_counts_ = make("list-counts", nodes * 4);
    list_offsets_ = make("list-offsets", nodes * 4);
    list_cursors_ = make("list-cursors", nodes * 4);
    lists_ = make("photon-lists", uint64_t(list_capacity_) * 4);
    node_flux_ = make("node-flux", variant_ == kTrivial ? nodes * 12 : 16);
    scan_blocks_ = make("scan-blocks", uint64_t(pb::gpu::groups_for(nodes, kScanBlock)) * 4);
    stats_ = gpu.create_buffer("cluster/stats", kStatWords * 4, storage | U::eIndirectBuffer,
                               Memory::host_visible);
    indirect_ = gpu.create_image("cluster/indirect", {frame.width, frame.height},
                                 vk::Format::eR32G32B32A32Sfloat, vk::ImageUsageFlagBits::eStorage);
  }

  void report(pb::Context& ctx, uint32_t photon_count) {
    auto s = stats_.view<uint32_t>();
    auto wide = [&](uint32_t at) { return double(uint64_t(s[at]) | (uint64_t(s[at + 1]) << 32)); };
    uint64_t entries = s[kStatEntries], dropped = s[kStatDropped];
    uint64_t jobs = s[kStatJobs], jobs_dropped = s[kStatJobsDropped];
    uint64_t truncated = s[kStatTruncated];
    ctx.count("list_entries", double(std::min<uint64_t>(entries, list_capacity_)));
    ctx.count("jobs", double(jobs));
    ctx.count("photons_read", wide(kStatRead));
    ctx.count("photons_rejected", wide(kStatRejected));
    if (variant_ == kTrivial) ctx.count("trivial_accepts", double(s[kStatTrivial]));
    if (variant_ != kPlain) ctx.count("cone_rejects", double(s[kStatCone]));
    ctx.count("overflows", double(dropped + jobs_dropped + truncated));
    uint64_t nodes = 0;
    for (uint32_t l = 0; l < hierarchy_.levels(); ++l) nodes += hierarchy_.occupied(l);
    ctx.count("hierarchy_nodes", double(nodes));
    ctx.count("hierarchy_leaves", double(hierarchy_.occupied(hierarchy_.leaf_level())));
    // Memory per Paper I Table 1 row.
    ctx.count("bytes_cluster_hierarchy", double(hierarchy_.bytes_hierarchy()));
    ctx.count("bytes_final_bounds", double(hierarchy_.bytes_final_bounds()));
    ctx.count("bytes_normal_cone", double(hierarchy_.bytes_normal_cone()));
    ctx.count("bytes_accum_flux", variant_ == kTrivial ? double(node_flux_.size()) : 0.0);
    ctx.count("bytes_jobs", double(jobs_a_.size() + jobs_b_.size() + job_bins_.size() +
                                   job_offsets_.size() + job_cursors_.size()));
    ctx.count("bytes_photon_lists",
              double(lists_.size() + list_counts_.size() + list_offsets_.size() +
                     list_cursors_.size() + scan_blocks_.size()));
    ctx.count("bytes_photons", double(uint64_t(photon_count) * sizeof(pb::trace::PhotonRecord)));
    if (dropped > 0)
      ctx.warn(fmt::format(
          "cluster: per-node photon lists overflowed: {} entries wanted, max_list_entries = {}; "
          "{} entries dropped (indirect light is underestimated in this frame)",
          entries, list_capacity_, dropped));
    if (jobs_dropped > 0)
      ctx.warn(fmt::format(
          "cluster: splat job list overflowed: {} jobs wanted, max_jobs = {}; {} jobs dropped "
          "(indirect light is underestimated in this frame)",
          jobs, job_capacity_, jobs_dropped));
    if (truncated > 0)
      ctx.warn(
          fmt::format("cluster: {} hierarchy traversals cut short by the loop budget "
                      "(lavapipe's loop limit); photons were lost",
                      truncated));
  }

  uint32_t paths_ = 0, max_bounces_ = 4, top_levels_ = 3, job_capacity_ = 0, list_capacity_ = 0;
  Variant variant_ = kPlain;
  float radius_ = 0;
  pb::cluster::Hierarchy hierarchy_;
  pb::trace::PhotonBatch batch_;
  Buffer photons_, jobs_a_, jobs_b_, job_bins_, job_offsets_, job_cursors_, list_counts_,
      list_offsets_, list_cursors_, lists_, node_flux_, scan_blocks_, stats_;
  pb::gpu::Image indirect_;
  pb::gpu::Pipeline top_, job_args_, regroup_, leaf_, scan_blocks_pipeline_, scan_top_, scan_add_,
      estimate_;
};

}  // namespace

PB_EXPORT_TECHNIQUE(
    Cluster, "cluster", "indirect",
    "Paper I's photon splatting with a view-sample cluster hierarchy: per-node photon lists, "
    "constant-kernel estimate; variants plain, cone (normal cones), trivial (per-node flux)",
    kParams)
