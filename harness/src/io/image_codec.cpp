// The image codec module (io/image.h's ImageCodec says why it is a module): OpenImageIO's reader
// and writer behind pb::io::ImageCodec, and the module's one exported symbol. It links OpenImageIO
// and fmt only, none of libphotonbench.
#include <OpenImageIO/imageio.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <vector>

#include "io/image.h"
#include "photonbench/error.h"

namespace pb::io {
namespace {

Image read_with_oiio(const std::filesystem::path& file) {
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
  // A scanline file of 32-bit floats in every channel (every EXR photonbench writes) is read as
  // stored, straight into the image: read_image reads through a temporary buffer of many
  // scanlines, which AddressSanitizer maps and poisons afresh at every read (measured: most of a
  // small cell's time in the sanitized build went to that buffer's shadow memory, at each
  // cached reference read). Other formats are converted by read_image; OIIO converts integer
  // formats to [0, 1] floats, the display-encoded value / 255.
  bool stored_as_float = spec.format == OIIO::TypeDesc::FLOAT && spec.channelformats.empty() &&
                         spec.tile_width == 0 && spec.depth == 1;
  bool read = false;
  if (stored_as_float) {
    std::lock_guard<OIIO::ImageInput> lock(*in);  // the native reads expect the caller to hold it
    read = in->read_native_scanlines(0, 0, spec.y, spec.y + spec.height, spec.z, 0, spec.nchannels,
                                     image.pixels.data());
  } else {
    read = in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, image.pixels.data());
  }
  if (!read)
    throw InputError(fmt::format("{}: cannot read image: {}", file.string(), in->geterror()));
  in->close();
  return image;
}

void write_with_oiio(const std::filesystem::path& file, const std::filesystem::path& temporary,
                     const Image& image) {
  bool is_png = file.extension() == ".png";
  OIIO::ImageSpec spec(image.width, image.height, image.channels,
                       is_png ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::FLOAT);
  if (!is_png) spec.attribute("compression", "zip");
  // OIIO picks the format from the extension, which the temporary name keeps.
  auto out = OIIO::ImageOutput::create(temporary.string());
  if (!out || !out->open(temporary.string(), spec))
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
}

constexpr ImageCodec kOpenImageIoCodec{read_with_oiio, write_with_oiio};

}  // namespace
}  // namespace pb::io

extern "C" __attribute__((visibility("default"))) const pb::io::ImageCodec*
photonbench_image_codec() {
  return &pb::io::kOpenImageIoCodec;
}
