#include "io/image.h"

#include <dlfcn.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "photonbench/error.h"

namespace pb::io {
namespace {

#ifdef PB_IMAGE_CODEC_LINKED
}  // namespace
}  // namespace pb::io
extern "C" const pb::io::ImageCodec* photonbench_image_codec();
namespace pb::io {
namespace {
// -DPB_IMAGE_CODEC_MODULE=OFF (the sanitized build): the codec is part of the library.
const ImageCodec& codec() { return *photonbench_image_codec(); }
#else
// The codec module (ImageCodec) sits beside libphotonbench.so, in the build folder and installed.
const ImageCodec& codec() {
  static const ImageCodec* loaded = [] {
    Dl_info self{};
    if (dladdr(reinterpret_cast<const void*>(&read_image), &self) == 0 || self.dli_fname == nullptr)
      throw Error("image codec: cannot locate libphotonbench.so to find its image codec beside it");
    std::filesystem::path module =
        std::filesystem::path(self.dli_fname).parent_path() / "libphotonbench_image_io.so";
    void* handle = dlopen(module.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) {
      const char* error = dlerror();
      throw Error(fmt::format("image codec: cannot load {}: {}", module.string(),
                              error ? error : "unknown error"));
    }
    auto entry =
        reinterpret_cast<const ImageCodec* (*)()>(dlsym(handle, "photonbench_image_codec"));
    if (entry == nullptr)
      throw Error(fmt::format("image codec: {} has no photonbench_image_codec", module.string()));
    return entry();
  }();
  return *loaded;
}
#endif

}  // namespace

Image read_image(const std::filesystem::path& file) {
  // OpenImageIO reads a device as a stream that never ends (/dev/zero), so only files are opened.
  std::error_code ec;
  auto status = std::filesystem::status(file, ec);
  if (!std::filesystem::exists(status))
    throw InputError(fmt::format("{}: image file not found", file.string()));
  if (!std::filesystem::is_regular_file(status))
    throw InputError(fmt::format("{}: not a regular file (a folder, device or pipe), not an image",
                                 file.string()));
  return codec().read(file);
}

void write_image(const std::filesystem::path& file, const Image& image) {
  std::filesystem::path temporary =
      file.parent_path() / (".tmp-" + std::to_string(::getpid()) + "-" + file.filename().string());
  codec().write(file, temporary, image);
  std::filesystem::rename(temporary, file);
}

float srgb_encode(float linear) {
  linear = std::clamp(linear, 0.f, 1.f);
  return linear <= 0.0031308f ? 12.92f * linear : 1.055f * std::pow(linear, 1.f / 2.4f) - 0.055f;
}

float srgb_decode(float encoded) {
  return encoded <= 0.04045f ? encoded / 12.92f : std::pow((encoded + 0.055f) / 1.055f, 2.4f);
}

Image display_encode(const Image& linear_image, float exposure) {
  Image out = linear_image;
  out.linear = false;
  for (size_t i = 0; i < out.pixels.size(); ++i) {
    bool is_alpha = out.channels == 4 && i % 4 == 3;
    if (!is_alpha) out.pixels[i] = srgb_encode(out.pixels[i] * exposure);
  }
  return out;
}

}  // namespace pb::io
