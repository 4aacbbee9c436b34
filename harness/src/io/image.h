// Images on disk through OpenImageIO (in a module loaded on first use: ImageCodec): EXR holds
// linear (scene-referred) values, PNG display-encoded 8-bit values. Writes are atomic (write to a
// temporary name, then rename), so a crash never leaves a half-written image that a resumed run
// would trust.
#pragma once

#include <filesystem>
#include <vector>

namespace pb::io {

// Interleaved float pixels, row-major from the top-left row. `linear` says how to read the values:
// true for radiance (EXR, HDR), false for display-encoded values in [0, 1] (an 8-bit sRGB PNG
// divided by 255, LDR).
struct Image {
  int width = 0, height = 0, channels = 0;
  std::vector<float> pixels;
  bool linear = true;

  Image() = default;
  Image(int w, int h, int c, bool is_linear = true)
      : width(w), height(h), channels(c), pixels(size_t(w) * h * c, 0.f), linear(is_linear) {}
  float& at(int x, int y, int c) { return pixels[(size_t(y) * width + x) * channels + c]; }
  float at(int x, int y, int c) const { return pixels[(size_t(y) * width + x) * channels + c]; }
  size_t pixel_count() const { return size_t(width) * height; }
};

// The largest side of an image read_image accepts (the largest config resolution is 8192).
inline constexpr int kMaxImageSide = 16384;

// Reads any format OpenImageIO knows; 8-bit files come back with linear = false and values / 255,
// float files with linear = true. Throws pb::InputError naming the file: not a regular file, not
// an image, sides beyond kMaxImageSide or more than 4 channels.
Image read_image(const std::filesystem::path& file);

// Writes by extension: .exr stores the float values as they are (32-bit float); .png quantises
// values in [0, 1] to 8 bits (the caller encodes for display first: see display_encode). Throws
// pb::Error.
void write_image(const std::filesystem::path& file, const Image& image);

// sRGB transfer function of each colour channel after clamping to [0, 1] (alpha is left alone).
Image display_encode(const Image& linear_image, float exposure = 1.0f);

float srgb_encode(float linear);
float srgb_decode(float encoded);

// read_image and write_image's OpenImageIO halves, in the module libphotonbench_image_io.so
// (io/image_codec.cpp) that the library loads beside itself on the first image read or written:
// Debian's OpenImageIO links every format it knows (FFmpeg, GDCM, libheif, GStreamer, ...), 260
// shared libraries whose loading took 0.45 s of every process's start (0.7-0.9 s under the
// sanitizers), about 90% of it, measured against an empty program; most processes of a run or of
// the tests (validate, schema, list, a cell without metric frames, most unit tests) never touch an
// image. `file` is a regular file (read), or the destination with `temporary`, a name in its folder
// with its extension, written first (write).
struct ImageCodec {
  Image (*read)(const std::filesystem::path& file);
  void (*write)(const std::filesystem::path& file, const std::filesystem::path& temporary,
                const Image& image);
};

}  // namespace pb::io
