// The GPU services a technique gets: one headless Vulkan device (lavapipe by default), named RAII
// buffers and images, and compute / graphics pipelines from SPIR-V embedded at build time.
// Resources are bound with push descriptors (VK_KHR_push_descriptor), so a pipeline is just its
// binding list and a technique never manages descriptor pools. Every image lives in
// VK_IMAGE_LAYOUT_GENERAL: one layout for storage, sampling and attachments keeps barriers to plain
// memory dependencies.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <variant>
#include <vector>
#include <vulkan/vulkan_raii.hpp>

namespace pb::gpu {

enum class Memory { device_local, host_visible };  // host_visible: coherent and persistently mapped

class Device;

class Buffer {
 public:
  Buffer() = default;
  // Moves hand over the memory accounting too: only the owner of the handle releases its bytes.
  Buffer(Buffer&& other) noexcept { *this = std::move(other); }
  Buffer& operator=(Buffer&& other) noexcept;
  ~Buffer();
  vk::Buffer handle() const { return *buffer_; }
  vk::DeviceSize size() const { return size_; }
  const std::string& name() const { return name_; }
  void* mapped() const { return mapped_; }  // null unless host_visible
  template <class T>
  std::span<T> view() const {
    return {static_cast<T*>(mapped_), size_t(size_ / sizeof(T))};
  }
  explicit operator bool() const { return size_ != 0; }

 private:
  friend class Device;
  vk::raii::Buffer buffer_{nullptr};
  vk::raii::DeviceMemory memory_{nullptr};
  vk::DeviceSize size_ = 0;
  void* mapped_ = nullptr;
  std::string name_;
  Device* device_ = nullptr;
};

class Image {
 public:
  Image() = default;
  Image(Image&& other) noexcept { *this = std::move(other); }
  Image& operator=(Image&& other) noexcept;
  ~Image();
  vk::Image handle() const { return *image_; }
  vk::ImageView view() const { return *view_; }
  vk::Format format() const { return format_; }
  vk::Extent2D extent() const { return extent_; }
  const std::string& name() const { return name_; }
  vk::DeviceSize bytes() const { return bytes_; }

 private:
  friend class Device;
  vk::raii::Image image_{nullptr};
  vk::raii::DeviceMemory memory_{nullptr};
  vk::raii::ImageView view_{nullptr};
  vk::Format format_ = vk::Format::eUndefined;
  vk::Extent2D extent_{};
  vk::DeviceSize bytes_ = 0;
  std::string name_;
  Device* device_ = nullptr;
};

// What a pipeline binding receives, in binding order.
struct Sampled {
  const Image* image;
};
using Resource = std::variant<const Buffer*, const Image*, Sampled>;

enum class Binding { storage_buffer, storage_image, sampled_image };

class Pipeline {
 public:
  Pipeline() = default;
  Pipeline(Pipeline&&) = default;
  Pipeline& operator=(Pipeline&&) = default;
  // Binds the pipeline and pushes its resources and push constants.
  void bind(vk::CommandBuffer cmd, std::span<const Resource> resources, const void* push = nullptr,
            uint32_t push_bytes = 0) const;
  void bind(vk::CommandBuffer cmd, std::initializer_list<Resource> resources,
            const void* push = nullptr, uint32_t push_bytes = 0) const {
    bind(cmd, std::span<const Resource>(resources.begin(), resources.size()), push, push_bytes);
  }
  template <class T>
  void bind(vk::CommandBuffer cmd, std::initializer_list<Resource> resources, const T& push) const {
    bind(cmd, resources, &push, sizeof(T));
  }
  template <class T>
  void bind(vk::CommandBuffer cmd, std::span<const Resource> resources, const T& push) const {
    bind(cmd, resources, &push, sizeof(T));
  }
  const std::string& name() const { return name_; }

 private:
  friend class Device;
  Device* device_ = nullptr;
  std::string name_;
  vk::PipelineBindPoint bind_point_ = vk::PipelineBindPoint::eCompute;
  std::vector<Binding> bindings_;
  vk::ShaderStageFlags push_stages_;
  vk::raii::DescriptorSetLayout set_layout_{nullptr};
  vk::raii::PipelineLayout layout_{nullptr};
  vk::raii::Pipeline pipeline_{nullptr};
};

// A raster pipeline for dynamic rendering. Vertex input is one interleaved buffer of
// `vertex_stride` bytes with the given attribute formats at consecutive binding-0 locations
// (offsets packed in order).
struct GraphicsPipelineDesc {
  std::string name;
  std::span<const uint32_t> vertex_spirv;
  std::span<const uint32_t> fragment_spirv;  // empty: depth-only
  std::vector<Binding> bindings;
  uint32_t push_bytes = 0;
  uint32_t vertex_stride = 0;
  std::vector<vk::Format> vertex_attributes;
  std::vector<vk::Format> color_formats;
  vk::Format depth_format = vk::Format::eUndefined;
  vk::CullModeFlags cull = vk::CullModeFlagBits::eNone;
  bool depth_bias = false;
  vk::SampleCountFlagBits samples = vk::SampleCountFlagBits::e1;
  std::vector<bool> additive_blend{};  // per colour attachment; empty: no blending
  // > 0: sample-rate shading (sampleShadingEnable) with this minSampleShading; 1 runs the fragment
  // shader once per sample.
  float min_sample_shading = 0;
};

class Device {
 public:
  // The device limits a technique sizes its work by.
  struct Limits {
    uint64_t max_storage_buffer_range;  // bytes one storage-buffer binding may span
    uint32_t max_compute_workgroup_count[3];
    uint32_t max_compute_workgroup_invocations;
    uint32_t max_push_constant_bytes;
    uint32_t max_color_samples;  // the highest sample count of float colour attachments
  };
  struct Options {
    std::string name_filter;  // substring of the device name; empty picks lavapipe, else the first
    bool validation = false;  // enable VK_LAYER_KHRONOS_validation and count its errors
  };
  explicit Device(const Options& options);
  ~Device();
  Device(const Device&) = delete;
  Device& operator=(const Device&) = delete;

  const std::string& name() const { return name_; }
  const std::string& driver() const { return driver_; }
  const vk::raii::Device& device() const { return device_; }
  const Limits& limits() const { return limits_; }
  vk::Queue queue() const { return *queue_; }
  uint32_t queue_family() const { return queue_family_; }
  // lavapipe (llvmpipe) bins rasterisation and runs it after a pass's closing timestamp, so its
  // timestamps miss raster work (tests/unit/timing_test.cpp measures this); the runner then times
  // passes with fences instead.
  bool raster_timestamps_unreliable() const {
    return driver_.find("llvmpipe") != std::string::npos;
  }
  double timestamp_period_ns() const { return timestamp_period_ns_; }
  uint32_t timestamp_valid_bits() const { return timestamp_valid_bits_; }

  Buffer create_buffer(std::string name, vk::DeviceSize size, vk::BufferUsageFlags usage,
                       Memory memory);
  Image create_image(std::string name, vk::Extent2D extent, vk::Format format,
                     vk::ImageUsageFlags usage,
                     vk::SampleCountFlagBits samples = vk::SampleCountFlagBits::e1);
  Pipeline create_compute_pipeline(std::string name, std::span<const uint32_t> spirv,
                                   std::vector<Binding> bindings, uint32_t push_bytes);
  Pipeline create_graphics_pipeline(const GraphicsPipelineDesc& desc);

  // Dynamic rendering, core on 1.3 devices and VK_KHR_dynamic_rendering on 1.2 ones.
  void begin_rendering(vk::CommandBuffer cmd, const vk::RenderingInfo& info) const;
  void end_rendering(vk::CommandBuffer cmd) const;

  // Records with `record`, submits, waits. For set-up work and read-backs, never inside a frame.
  void submit_and_wait(const std::function<void(vk::CommandBuffer)>& record);
  void upload(const Buffer& dst, const void* data, vk::DeviceSize bytes, vk::DeviceSize offset = 0);
  void download(const Buffer& src, void* data, vk::DeviceSize bytes, vk::DeviceSize offset = 0);
  // Reads an RGBA32F image into `rgba` (width * height * 4 floats).
  void read_image(const Image& image, std::vector<float>& rgba);

  uint64_t validation_errors() const;
  std::string first_validation_error() const;

  // One nearest-neighbour, clamp-to-edge sampler for every sampled binding: techniques read
  // textures with texelFetch or unfiltered lookups; shadow-map depth compares are done in the
  // shader.
  vk::Sampler nearest_sampler() const { return *nearest_sampler_; }

  void set_debug_name(uint64_t handle, vk::ObjectType type, const std::string& name) const;

 private:
  friend class Buffer;  // their destructors hand back their bytes (release)
  friend class Image;
  friend struct DeviceAccounting;  // the runner's view: gpu/device_accounting.h
  void release(vk::DeviceSize bytes) { allocated_bytes_ -= bytes; }
  uint32_t find_memory_type(uint32_t type_bits, vk::MemoryPropertyFlags flags) const;
  vk::raii::DeviceMemory allocate(vk::MemoryRequirements requirements,
                                  vk::MemoryPropertyFlags flags);

  struct Messenger;
  vk::raii::Context context_;
  vk::raii::Instance instance_{nullptr};
  std::unique_ptr<Messenger> messenger_;
  vk::raii::PhysicalDevice physical_{nullptr};
  vk::raii::Device device_{nullptr};
  vk::raii::Queue queue_{nullptr};
  vk::raii::CommandPool command_pool_{nullptr};
  vk::raii::Sampler nearest_sampler_{nullptr};
  uint32_t queue_family_ = 0;
  std::string name_, driver_;
  double timestamp_period_ns_ = 1;
  uint32_t timestamp_valid_bits_ = 64;
  Limits limits_{};
  bool debug_names_ = false;
  uint64_t allocated_bytes_ = 0;
};

// A full memory barrier between commands: every earlier write is visible to every later access.
// Passes are separated by it; it is what a technique uses between dependent dispatches.
void full_barrier(vk::CommandBuffer cmd);

// Work groups needed to cover `n` items with groups of `group_size`.
inline uint32_t groups_for(uint64_t n, uint32_t group_size) {
  return uint32_t((n + group_size - 1) / group_size);
}

}  // namespace pb::gpu
