// Inputs the libFuzzer targets (tests/fuzz) found to crash, kept in
// tests/fuzz/regressions/ exactly as the fuzzer wrote them. Each must now be
// rejected with the project's own error naming the file and what was wrong.
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>

#include "camera/calibration.hpp"
#include "config/errors.hpp"
#include "temp_dir.hpp"

namespace sg {
namespace {

std::string regression(const std::string& name) {
  const std::string path = std::string(SG_SOURCE_DIR) + "/tests/fuzz/regressions/" + name;
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in.good()) << path;
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// fuzz_calib_opencv: byte 0 picks the file name (0 = .yaml), the rest is the file.
std::string opencvCalibrationError(const test::TempDir& dir, const std::string& name) {
  const std::string input = regression(name);
  EXPECT_FALSE(input.empty());
  static const char* const kNames[] = {"calib.yaml", "calib.xml", "calib.yml"};
  const std::string path = dir.write(kNames[(static_cast<unsigned char>(input[0]) & 0x7f) % 3], input.substr(1));
  try {
    loadCalibration(path);
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(path + ": ", 0), 0u) << "message does not start with the file: " << e.what();
    return e.what();
  }
  ADD_FAILURE() << name << " was accepted";
  return {};
}

TEST(FuzzRegressions, OpenCvMatrixRowsThatAreNotANumberAreRejected) {
  // "rows: N4YAML15ParserExc 3" read as an int gave INT_MAX, and rows * cols overflowed.
  const test::TempDir dir("fuzz_regression");
  EXPECT_NE(opencvCalibrationError(dir, "calib_opencv-rows-not-a-number").find("field 'M1': 'rows' and 'cols' must be whole numbers"),
            std::string::npos);
}

TEST(FuzzRegressions, OpenCvFileWhoseTopLevelIsNotAMappingIsRejected) {
  // cv::FileStorage::operator[] asserted (cv::Exception escaped the reader).
  // The fuzzer's input also holds a NUL byte, which is now refused first; the same
  // shape without it must meet the top-level check.
  const test::TempDir dir("fuzz_regression");
  EXPECT_NE(opencvCalibrationError(dir, "calib_opencv-top-level-not-a-map").find("NUL byte"), std::string::npos);
  const std::string path = dir.write("sequence.yaml", "%YAML:1.0\n---\n- P1\n- 721.5\n");
  try {
    loadCalibration(path);
    ADD_FAILURE() << "a top-level sequence was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), path + ": expected a mapping of calibration fields at the top level");
  }
}

TEST(FuzzRegressions, OpenCvFileWithAnEmptyKeyIsRejected) {
  // OpenCV's YAML parser threw std::length_error from basic_string on "   :ls3 co".
  const test::TempDir dir("fuzz_regression");
  EXPECT_NE(opencvCalibrationError(dir, "calib_opencv-empty-key").find("cannot parse the OpenCV calibration file"),
            std::string::npos);
}

TEST(FuzzRegressions, OpenCvXmlWithANulByteIsRejectedBeforeOpenCvParsesIt) {
  // cv::FileStorage (OpenCV 4.6 XML parser) dereferenced a null pointer on this input.
  const test::TempDir dir("fuzz_regression");
  EXPECT_NE(opencvCalibrationError(dir, "calib_opencv-nul-byte").find("NUL byte at offset 11"), std::string::npos);
}

}  // namespace
}  // namespace sg
