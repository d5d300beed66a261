// Writing rendered frames: one RGB frame as PNG (libpng), several as an animated GIF
// (giflib, a palette quantised per frame). Frames are 8-bit RGB, row-major, top row first.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/status.h"

namespace coins::envs {

struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;  // height x width x 3
};

Status WritePng(const std::string& path, const Image& image);
// delay_cs: time between frames in hundredths of a second; loops forever
Status WriteGif(const std::string& path, const std::vector<Image>& frames, int delay_cs);

}  // namespace coins::envs
