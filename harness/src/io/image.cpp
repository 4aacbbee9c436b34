#include "io/image.h"

#include <OpenImageIO/imageio.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>

#include "photonbench/error.h"

namespace pb::io {

Image read_image(const std::filesystem::path& file) {
  // OpenImageIO reads a device as a stream that never ends (/dev/zero), so only files are opened.
  std::error_code ec;
  auto status = std::filesystem::status(file, ec);
  if (!std::filesystem::exists(status))
    throw InputError(fmt::format("{}: image file not found", file.string()));
  if (!std::filesystem::is_regular_file(status))
    throw InputError(fmt::format("{}: not a regular file (a folder, device or pipe), not an image",
                                 file.string()));
  auto in = OIIO::ImageInput::open(file.string());
  if (!in)
    throw InputError(fmt::format("{}: cannot read image: {}", file.string(), OIIO::geterror()));
  const OIIO::ImageSpec& spec = in->spec();
  // A header may claim any size; a scored image is at most a config's resolution (8192 x 8192).
  if (spec.width <= 0 || spec.height <= 0 || spec.width > kMaxImageSide ||
      spec.height > kMaxImageSide || spec.nchannels <= 0 || spec.nchannels > 4)
    throw InputError(fmt::format(
        "{}: a {} x {} image of {} channels; images are 1 x 1 to {} x {} "
        "with 1 to 4 channels",
        file.string(), spec.width, spec.height, spec.nchannels, kMaxImageSide, kMaxImageSide));
  Image image(spec.width, spec.height, spec.nchannels);
  image.linear = spec.format.basetype == OIIO::TypeDesc::FLOAT ||
                 spec.format.basetype == OIIO::TypeDesc::HALF ||
                 spec.format.basetype == OIIO::TypeDesc::DOUBLE;
  // OIIO converts integer formats to [0, 1] floats; that is the display-encoded value / 255.
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, image.pixels.data()))
    throw InputError(fmt::format("{}: cannot read image: {}", file.string(), in->geterror()));
  in->close();
  return image;
}

void write_image(const std::filesystem::path& file, const Image& image) {
  // OIIO picks the format from the extension, so the temporary name keeps it.
  std::filesystem::path tmp_named =
      file.parent_path() / (".tmp-" + std::to_string(::getpid()) + "-" + file.filename().string());
  bool is_png = file.extension() == ".png";
  OIIO::ImageSpec spec(image.width, image.height, image.channels,
                       is_png ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::FLOAT);
  if (!is_png) spec.attribute("compression", "zip");
  auto out = OIIO::ImageOutput::create(tmp_named.string());
  if (!out || !out->open(tmp_named.string(), spec))
    throw Error(fmt::format("{}: cannot write image: {}", file.string(), OIIO::geterror()));
  std::vector<float> clamped;
  const float* data = image.pixels.data();
  if (is_png) {
    clamped.resize(image.pixels.size());
    std::transform(image.pixels.begin(), image.pixels.end(), clamped.begin(),
                   [](float v) { return std::isfinite(v) ? std::clamp(v, 0.f, 1.f) : 0.f; });
    data = clamped.data();
  }
  if (!out->write_image(OIIO::TypeDesc::FLOAT, data) || !out->close())
    throw Error(fmt::format("{}: cannot write image: {}", file.string(), out->geterror()));
  std::filesystem::rename(tmp_named, file);
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
