#include "cell/video_capture.h"

#include <fmt/format.h>

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>

#include "io/image.h"
#include "photonbench/error.h"

namespace pb::run {

bool captures_cell(const config::VideoSettings& video, const std::string& technique) {
  if (!video.enabled) return false;
  return video.techniques.empty() || std::find(video.techniques.begin(), video.techniques.end(),
                                               technique) != video.techniques.end();
}

bool captures_frame(const config::VideoSettings& video, const config::FrameSettings& frames,
                    uint32_t frame) {
  if (!video.enabled || !frames.measured(frame)) return false;
  return (frame - frames.start) % std::max<uint32_t>(video.every, 1) == 0;
}

std::array<uint32_t, 4> video_crop(const config::VideoSettings& video, uint32_t width,
                                   uint32_t height) {
  if (video.crop[2] > 0 && video.crop[3] > 0)
    return {video.crop[0], video.crop[1], video.crop[2], video.crop[3]};
  const uint32_t w = std::max<uint32_t>(1, width / 2), h = std::max<uint32_t>(1, height / 2);
  return {(width - w) / 2, (height - h) / 2, w, h};
}

void write_video_frame(const std::filesystem::path& dir, uint32_t frame,
                       const std::vector<float>& rgba, uint32_t width, uint32_t height) {
  io::Image image(int(width), int(height), 4);
  image.pixels = rgba;
  std::filesystem::create_directories(dir);
  io::write_image(dir / fmt::format("frame_{:04d}.png", frame), io::display_encode(image));
}

void write_video_index(const std::filesystem::path& dir, float fps,
                       const config::VideoSettings& video, uint32_t width, uint32_t height,
                       const std::vector<uint32_t>& frames) {
  const std::array<uint32_t, 4> crop = video_crop(video, width, height);
  const nlohmann::json index = {{"fps", fps},       {"every", video.every}, {"width", width},
                                {"height", height}, {"crop", crop},         {"frames", frames}};
  std::filesystem::create_directories(dir);
  std::ofstream out(dir / "video.json");
  out << index.dump(2) << "\n";
  if (!out) throw Error(fmt::format("cannot write {}", (dir / "video.json").string()));
}

}  // namespace pb::run
