// Which frames of a cell become video frames (config `video:`), and writing them. The frame is
// the output the frame loop already reads back after the timed region (its NaN check), so saving
// it adds no GPU work and nothing inside the timing; `photonbench video` (tools/pbtools/video.py)
// encodes the folder.
//
//   cells/<cell>/video/frame_NNNN.png   the display-encoded output of each captured frame
//   cells/<cell>/video/video.json       {fps, every, crop: [x, y, w, h], frames: [N, ...]}
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "config/config.h"

namespace pb::run {

// Whether a cell of `technique` is captured: the block is on and names it (or every cell).
bool captures_cell(const config::VideoSettings& video, const std::string& technique);

// Whether `frame` is captured: measured (warm-up frames are not shown) and every `every`-th from
// the first measured frame on.
bool captures_frame(const config::VideoSettings& video, const config::FrameSettings& frames,
                    uint32_t frame);

// The window of the lossless crop: the block's, or the centre half of the image.
std::array<uint32_t, 4> video_crop(const config::VideoSettings& video, uint32_t width,
                                   uint32_t height);

// Writes `rgba` (linear, width x height) as dir/frame_NNNN.png, display-encoded as the metric
// frames' PNGs are.
void write_video_frame(const std::filesystem::path& dir, uint32_t frame,
                       const std::vector<float>& rgba, uint32_t width, uint32_t height);

// Writes dir/video.json: what the encoder needs to play the frames at the animation's rate.
void write_video_index(const std::filesystem::path& dir, float fps,
                       const config::VideoSettings& video, uint32_t width, uint32_t height,
                       const std::vector<uint32_t>& frames);

}  // namespace pb::run
