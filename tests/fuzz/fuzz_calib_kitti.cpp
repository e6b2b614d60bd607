// libFuzzer target: KITTI calib text files (P0..P3, P_rect_02/03, Karlsruhe
// P1/P2). Input: one byte for an optional image size, then the file.
#include <cstddef>
#include <cstdint>

#include "calibration_fuzz.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::string path = sg::fuzz::scratch().write("calib.txt", sg::fuzz::asText(data + 1, size - 1));
  sg::fuzz::exerciseCalibration(path, sg::fuzz::sizeHint(data[0]));
  return 0;
}
