// The plugin boundary (plan/plugins.h): which differences in a module's build record fail it, and
// that the message names both sides; and the loader's use of it on the test plugins.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "photonbench/plugin.h"
#include "plan/plugins.h"

namespace pb::run {
namespace plugin_abi_test {

std::string fmt_vulkan(uint32_t module, uint32_t host) {
  return "Vulkan-Hpp headers " + std::to_string(module) + " (photonbench: " + std::to_string(host) +
         ")";
}

// A copy of this build's record whose fields a test may change.
struct EditableRecord {
  EditableRecord() : record(*detail::this_build()) {
    sizes.assign(record.class_sizes, record.class_sizes + record.class_size_count);
    record.class_sizes = sizes.data();
  }
  pb_build_record record;
  std::vector<pb_class_size> sizes;
};

TEST(PluginAbi, SameBuildMatches) {
  EditableRecord module;
  EXPECT_EQ(build_mismatch(*detail::this_build(), module.record), "");
}

TEST(PluginAbi, CompilerAloneIsReportedNotCompared) {
  EditableRecord module;
  module.record.compiler = "clang 99.0.0";
  module.record.standard_library = "libstdc++ 99 (20990101)";
  EXPECT_EQ(build_mismatch(*detail::this_build(), module.record), "");
}

TEST(PluginAbi, VulkanHppVersionNamesBothSides) {
  EditableRecord module;
  module.record.vulkan_hpp_version += 7;
  module.record.compiler = "clang 99.0.0";
  const pb_build_record& host = *detail::this_build();
  std::string message = build_mismatch(host, module.record);
  EXPECT_NE(message.find(fmt_vulkan(module.record.vulkan_hpp_version, host.vulkan_hpp_version)),
            std::string::npos)
      << message;
  EXPECT_NE(message.find("plugin built with clang 99.0.0"), std::string::npos) << message;
  EXPECT_NE(message.find(std::string("photonbench with ") + host.compiler), std::string::npos)
      << message;
}

TEST(PluginAbi, ClassSizeAndLibraryAbiEachFail) {
  EditableRecord module;
  const pb_build_record& host = *detail::this_build();
  for (auto& size : module.sizes)
    if (std::string(size.name) == "pb::gpu::Device") size.bytes += 8;
  module.record.standard_library_abi = "libc++ 1";
  std::string message = build_mismatch(host, module.record);
  uint32_t device_bytes = 0;
  for (uint32_t i = 0; i < host.class_size_count; ++i)
    if (std::string(host.class_sizes[i].name) == "pb::gpu::Device")
      device_bytes = host.class_sizes[i].bytes;
  ASSERT_GT(device_bytes, 0u) << "the record holds sizeof(pb::gpu::Device)";
  EXPECT_NE(message.find("sizeof(pb::gpu::Device) " + std::to_string(device_bytes + 8) +
                         " bytes (photonbench: " + std::to_string(device_bytes) + ")"),
            std::string::npos)
      << message;
  EXPECT_NE(message.find(std::string("standard library ABI libc++ 1 (photonbench: ") +
                         host.standard_library_abi + ")"),
            std::string::npos)
      << message;
}

TEST(PluginAbi, AssertionsFailNamingNdebugAndTheBuildTypeToUse) {
  EditableRecord module;
  const pb_build_record& host = *detail::this_build();
  module.record.assertions = host.assertions ? 0u : 1u;
  const std::string message = build_mismatch(host, module.record);
  const std::string plugin_side = host.assertions ? "built with NDEBUG" : "built without NDEBUG";
  const std::string host_side = host.assertions ? "built without NDEBUG" : "built with NDEBUG";
  EXPECT_EQ(message.find(plugin_side), 0u) << message;
  EXPECT_NE(message.find("(photonbench: " + host_side), std::string::npos) << message;
  EXPECT_NE(message.find(std::string("configure the plugin with -DCMAKE_BUILD_TYPE=") +
                         (host.assertions ? "Debug" : "Release")),
            std::string::npos)
      << message;
}

TEST(PluginAbi, RecordsVulkanHppDispatcherSizes) {
  // NDEBUG adds a header version and a flag to each dispatcher (vk::DispatchLoaderBase): a plugin
  // that reads the host's dispatchers must agree on their size.
  const pb_build_record& host = *detail::this_build();
  std::vector<std::string> names;
  for (uint32_t i = 0; i < host.class_size_count; ++i) names.push_back(host.class_sizes[i].name);
  for (const char* dispatcher : {"vk::raii::ContextDispatcher", "vk::raii::InstanceDispatcher",
                                 "vk::raii::DeviceDispatcher"})
    EXPECT_NE(std::find(names.begin(), names.end(), dispatcher), names.end()) << dispatcher;
  EditableRecord module;
  for (auto& size : module.sizes)
    if (std::string(size.name) == "vk::raii::DeviceDispatcher") size.bytes += 16;
  EXPECT_NE(build_mismatch(host, module.record).find("sizeof(vk::raii::DeviceDispatcher)"),
            std::string::npos);
}

TEST(PluginAbi, MissingClassFails) {
  EditableRecord module;
  module.sizes.pop_back();
  module.record.class_size_count = uint32_t(module.sizes.size());
  EXPECT_NE(build_mismatch(*detail::this_build(), module.record).find("no size recorded for"),
            std::string::npos);
}

TEST(PluginAbi, LoaderFailsOnlyTheModulesThatDoNotFit) {
  // build/tests/plugins is the test plugins' CMake folder, not a plugin folder: name build/plugins.
  PluginRegistry plugins(
      {std::string(PB_BINARY_DIR) + "/plugins", std::string(PB_BINARY_DIR) + "/test-plugins"});
  const Plugin* wrong = plugins.find("wrong_api_version");
  ASSERT_NE(wrong, nullptr);
  EXPECT_FALSE(wrong->loaded());
  EXPECT_NE(wrong->load_error.find("was built for plugin API version 42"), std::string::npos)
      << wrong->load_error;
  const Plugin* unknown = plugins.find("unknown_path_class");
  ASSERT_NE(unknown, nullptr);
  EXPECT_FALSE(unknown->loaded());
  EXPECT_NE(unknown->load_error.find("declares path class 'C D D L'"), std::string::npos)
      << unknown->load_error;
  const Plugin* direct = plugins.find("direct");
  ASSERT_NE(direct, nullptr);
  EXPECT_TRUE(direct->loaded()) << direct->load_error;
  EXPECT_EQ(direct->descriptor->api_version, PB_PLUGIN_API_VERSION);
}

}  // namespace plugin_abi_test
}  // namespace pb::run
