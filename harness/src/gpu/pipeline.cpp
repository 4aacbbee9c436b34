// Compute and graphics pipelines bound through push descriptors: a pipeline is its SPIR-V, its
// binding list and its push-constant size; `bind` pushes the resources in binding order.
#include <fmt/format.h>

#include "photonbench/error.h"
#include "photonbench/gpu.h"

namespace pb::gpu {

namespace {

vk::DescriptorType descriptor_type(Binding binding) {
  switch (binding) {
    case Binding::storage_buffer:
      return vk::DescriptorType::eStorageBuffer;
    case Binding::storage_image:
      return vk::DescriptorType::eStorageImage;
    case Binding::sampled_image:
      return vk::DescriptorType::eCombinedImageSampler;
  }
  return vk::DescriptorType::eStorageBuffer;
}

vk::raii::ShaderModule make_module(const vk::raii::Device& device,
                                   std::span<const uint32_t> spirv) {
  return vk::raii::ShaderModule(device,
                                vk::ShaderModuleCreateInfo{{}, spirv.size_bytes(), spirv.data()});
}

void make_layouts(const vk::raii::Device& device, Pipeline& pipeline,
                  const std::vector<Binding>& bindings, vk::ShaderStageFlags stages,
                  uint32_t push_bytes, vk::raii::DescriptorSetLayout& set_layout,
                  vk::raii::PipelineLayout& layout) {
  std::vector<vk::DescriptorSetLayoutBinding> layout_bindings;
  for (uint32_t i = 0; i < bindings.size(); ++i)
    layout_bindings.push_back({i, descriptor_type(bindings[i]), 1, stages});
  set_layout = vk::raii::DescriptorSetLayout(
      device, vk::DescriptorSetLayoutCreateInfo{
                  vk::DescriptorSetLayoutCreateFlagBits::ePushDescriptorKHR, layout_bindings});
  vk::PushConstantRange range{stages, 0, push_bytes};
  vk::DescriptorSetLayout set = *set_layout;
  vk::PipelineLayoutCreateInfo info{{}, set};
  if (push_bytes) info.setPushConstantRanges(range);
  layout = vk::raii::PipelineLayout(device, info);
  (void)pipeline;
}

}  // namespace

Pipeline Device::create_compute_pipeline(std::string name, std::span<const uint32_t> spirv,
                                         std::vector<Binding> bindings, uint32_t push_bytes) {
  Pipeline pipeline;
  pipeline.device_ = this;
  pipeline.name_ = std::move(name);
  pipeline.bind_point_ = vk::PipelineBindPoint::eCompute;
  pipeline.bindings_ = std::move(bindings);
  pipeline.push_stages_ = vk::ShaderStageFlagBits::eCompute;
  make_layouts(device_, pipeline, pipeline.bindings_, pipeline.push_stages_, push_bytes,
               pipeline.set_layout_, pipeline.layout_);
  auto module = make_module(device_, spirv);
  vk::ComputePipelineCreateInfo info{
      {},
      vk::PipelineShaderStageCreateInfo{{}, vk::ShaderStageFlagBits::eCompute, *module, "main"},
      *pipeline.layout_};
  pipeline.pipeline_ = vk::raii::Pipeline(device_, nullptr, info);
  set_debug_name(uint64_t(VkPipeline(*pipeline.pipeline_)), vk::ObjectType::ePipeline,
                 pipeline.name_);
  return pipeline;
}

Pipeline Device::create_graphics_pipeline(const GraphicsPipelineDesc& desc) {
  Pipeline pipeline;
  pipeline.device_ = this;
  pipeline.name_ = desc.name;
  pipeline.bind_point_ = vk::PipelineBindPoint::eGraphics;
  pipeline.bindings_ = desc.bindings;
  pipeline.push_stages_ = vk::ShaderStageFlagBits::eVertex | vk::ShaderStageFlagBits::eFragment;
  make_layouts(device_, pipeline, pipeline.bindings_, pipeline.push_stages_, desc.push_bytes,
               pipeline.set_layout_, pipeline.layout_);

  auto vertex = make_module(device_, desc.vertex_spirv);
  std::vector<vk::PipelineShaderStageCreateInfo> stages = {
      {{}, vk::ShaderStageFlagBits::eVertex, *vertex, "main"}};
  vk::raii::ShaderModule fragment{nullptr};
  if (!desc.fragment_spirv.empty()) {
    fragment = make_module(device_, desc.fragment_spirv);
    stages.push_back({{}, vk::ShaderStageFlagBits::eFragment, *fragment, "main"});
  }

  auto format_bytes = [](vk::Format f) -> uint32_t {
    switch (f) {
      case vk::Format::eR32Sfloat:
      case vk::Format::eR32Uint:
        return 4;
      case vk::Format::eR32G32Sfloat:
        return 8;
      case vk::Format::eR32G32B32Sfloat:
        return 12;
      case vk::Format::eR32G32B32A32Sfloat:
      case vk::Format::eR32G32B32A32Uint:
        return 16;
      default:
        throw Error(fmt::format("vertex attribute format {} not supported", vk::to_string(f)));
    }
  };
  std::vector<vk::VertexInputAttributeDescription> attributes;
  uint32_t offset = 0;
  for (uint32_t i = 0; i < desc.vertex_attributes.size(); ++i) {
    attributes.push_back({i, 0, desc.vertex_attributes[i], offset});
    offset += format_bytes(desc.vertex_attributes[i]);
  }
  vk::VertexInputBindingDescription binding{0, desc.vertex_stride, vk::VertexInputRate::eVertex};
  vk::PipelineVertexInputStateCreateInfo vertex_input{{}, binding, attributes};
  if (desc.vertex_stride == 0) vertex_input = vk::PipelineVertexInputStateCreateInfo{};
  vk::PipelineInputAssemblyStateCreateInfo assembly{{}, vk::PrimitiveTopology::eTriangleList};
  vk::PipelineViewportStateCreateInfo viewport{{}, 1, nullptr, 1, nullptr};
  vk::PipelineRasterizationStateCreateInfo raster{{},
                                                  VK_FALSE,
                                                  VK_FALSE,
                                                  vk::PolygonMode::eFill,
                                                  desc.cull,
                                                  vk::FrontFace::eCounterClockwise,
                                                  desc.depth_bias,
                                                  0,
                                                  0,
                                                  0,
                                                  1.f};
  vk::PipelineMultisampleStateCreateInfo multisample{{}, desc.samples};
  if (desc.min_sample_shading > 0) {
    multisample.sampleShadingEnable = VK_TRUE;
    multisample.minSampleShading = desc.min_sample_shading;
  }
  bool has_depth = desc.depth_format != vk::Format::eUndefined;
  vk::PipelineDepthStencilStateCreateInfo depth{
      {}, has_depth, has_depth, vk::CompareOp::eLessOrEqual};
  std::vector<vk::PipelineColorBlendAttachmentState> blends;
  for (size_t i = 0; i < desc.color_formats.size(); ++i) {
    vk::PipelineColorBlendAttachmentState state;
    state.colorWriteMask = vk::ColorComponentFlagBits::eR | vk::ColorComponentFlagBits::eG |
                           vk::ColorComponentFlagBits::eB | vk::ColorComponentFlagBits::eA;
    if (i < desc.additive_blend.size() && desc.additive_blend[i]) {
      state.blendEnable = VK_TRUE;
      state.srcColorBlendFactor = state.dstColorBlendFactor = vk::BlendFactor::eOne;
      state.srcAlphaBlendFactor = state.dstAlphaBlendFactor = vk::BlendFactor::eOne;
    }
    blends.push_back(state);
  }
  vk::PipelineColorBlendStateCreateInfo blend{{}, VK_FALSE, vk::LogicOp::eCopy, blends};
  std::vector<vk::DynamicState> dynamic_states = {vk::DynamicState::eViewport,
                                                  vk::DynamicState::eScissor};
  if (desc.depth_bias) dynamic_states.push_back(vk::DynamicState::eDepthBias);
  vk::PipelineDynamicStateCreateInfo dynamic{{}, dynamic_states};
  vk::PipelineRenderingCreateInfo rendering{0, desc.color_formats, desc.depth_format};
  vk::GraphicsPipelineCreateInfo info{{},      stages,    &vertex_input, &assembly,
                                      nullptr, &viewport, &raster,       &multisample,
                                      &depth,  &blend,    &dynamic,      *pipeline.layout_};
  info.pNext = &rendering;
  pipeline.pipeline_ = vk::raii::Pipeline(device_, nullptr, info);
  set_debug_name(uint64_t(VkPipeline(*pipeline.pipeline_)), vk::ObjectType::ePipeline,
                 pipeline.name_);
  return pipeline;
}

void Pipeline::bind(vk::CommandBuffer cmd, std::span<const Resource> resources, const void* push,
                    uint32_t push_bytes) const {
  if (resources.size() != bindings_.size())
    throw Error(fmt::format("pipeline '{}' takes {} resources, got {}", name_, bindings_.size(),
                            resources.size()));
  cmd.bindPipeline(bind_point_, *pipeline_);
  std::vector<vk::WriteDescriptorSet> writes;
  std::vector<vk::DescriptorBufferInfo> buffer_infos;
  std::vector<vk::DescriptorImageInfo> image_infos;
  buffer_infos.reserve(resources.size());
  image_infos.reserve(resources.size());
  uint32_t index = 0;
  for (const Resource& resource : resources) {
    vk::WriteDescriptorSet write{{}, index, 0, 1, descriptor_type(bindings_[index])};
    if (auto* buffer = std::get_if<const Buffer*>(&resource)) {
      if (bindings_[index] != Binding::storage_buffer)
        throw Error(fmt::format("pipeline '{}' binding {} is not a buffer", name_, index));
      buffer_infos.push_back({(*buffer)->handle(), 0, VK_WHOLE_SIZE});
      write.pBufferInfo = &buffer_infos.back();
    } else if (auto* image = std::get_if<const Image*>(&resource)) {
      if (bindings_[index] != Binding::storage_image)
        throw Error(fmt::format("pipeline '{}' binding {} is not a storage image", name_, index));
      image_infos.push_back({nullptr, (*image)->view(), vk::ImageLayout::eGeneral});
      write.pImageInfo = &image_infos.back();
    } else {
      auto sampled = std::get<Sampled>(resource);
      if (bindings_[index] != Binding::sampled_image)
        throw Error(fmt::format("pipeline '{}' binding {} is not a sampled image", name_, index));
      image_infos.push_back(
          {device_->nearest_sampler(), sampled.image->view(), vk::ImageLayout::eGeneral});
      write.pImageInfo = &image_infos.back();
    }
    writes.push_back(write);
    ++index;
  }
  if (!writes.empty())
    cmd.pushDescriptorSetKHR(bind_point_, *layout_, 0, writes, *device_->device().getDispatcher());
  if (push_bytes) cmd.pushConstants(*layout_, push_stages_, 0, push_bytes, push);
}

}  // namespace pb::gpu
