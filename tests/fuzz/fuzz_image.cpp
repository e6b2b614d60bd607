// libFuzzer target: image decoding of the frame sources (io/image_file.hpp,
// the pairs: and kitti: sources read every frame through it). Bad bytes must
// end in sg::InputError; an accepted image is a non-empty mono8 image.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "config/errors.hpp"
#include "io/image_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::vector<unsigned char> bytes(data, data + size);
  cv::Mat image;
  try {
    image = sg::decodeMono8(bytes, "fuzz.png");
  } catch (const sg::InputError&) {
    return 0;
  }
  if (image.empty() || image.type() != CV_8UC1 || image.cols > 16384 || image.rows > 16384) {
    std::fprintf(stderr, "decodeMono8 accepted a %dx%d image of type %d\n", image.cols, image.rows, image.type());
    std::abort();
  }
  return 0;
}
