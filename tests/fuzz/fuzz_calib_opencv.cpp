// libFuzzer target: OpenCV stereo calibration files (cv::FileStorage YAML/XML
// and plain YAML: M1 D1 M2 D2 R T, P1 P2). Input: one byte choosing the file
// name extension and an optional image size, then the file.
#include <cstddef>
#include <cstdint>

#include "calibration_fuzz.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static const char* const kNames[] = {"calib.yaml", "calib.xml", "calib.yml"};
  const std::string path = sg::fuzz::scratch().write(kNames[(data[0] & 0x7f) % 3], sg::fuzz::asText(data + 1, size - 1));
  sg::fuzz::exerciseCalibration(path, sg::fuzz::sizeHint(data[0]));
  return 0;
}
