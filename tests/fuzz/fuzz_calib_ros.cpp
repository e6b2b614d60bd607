// libFuzzer target: a ROS camera_info pair ("left.yaml,right.yaml"). Input:
// one byte for an optional image size, then the left file, a line "#right",
// then the right file (no such line: the right file is empty).
#include <cstddef>
#include <cstdint>
#include <string>

#include "calibration_fuzz.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::string_view text = sg::fuzz::asText(data + 1, size - 1);
  const std::string_view separator = "\n#right\n";
  const std::size_t split = text.find(separator);
  const std::string_view left = split == std::string_view::npos ? text : text.substr(0, split);
  const std::string_view right =
      split == std::string_view::npos ? std::string_view() : text.substr(split + separator.size());
  const std::string left_path = sg::fuzz::scratch().write("left.yaml", left);
  const std::string right_path = sg::fuzz::scratch().write("right.yaml", right);
  sg::fuzz::exerciseCalibration(left_path + "," + right_path, sg::fuzz::sizeHint(data[0]));
  return 0;
}
