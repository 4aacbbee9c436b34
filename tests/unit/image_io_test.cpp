// Images written by photonbench read back as written: EXR bit for bit (the float scanline files
// that io/image_codec.cpp reads as stored), PNG to the 8-bit step.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>

#include "io/image.h"

namespace image_io_test {

namespace fs = std::filesystem;
using pb::io::Image;

// A folder of this process's, removed with everything in it at the end of the test.
struct Scratch {
  fs::path dir = fs::temp_directory_path() / ("pb_image_io_" + std::to_string(::getpid()));
  Scratch() { fs::create_directories(dir); }
  ~Scratch() { fs::remove_all(dir); }
  fs::path operator/(const std::string& name) const { return dir / name; }
};

// Every pixel and channel a different value, none of them round, with the values a radiance
// image can hold at its ends (zero, a subnormal, a large one, infinity).
Image distinct_values(int width, int height, int channels) {
  Image image(width, height, channels);
  for (size_t i = 0; i < image.pixels.size(); ++i)
    image.pixels[i] = std::ldexp(1.0f + 0.0078125f * float(i % 97), int(i % 29) - 14) / 3.0f;
  image.pixels[0] = 0.0f;
  image.pixels[1] = std::numeric_limits<float>::denorm_min();
  image.pixels[2] = 65504.0f * 1000.0f;  // beyond half floats: a 32-bit file keeps it
  image.pixels.back() = std::numeric_limits<float>::infinity();
  return image;
}

uint32_t bits(float v) {
  uint32_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

TEST(ImageIo, ExrReadsBackBitForBitInEveryChannelCount) {
  Scratch scratch;
  for (int channels = 1; channels <= 4; ++channels) {
    // An odd size: rows of a width that is no multiple of a block, a height of one chunk or less.
    Image written = distinct_values(37, 11, channels);
    fs::path file = scratch / ("image_" + std::to_string(channels) + ".exr");
    pb::io::write_image(file, written);
    Image read = pb::io::read_image(file);
    ASSERT_EQ(read.width, written.width);
    ASSERT_EQ(read.height, written.height);
    ASSERT_EQ(read.channels, channels);
    EXPECT_TRUE(read.linear);
    size_t mismatches = 0, first = 0;
    for (size_t i = 0; i < written.pixels.size(); ++i)
      if (bits(read.pixels[i]) != bits(written.pixels[i]) && mismatches++ == 0) first = i;
    EXPECT_EQ(mismatches, 0u) << channels << " channels; first at value " << first << ": "
                              << read.pixels[first] << " read, " << written.pixels[first]
                              << " written";
  }
}

TEST(ImageIo, PngReadsBackToTheEightBitStep) {
  Scratch scratch;
  Image written(13, 7, 3, false);
  for (size_t i = 0; i < written.pixels.size(); ++i) written.pixels[i] = float(i % 256) / 255.0f;
  fs::path file = scratch / "image.png";
  pb::io::write_image(file, written);
  Image read = pb::io::read_image(file);
  ASSERT_EQ(read.width, 13);
  ASSERT_EQ(read.height, 7);
  ASSERT_EQ(read.channels, 3);
  EXPECT_FALSE(read.linear);
  for (size_t i = 0; i < written.pixels.size(); ++i)
    ASSERT_NEAR(read.pixels[i], written.pixels[i], 0.5f / 255.0f) << "value " << i;
}

}  // namespace image_io_test
