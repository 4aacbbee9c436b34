// The headless Vulkan device: no surface, no swapchain. lavapipe is picked by default because it is
// always there; `--device NAME` picks any Vulkan 1.2 device whose name contains NAME.
#include <fmt/format.h>

#include <atomic>
#include <cstring>
#include <mutex>

#include "gpu/device_accounting.h"
#include "photonbench/error.h"
#include "photonbench/gpu.h"

namespace pb::gpu {

namespace {

// Every failing VkResult becomes a pb::Error carrying the result's name and the call (rule 12).
void check(vk::Result result, const char* call) {
  if (result != vk::Result::eSuccess)
    throw Error(fmt::format("{} failed: {}", call, vk::to_string(result)));
}

bool has_layer(const vk::raii::Context& context, const char* name) {
  for (const auto& layer : context.enumerateInstanceLayerProperties())
    if (std::strcmp(layer.layerName, name) == 0) return true;
  return false;
}

bool has_instance_extension(const vk::raii::Context& context, const char* name) {
  for (const auto& ext : context.enumerateInstanceExtensionProperties())
    if (std::strcmp(ext.extensionName, name) == 0) return true;
  return false;
}

bool has_device_extension(const vk::raii::PhysicalDevice& physical, const char* name) {
  for (const auto& ext : physical.enumerateDeviceExtensionProperties())
    if (std::strcmp(ext.extensionName, name) == 0) return true;
  return false;
}

vk::raii::Instance make_instance(const vk::raii::Context& context, bool validation,
                                 bool debug_utils) {
  // Ask for 1.3 so core 1.3 entry points (dynamic rendering) are dispatched on 1.3 devices; 1.2
  // devices use the KHR extension instead (see begin_rendering).
  vk::ApplicationInfo app{"photonbench", 1, "photonbench", 1, VK_API_VERSION_1_3};
  std::vector<const char*> layers, extensions;
  if (validation) {
    if (!has_layer(context, "VK_LAYER_KHRONOS_validation"))
      throw Error(
          "validation requested but VK_LAYER_KHRONOS_validation is not installed "
          "(Debian package vulkan-validationlayers)");
    layers.push_back("VK_LAYER_KHRONOS_validation");
  }
  if (debug_utils) extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  vk::InstanceCreateInfo info{{}, &app, layers, extensions};
  return vk::raii::Instance(context, info);
}

}  // namespace

struct Device::Messenger {
  vk::raii::DebugUtilsMessengerEXT handle{nullptr};
  std::atomic<uint64_t> errors{0};
  std::mutex mutex;
  std::string first_error;

  static VKAPI_ATTR VkBool32 VKAPI_CALL callback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                 VkDebugUtilsMessageTypeFlagsEXT,
                                                 const VkDebugUtilsMessengerCallbackDataEXT* data,
                                                 void* user) {
    auto* self = static_cast<Messenger*>(user);
    if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) {
      self->errors++;
      std::lock_guard lock(self->mutex);
      if (self->first_error.empty()) self->first_error = data->pMessage ? data->pMessage : "?";
      std::fprintf(stderr, "vulkan validation error: %s\n", data->pMessage ? data->pMessage : "?");
    }
    return VK_FALSE;
  }
};

std::vector<std::string> list_devices() {
  vk::raii::Context context;
  vk::raii::Instance instance = make_instance(context, false, false);
  std::vector<std::string> names;
  for (const auto& physical : vk::raii::PhysicalDevices(instance)) {
    auto props = physical.getProperties();
    names.push_back(fmt::format("{} (Vulkan {}.{}, {})", std::string(props.deviceName.data()),
                                VK_API_VERSION_MAJOR(props.apiVersion),
                                VK_API_VERSION_MINOR(props.apiVersion),
                                vk::to_string(props.deviceType)));
  }
  return names;
}

Device::Device(const Options& options) {
  debug_names_ = has_instance_extension(context_, VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  instance_ = make_instance(context_, options.validation, debug_names_);
  if (options.validation && debug_names_) {
    messenger_ = std::make_unique<Messenger>();
    using S = vk::DebugUtilsMessageSeverityFlagBitsEXT;
    using T = vk::DebugUtilsMessageTypeFlagBitsEXT;
    vk::DebugUtilsMessengerCreateInfoEXT info{{},
                                              S::eError | S::eWarning,
                                              T::eGeneral | T::eValidation | T::ePerformance,
                                              &Messenger::callback,
                                              messenger_.get()};
    messenger_->handle = vk::raii::DebugUtilsMessengerEXT(instance_, info);
  }

  // Pick the device: by name when asked, else lavapipe (the always-available default).
  vk::raii::PhysicalDevices physicals(instance_);
  std::string available;
  for (auto& candidate : physicals) {
    std::string name = candidate.getProperties().deviceName.data();
    available += (available.empty() ? "" : ", ") + name;
    bool wanted = options.name_filter.empty() ? name.find("llvmpipe") != std::string::npos
                                              : name.find(options.name_filter) != std::string::npos;
    if (wanted) {
      physical_ = std::move(candidate);
      break;
    }
  }
  if (!*physical_ && options.name_filter.empty() && !physicals.empty())
    physical_ = std::move(physicals[0]);
  if (!*physical_)
    throw InputError(fmt::format("--device: no Vulkan device matches '{}' (available: {})",
                                 options.name_filter, available.empty() ? "none" : available));

  auto props = physical_.getProperties();
  name_ = props.deviceName.data();
  if (props.apiVersion < VK_API_VERSION_1_2)
    throw Error(fmt::format("device '{}' supports only Vulkan {}.{}; photonbench needs 1.2", name_,
                            VK_API_VERSION_MAJOR(props.apiVersion),
                            VK_API_VERSION_MINOR(props.apiVersion)));
  auto driver_props =
      physical_.getProperties2<vk::PhysicalDeviceProperties2, vk::PhysicalDeviceDriverProperties>();
  const auto& driver = driver_props.get<vk::PhysicalDeviceDriverProperties>();
  driver_ = fmt::format("{} {}", driver.driverName.data(), driver.driverInfo.data());
  timestamp_period_ns_ = props.limits.timestampPeriod;
  limits_.max_storage_buffer_range = props.limits.maxStorageBufferRange;
  for (int axis = 0; axis < 3; ++axis)
    limits_.max_compute_workgroup_count[axis] = props.limits.maxComputeWorkGroupCount[axis];
  limits_.max_compute_workgroup_invocations = props.limits.maxComputeWorkGroupInvocations;
  limits_.max_push_constant_bytes = props.limits.maxPushConstantsSize;
  limits_.max_color_samples = 1;
  for (uint32_t n = 64; n > 1; n /= 2)
    if (uint32_t(props.limits.framebufferColorSampleCounts) & n) {
      limits_.max_color_samples = n;
      break;
    }

  // One queue that does graphics and compute, with timestamps (checked: rule 7).
  auto families = physical_.getQueueFamilyProperties();
  bool found = false;
  for (uint32_t i = 0; i < families.size(); ++i) {
    if ((families[i].queueFlags & vk::QueueFlagBits::eGraphics) &&
        (families[i].queueFlags & vk::QueueFlagBits::eCompute)) {
      queue_family_ = i;
      timestamp_valid_bits_ = families[i].timestampValidBits;
      found = true;
      break;
    }
  }
  if (!found) throw Error(fmt::format("device '{}' has no graphics+compute queue", name_));
  if (timestamp_valid_bits_ == 0)
    throw Error(fmt::format("device '{}' has no timestamp support on its queue", name_));

  std::vector<const char*> extensions = {VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME};
  for (const char* required : extensions)
    if (!has_device_extension(physical_, required))
      throw Error(fmt::format("device '{}' lacks {}", name_, required));
  bool core_13 = props.apiVersion >= VK_API_VERSION_1_3;
  if (!core_13) {
    if (!has_device_extension(physical_, VK_KHR_DYNAMIC_RENDERING_EXTENSION_NAME))
      throw Error(fmt::format("device '{}' lacks dynamic rendering", name_));
    extensions.push_back(VK_KHR_DYNAMIC_RENDERING_EXTENSION_NAME);
  }

  float priority = 1.f;
  vk::DeviceQueueCreateInfo queue_info{{}, queue_family_, 1, &priority};
  vk::PhysicalDeviceFeatures2 features;
  features.features.shaderInt64 = physical_.getFeatures().shaderInt64;
  features.features.fragmentStoresAndAtomics = VK_TRUE;
  features.features.sampleRateShading = physical_.getFeatures().sampleRateShading;
  features.features.vertexPipelineStoresAndAtomics =
      physical_.getFeatures().vertexPipelineStoresAndAtomics;
  vk::PhysicalDeviceVulkan12Features features12;
  features12.hostQueryReset = VK_TRUE;
  features12.scalarBlockLayout = VK_TRUE;
  features12.shaderFloat16 = VK_FALSE;
  features12.bufferDeviceAddress = VK_FALSE;
  vk::PhysicalDeviceDynamicRenderingFeatures dynamic_rendering{VK_TRUE};
  features.pNext = &features12;
  features12.pNext = &dynamic_rendering;
  vk::DeviceCreateInfo info{{}, queue_info, {}, extensions, nullptr, &features};
  device_ = vk::raii::Device(physical_, info);
  queue_ = vk::raii::Queue(device_, queue_family_, 0);
  command_pool_ = vk::raii::CommandPool(
      device_, {vk::CommandPoolCreateFlagBits::eResetCommandBuffer, queue_family_});
  nearest_sampler_ =
      vk::raii::Sampler(device_, vk::SamplerCreateInfo{{},
                                                       vk::Filter::eNearest,
                                                       vk::Filter::eNearest,
                                                       vk::SamplerMipmapMode::eNearest,
                                                       vk::SamplerAddressMode::eClampToEdge,
                                                       vk::SamplerAddressMode::eClampToEdge,
                                                       vk::SamplerAddressMode::eClampToEdge});
}

Device::~Device() {
  if (*device_) device_.waitIdle();
}

uint64_t Device::validation_errors() const { return messenger_ ? messenger_->errors.load() : 0; }

std::string Device::first_validation_error() const {
  if (!messenger_) return {};
  std::lock_guard lock(messenger_->mutex);
  return messenger_->first_error;
}

void Device::set_debug_name(uint64_t handle, vk::ObjectType type, const std::string& name) const {
  if (!debug_names_) return;
  device_.setDebugUtilsObjectNameEXT(vk::DebugUtilsObjectNameInfoEXT{type, handle, name.c_str()});
}

uint32_t Device::find_memory_type(uint32_t type_bits, vk::MemoryPropertyFlags flags) const {
  auto memory = physical_.getMemoryProperties();
  for (uint32_t i = 0; i < memory.memoryTypeCount; ++i)
    if ((type_bits & (1u << i)) && (memory.memoryTypes[i].propertyFlags & flags) == flags) return i;
  throw Error(fmt::format("device '{}' has no memory type with {}", name_, vk::to_string(flags)));
}

vk::raii::DeviceMemory Device::allocate(vk::MemoryRequirements requirements,
                                        vk::MemoryPropertyFlags flags) {
  vk::MemoryAllocateInfo info{requirements.size,
                              find_memory_type(requirements.memoryTypeBits, flags)};
  try {
    return vk::raii::DeviceMemory(device_, info);
  } catch (const vk::SystemError& e) {
    throw Error(
        fmt::format("allocating {} bytes of GPU memory failed: {}", requirements.size, e.what()));
  }
}

Buffer Device::create_buffer(std::string name, vk::DeviceSize size, vk::BufferUsageFlags usage,
                             Memory memory) {
  if (size == 0) size = 16;  // a zero-sized buffer is invalid; an empty list still needs a binding
  Buffer buffer;
  buffer.name_ = std::move(name);
  buffer.size_ = size;
  buffer.device_ = this;
  usage |= vk::BufferUsageFlagBits::eTransferSrc | vk::BufferUsageFlagBits::eTransferDst;
  buffer.buffer_ = vk::raii::Buffer(device_, vk::BufferCreateInfo{{}, size, usage});
  auto flags = memory == Memory::host_visible ? vk::MemoryPropertyFlagBits::eHostVisible |
                                                    vk::MemoryPropertyFlagBits::eHostCoherent
                                              : vk::MemoryPropertyFlagBits::eDeviceLocal;
  auto requirements = buffer.buffer_.getMemoryRequirements();
  buffer.memory_ = allocate(requirements, flags);
  buffer.buffer_.bindMemory(*buffer.memory_, 0);
  if (memory == Memory::host_visible) buffer.mapped_ = buffer.memory_.mapMemory(0, size);
  allocated_bytes_ += size;
  set_debug_name(uint64_t(VkBuffer(*buffer.buffer_)), vk::ObjectType::eBuffer, buffer.name_);
  return buffer;
}

Buffer::~Buffer() {
  if (device_ && size_) device_->release(size_);
}

Buffer& Buffer::operator=(Buffer&& other) noexcept {
  if (this == &other) return *this;
  if (device_ && size_) device_->release(size_);
  buffer_ = std::move(other.buffer_);
  memory_ = std::move(other.memory_);
  size_ = std::exchange(other.size_, 0);
  mapped_ = std::exchange(other.mapped_, nullptr);
  name_ = std::move(other.name_);
  device_ = std::exchange(other.device_, nullptr);
  return *this;
}

Image Device::create_image(std::string name, vk::Extent2D extent, vk::Format format,
                           vk::ImageUsageFlags usage, vk::SampleCountFlagBits samples) {
  // Beyond the limit vkCreateImage's behaviour is undefined (lavapipe: 16384): refuse by name.
  const uint32_t max_side = physical_.getProperties().limits.maxImageDimension2D;
  if (extent.width > max_side || extent.height > max_side)
    throw Error(
        fmt::format("image '{}' of {} x {} texels exceeds this device's largest 2D image "
                    "side, {} texels (maxImageDimension2D)",
                    name, extent.width, extent.height, max_side));
  Image image;
  image.name_ = std::move(name);
  image.format_ = format;
  image.extent_ = extent;
  image.device_ = this;
  bool depth = format == vk::Format::eD32Sfloat || format == vk::Format::eD16Unorm;
  vk::ImageCreateInfo info{
      {},
      vk::ImageType::e2D,
      format,
      vk::Extent3D{extent.width, extent.height, 1},
      1,
      1,
      samples,
      vk::ImageTiling::eOptimal,
      usage | vk::ImageUsageFlagBits::eTransferSrc | vk::ImageUsageFlagBits::eTransferDst,
      vk::SharingMode::eExclusive};
  image.image_ = vk::raii::Image(device_, info);
  auto requirements = image.image_.getMemoryRequirements();
  image.memory_ = allocate(requirements, vk::MemoryPropertyFlagBits::eDeviceLocal);
  image.image_.bindMemory(*image.memory_, 0);
  image.bytes_ = requirements.size;
  auto aspect = depth ? vk::ImageAspectFlagBits::eDepth : vk::ImageAspectFlagBits::eColor;
  image.view_ = vk::raii::ImageView(
      device_, vk::ImageViewCreateInfo{
                   {}, *image.image_, vk::ImageViewType::e2D, format, {}, {aspect, 0, 1, 0, 1}});
  allocated_bytes_ += image.bytes_;
  set_debug_name(uint64_t(VkImage(*image.image_)), vk::ObjectType::eImage, image.name_);
  // Every image lives in GENERAL from here on (see gpu.h).
  submit_and_wait([&](vk::CommandBuffer cmd) {
    vk::ImageMemoryBarrier barrier{
        {},
        vk::AccessFlagBits::eMemoryRead | vk::AccessFlagBits::eMemoryWrite,
        vk::ImageLayout::eUndefined,
        vk::ImageLayout::eGeneral,
        VK_QUEUE_FAMILY_IGNORED,
        VK_QUEUE_FAMILY_IGNORED,
        *image.image_,
        {aspect, 0, 1, 0, 1}};
    cmd.pipelineBarrier(vk::PipelineStageFlagBits::eTopOfPipe,
                        vk::PipelineStageFlagBits::eAllCommands, {}, {}, {}, barrier);
  });
  return image;
}

Image::~Image() {
  if (device_ && bytes_) device_->release(bytes_);
}

Image& Image::operator=(Image&& other) noexcept {
  if (this == &other) return *this;
  if (device_ && bytes_) device_->release(bytes_);
  view_ = std::move(other.view_);  // the view goes before the image it views
  image_ = std::move(other.image_);
  memory_ = std::move(other.memory_);
  format_ = other.format_;
  extent_ = other.extent_;
  bytes_ = std::exchange(other.bytes_, 0);
  name_ = std::move(other.name_);
  device_ = std::exchange(other.device_, nullptr);
  return *this;
}

void Device::submit_and_wait(const std::function<void(vk::CommandBuffer)>& record) {
  vk::raii::CommandBuffers buffers(device_, {*command_pool_, vk::CommandBufferLevel::ePrimary, 1});
  vk::CommandBuffer cmd = *buffers[0];
  cmd.begin(vk::CommandBufferBeginInfo{vk::CommandBufferUsageFlagBits::eOneTimeSubmit});
  record(cmd);
  cmd.end();
  vk::raii::Fence fence(device_, vk::FenceCreateInfo{});
  queue_.submit(vk::SubmitInfo{{}, {}, cmd}, *fence);
  check(device_.waitForFences(*fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
}

void Device::upload(const Buffer& dst, const void* data, vk::DeviceSize bytes,
                    vk::DeviceSize offset) {
  if (bytes == 0) return;
  if (dst.mapped()) {
    std::memcpy(static_cast<char*>(dst.mapped()) + offset, data, bytes);
    return;
  }
  Buffer staging = create_buffer(dst.name() + "/staging", bytes,
                                 vk::BufferUsageFlagBits::eTransferSrc, Memory::host_visible);
  std::memcpy(staging.mapped(), data, bytes);
  submit_and_wait([&](vk::CommandBuffer cmd) {
    cmd.copyBuffer(staging.handle(), dst.handle(), vk::BufferCopy{0, offset, bytes});
  });
}

void Device::download(const Buffer& src, void* data, vk::DeviceSize bytes, vk::DeviceSize offset) {
  if (bytes == 0) return;
  if (src.mapped()) {
    std::memcpy(data, static_cast<const char*>(src.mapped()) + offset, bytes);
    return;
  }
  Buffer staging = create_buffer(src.name() + "/readback", bytes,
                                 vk::BufferUsageFlagBits::eTransferDst, Memory::host_visible);
  submit_and_wait([&](vk::CommandBuffer cmd) {
    full_barrier(cmd);
    cmd.copyBuffer(src.handle(), staging.handle(), vk::BufferCopy{offset, 0, bytes});
  });
  std::memcpy(data, staging.mapped(), bytes);
}

void Device::read_image(const Image& image, std::vector<float>& rgba) {
  if (image.format() != vk::Format::eR32G32B32A32Sfloat)
    throw Error(fmt::format("read_image: '{}' is not RGBA32F", image.name()));
  auto extent = image.extent();
  vk::DeviceSize bytes = vk::DeviceSize(extent.width) * extent.height * 16;
  Buffer staging = create_buffer(image.name() + "/readback", bytes,
                                 vk::BufferUsageFlagBits::eTransferDst, Memory::host_visible);
  submit_and_wait([&](vk::CommandBuffer cmd) {
    full_barrier(cmd);
    vk::BufferImageCopy region{0,         0,
                               0,         {vk::ImageAspectFlagBits::eColor, 0, 0, 1},
                               {0, 0, 0}, {extent.width, extent.height, 1}};
    cmd.copyImageToBuffer(image.handle(), vk::ImageLayout::eGeneral, staging.handle(), region);
  });
  rgba.resize(size_t(extent.width) * extent.height * 4);
  std::memcpy(rgba.data(), staging.mapped(), bytes);
}

void Device::begin_rendering(vk::CommandBuffer cmd, const vk::RenderingInfo& info) const {
  const auto& d = *device_.getDispatcher();
  auto begin = d.vkCmdBeginRendering ? d.vkCmdBeginRendering : d.vkCmdBeginRenderingKHR;
  begin(cmd, reinterpret_cast<const VkRenderingInfo*>(&info));
}

void Device::end_rendering(vk::CommandBuffer cmd) const {
  const auto& d = *device_.getDispatcher();
  auto end = d.vkCmdEndRendering ? d.vkCmdEndRendering : d.vkCmdEndRenderingKHR;
  end(cmd);
}

void full_barrier(vk::CommandBuffer cmd) {
  vk::MemoryBarrier barrier{vk::AccessFlagBits::eMemoryWrite,
                            vk::AccessFlagBits::eMemoryRead | vk::AccessFlagBits::eMemoryWrite};
  cmd.pipelineBarrier(vk::PipelineStageFlagBits::eAllCommands,
                      vk::PipelineStageFlagBits::eAllCommands, {}, barrier, {}, {});
}

}  // namespace pb::gpu
