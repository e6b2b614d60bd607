// Inputs the libFuzzer targets (tests/fuzz) found to crash, kept in
// tests/fuzz/regressions/ exactly as the fuzzer wrote them. Each must now be
// rejected with the project's own error naming the file and what was wrong.
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "camera/calibration.hpp"
#include "config/errors.hpp"
#include "io/image_file.hpp"
#include "temp_dir.hpp"

namespace sg {
namespace {

std::string regression(const std::string& name) {
  const std::string path = std::string(SG_SOURCE_DIR) + "/tests/fuzz/regressions/" + name;
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in.good()) << path;
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// The error loadCalibration gives for a file written here; a failure when it is accepted.
std::string calibrationError(const std::string& path) {
  try {
    loadCalibration(path);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << path << " was accepted";
  return {};
}

// fuzz_calib_opencv: byte 0 picks the file name (0 = .yaml), the rest is the file.
std::string opencvCalibrationError(const test::TempDir& dir, const std::string& name) {
  const std::string input = regression(name);
  EXPECT_FALSE(input.empty());
  static const char* const kNames[] = {"calib.yaml", "calib.xml", "calib.yml"};
  const std::string path = dir.write(kNames[(static_cast<unsigned char>(input[0]) & 0x7f) % 3], input.substr(1));
  const std::string error = calibrationError(path);
  if (!error.empty()) {
    EXPECT_EQ(error.rfind(path + ": ", 0), 0u) << "message does not start with the file: " << error;
  }
  return error;
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
  EXPECT_EQ(calibrationError(path), path + ": expected a mapping of calibration fields at the top level");
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

TEST(FuzzRegressions, OpenCvXmlCutOffAfterAnAttributesEqualsSignIsRejected) {
  // OpenCV's XML parser read past the end of "<?xml version=" (SEGV on a null pointer).
  const test::TempDir dir("fuzz_regression");
  EXPECT_NE(opencvCalibrationError(dir, "calib_opencv-xml-cut-after-attribute-equals")
                .find("XML calibration file does not end with a closing tag (cut off?)"),
            std::string::npos);
  // The same cut inside the document, after the header.
  const std::string path = dir.write("cut.xml", "<?xml version=\"1.0\"?>\n<opencv_storage>\n<M1 type_id=  \n");
  EXPECT_EQ(calibrationError(path), path + ": XML calibration file does not end with a closing tag (cut off?)");
}

// Image files: only the documented formats reach a decoder, and no header may
// make a decoder allocate for more than 16384 pixels a side. (The image fuzz
// target reached OpenCV's DICOM, WebP and JPEG 2000 decoders through files
// named .png.)
std::string decodeError(const std::vector<unsigned char>& bytes) {
  try {
    decodeMono8(bytes, "frame.png");
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "accepted";
  return {};
}

std::vector<unsigned char> encode(const char* ext, const cv::Mat& image) {
  std::vector<unsigned char> bytes;
  EXPECT_TRUE(cv::imencode(ext, image, bytes)) << ext;
  return bytes;
}

TEST(ImageHardening, FormatsOtherThanPngJpegBmpPnmAreRefusedBeforeDecoding) {
  const cv::Mat grey(8, 8, CV_8UC1, cv::Scalar(77));
  for (const char* ext : {".tiff", ".webp"}) {
    std::vector<unsigned char> bytes;
    if (!cv::imencode(ext, grey, bytes)) continue;  // encoder not built into this OpenCV
    EXPECT_EQ(decodeError(bytes), "frame.png: not a PNG, JPEG, BMP or PNM image (unknown file signature)") << ext;
  }
  const std::string dicom_like(132, 'D');  // DICOM: 128-byte preamble, then "DICM"
  EXPECT_NE(decodeError(std::vector<unsigned char>(dicom_like.begin(), dicom_like.end())).find("unknown file signature"),
            std::string::npos);
  for (const char* ext : {".png", ".jpg", ".bmp", ".pgm"}) {
    const cv::Mat decoded = decodeMono8(encode(ext, grey), std::string("frame") + ext);
    EXPECT_EQ(decoded.size(), grey.size()) << ext;
  }
}

TEST(FuzzRegressions, PnmMagicWithoutWhiteSpaceDoesNotReachTheDicomReader) {
  // "P41111..." passed a looser PNM check; cv::imdecode's own PxM check wants white space
  // after the magic, so it went on to GDCM (DICM at offset 128), which aborted.
  const std::string input = regression("image-pnm-magic-then-dicom");
  EXPECT_EQ(decodeError(std::vector<unsigned char>(input.begin(), input.end())),
            "frame.png: not a PNG, JPEG, BMP or PNM image (unknown file signature)");
}

TEST(FuzzRegressions, FileNamedPngThatIsDicomDoesNotReachTheDicomReader) {
  // cv::imdecode handed this file to GDCM, which asked for 3.9 GB (malloc(3924426544)).
  const std::string input = regression("image-dicom-4gb-allocation");
  EXPECT_EQ(decodeError(std::vector<unsigned char>(input.begin(), input.end())),
            "frame.png: not a PNG, JPEG, BMP or PNM image (unknown file signature)");
}

TEST(FuzzRegressions, JpegWhoseSecondFrameHeaderIsTooTallIsRefused) {
  // The first SOF header passed the size check; the decoder used a later one and
  // returned a 32x47128 image. (The header walk now passes over the bytes between
  // segments as libjpeg does, so it finds that header before decoding.)
  const std::string input = regression("image-jpeg-second-frame-header-too-tall");
  EXPECT_EQ(decodeError(std::vector<unsigned char>(input.begin(), input.end())),
            "frame.png: header declares a 32x47128 image; accepted are 1..16384 pixels a side");
}

TEST(FuzzRegressions, JpegDeclaringAHugeImageWithLittleCodedDataIsRefusedBeforeDecoding) {
  // 766 bytes: a baseline frame header of 12079x12602 colour pixels, one scan with
  // 39 bytes of data. libjpeg decoded all 3.6 million blocks, zeros after the data,
  // for more than 3 s (fuzz_image -timeout=3).
  const std::string input = regression("image-jpeg-huge-frame-little-data-timeout");
  EXPECT_EQ(decodeError(std::vector<unsigned char>(input.begin(), input.end())),
            "frame.png: JPEG declares a 12079x12602 image (3569640 blocks of 8x8) but holds only 39 bytes of "
            "coded data; a complete one needs at least 446205 (one bit per block)");
}

TEST(ImageHardening, HeadersDeclaringHugeImagesAreRefusedBeforeAllocating) {
  // A 25-byte PGM asking for 60000 x 60000 pixels (3.6 GB).
  const std::string pgm = "P5\n# comment\n60000 60000\n255\n";
  EXPECT_EQ(decodeError(std::vector<unsigned char>(pgm.begin(), pgm.end())),
            "frame.png: header declares a 60000x60000 image; accepted are 1..16384 pixels a side");
  // A PNG whose IHDR says 20000 x 10 (its CRC no longer matches, but no decoder sees it).
  std::vector<unsigned char> png = encode(".png", cv::Mat(10, 10, CV_8UC1, cv::Scalar(1)));
  png[16] = 0;
  png[17] = 0;
  png[18] = 0x4e;
  png[19] = 0x20;
  EXPECT_EQ(decodeError(png), "frame.png: header declares a 20000x10 image; accepted are 1..16384 pixels a side");
  // A BMP with a zero width, a JPEG whose frame header says 0 rows.
  std::vector<unsigned char> bmp = encode(".bmp", cv::Mat(10, 10, CV_8UC1, cv::Scalar(1)));
  bmp[18] = bmp[19] = bmp[20] = bmp[21] = 0;
  EXPECT_NE(decodeError(bmp).find("declares a 0x10 image"), std::string::npos);
  std::vector<unsigned char> jpg = encode(".jpg", cv::Mat(10, 12, CV_8UC1, cv::Scalar(1)));
  for (std::size_t i = 2; i + 9 < jpg.size(); ++i) {
    if (jpg[i] == 0xff && jpg[i + 1] == 0xc0) {  // baseline frame header: rows at +5, columns at +7
      jpg[i + 5] = 0;
      jpg[i + 6] = 0;
      break;
    }
  }
  EXPECT_NE(decodeError(jpg).find("declares a 12x0 image"), std::string::npos);
}

// Offsets of the start-of-scan segments of a JPEG, and of its end-of-image marker.
std::vector<std::size_t> jpegScanStarts(const std::vector<unsigned char>& jpg, std::size_t& eoi) {
  std::vector<std::size_t> scans;
  eoi = 0;
  for (std::size_t i = 2; i + 1 < jpg.size(); ++i) {
    if (jpg[i] != 0xff) continue;
    if (jpg[i + 1] == 0xda) scans.push_back(i);
    if (jpg[i + 1] == 0xd9) eoi = i;
  }
  return scans;
}

cv::Mat texture(int rows, int cols) {
  cv::Mat image(rows, cols, CV_8UC3);
  cv::randu(image, cv::Scalar::all(0), cv::Scalar::all(255));
  return image;
}

TEST(ImageHardening, JpegWithMoreThan64ScansIsRefused) {
  // A progressive colour JPEG has 10 scans; repeat its last one until there are 70
  // (libjpeg warns and decodes every one over the whole image).
  const std::vector<unsigned char> jpg = [] {
    std::vector<unsigned char> bytes;
    EXPECT_TRUE(cv::imencode(".jpg", texture(64, 80), bytes, {cv::IMWRITE_JPEG_PROGRESSIVE, 1}));
    return bytes;
  }();
  std::size_t eoi = 0;
  const std::vector<std::size_t> scans = jpegScanStarts(jpg, eoi);
  ASSERT_EQ(scans.size(), 10u);
  ASSERT_GT(eoi, scans.back());
  EXPECT_EQ(decodeMono8(jpg, "frame.jpg").size(), cv::Size(80, 64));  // as written: accepted

  std::vector<unsigned char> many(jpg.begin(), jpg.begin() + static_cast<std::ptrdiff_t>(eoi));
  for (int k = 0; k < 60; ++k)
    many.insert(many.end(), jpg.begin() + static_cast<std::ptrdiff_t>(scans.back()),
                jpg.begin() + static_cast<std::ptrdiff_t>(eoi));
  many.insert(many.end(), {0xff, 0xd9});
  EXPECT_EQ(decodeError(many),
            "frame.png: JPEG has more than 64 scans (start-of-scan markers); a progressive JPEG normally has 6 to 10");
}

TEST(ImageHardening, CompleteJpegsOfUniformImagesAreAccepted) {
  // The least coded data a complete Huffman-coded JPEG can have: a uniform image,
  // optimised Huffman tables, grey (one component), baseline and progressive.
  const cv::Mat black(1504, 2000, CV_8UC1, cv::Scalar(0));
  for (const int progressive : {0, 1}) {
    std::vector<unsigned char> bytes;
    ASSERT_TRUE(cv::imencode(".jpg", black, bytes,
                             {cv::IMWRITE_JPEG_OPTIMIZE, 1, cv::IMWRITE_JPEG_PROGRESSIVE, progressive}));
    SCOPED_TRACE("progressive " + std::to_string(progressive) + ", " + std::to_string(bytes.size()) + " bytes");
    const cv::Mat decoded = decodeMono8(bytes, "black.jpg");
    EXPECT_EQ(decoded.size(), black.size());
    EXPECT_EQ(cv::countNonZero(decoded), 0);
  }
}

TEST(ImageHardening, JpegWhoseCodedDataIsCutShortIsRefused) {
  // A real image with most of its scan data removed, the end marker kept.
  std::vector<unsigned char> jpg = encode(".jpg", texture(480, 640));
  std::size_t eoi = 0;
  const std::vector<std::size_t> scans = jpegScanStarts(jpg, eoi);
  ASSERT_EQ(scans.size(), 1u);
  const std::size_t keep = scans[0] + 200;
  ASSERT_LT(keep, eoi);
  jpg.erase(jpg.begin() + static_cast<std::ptrdiff_t>(keep), jpg.begin() + static_cast<std::ptrdiff_t>(eoi));
  EXPECT_NE(decodeError(jpg).find("JPEG declares a 640x480 image (7200 blocks of 8x8) but holds only"),
            std::string::npos);
}

TEST(ImageHardening, ArithmeticCodedJpegIsRefused) {
  std::vector<unsigned char> jpg = encode(".jpg", cv::Mat(16, 16, CV_8UC1, cv::Scalar(9)));
  for (std::size_t i = 2; i + 1 < jpg.size(); ++i) {
    if (jpg[i] == 0xff && jpg[i + 1] == 0xc0) {
      jpg[i + 1] = 0xc9;  // SOF9: extended sequential, arithmetic coding
      break;
    }
  }
  EXPECT_EQ(decodeError(jpg),
            "frame.png: arithmetic-coded JPEG (frame header 0xFFC9); only Huffman-coded (baseline, extended or "
            "progressive) JPEG is accepted");
}

TEST(FuzzRegressions, PnmWhoseNumbersEndInOtherBytesIsSizedAsTheDecoderReadsIt) {
  // "P3\v\t999\x19" "999999=7960#9...": OpenCV's PxM reader ends a number at any
  // byte and consumes it, so it read 999x999999 samples of 16 bits and filled
  // 6 GB (more than 3 s under fuzz_image -timeout=3). The size check stopped at
  // the \x19 and let it through.
  const std::string input = regression("image-pnm-number-ended-by-any-byte-timeout");
  EXPECT_EQ(decodeError(std::vector<unsigned char>(input.begin(), input.end())),
            "frame.png: header declares a 999x999999 image; accepted are 1..16384 pixels a side");
}

TEST(ImageHardening, HeadersTheFileIsTooShortForAreRefusedBeforeDecoding) {
  // A PGM header asking for 4000 x 3000 binary samples, followed by 10 bytes.
  std::string pgm = "P5 4000 3000 255\n";
  const std::string header_size = std::to_string(pgm.size());
  pgm += std::string(10, '\x7f');
  EXPECT_EQ(decodeError(std::vector<unsigned char>(pgm.begin(), pgm.end())),
            "frame.png: header declares a 4000x3000 image, which needs at least " +
                std::to_string(4000 * 3000 + std::stoi(header_size)) + " bytes (as binary samples); the file has " +
                std::to_string(pgm.size()));
  // The same as text: a digit and a separator per sample, 16-bit samples twice the bytes.
  const std::string text = "P2\n4000 3000\n255\n1 2 3\n";
  EXPECT_NE(decodeError(std::vector<unsigned char>(text.begin(), text.end())).find("(as text samples)"),
            std::string::npos);
  const std::string wide = "P5 100 100 65535\n" + std::string(100 * 100, '\x01');
  EXPECT_NE(decodeError(std::vector<unsigned char>(wide.begin(), wide.end())).find("needs at least 20017 bytes"),
            std::string::npos);
  // A PNG of 8 x 8 whose header is edited to 16000 x 16000: 256 MB of rows cannot
  // come out of a 70-byte file at deflate's best ratio.
  std::vector<unsigned char> png = encode(".png", cv::Mat(8, 8, CV_8UC1, cv::Scalar(3)));
  for (const std::size_t at : {16u, 20u}) {
    png[at] = 0;
    png[at + 1] = 0;
    png[at + 2] = 0x3e;
    png[at + 3] = 0x80;
  }
  EXPECT_NE(decodeError(png).find("header declares a 16000x16000 image, which needs at least 248078 bytes (at "
                                  "1032:1, deflate's best ratio)"),
            std::string::npos);
  // A BMP whose rows are cut off, and a run-length coded one.
  std::vector<unsigned char> bmp = encode(".bmp", cv::Mat(64, 64, CV_8UC1, cv::Scalar(5)));
  const std::size_t full = bmp.size();
  bmp.resize(full - 64);
  EXPECT_NE(decodeError(bmp).find("needs at least " + std::to_string(full) + " bytes (uncompressed rows)"),
            std::string::npos);
  bmp = encode(".bmp", cv::Mat(64, 64, CV_8UC1, cv::Scalar(5)));
  bmp[30] = 1;  // BI_RLE8
  EXPECT_EQ(decodeError(bmp), "frame.png: run-length coded BMP (compression 1); only uncompressed BMP is accepted");
}

TEST(ImageHardening, ImagesAtTheBestCompressionAreAccepted) {
  // A uniform image at zlib's strongest setting comes closest to the ratio bound.
  const cv::Mat black(1500, 2000, CV_8UC1, cv::Scalar(0));
  std::vector<unsigned char> png;
  ASSERT_TRUE(cv::imencode(".png", black, png, {cv::IMWRITE_PNG_COMPRESSION, 9}));
  SCOPED_TRACE(std::to_string(png.size()) + " bytes");
  EXPECT_EQ(decodeMono8(png, "black.png").size(), black.size());
  // Every format at a size whose rows need padding, grey and colour.
  const cv::Mat grey(37, 51, CV_8UC1, cv::Scalar(7));
  const cv::Mat colour(37, 51, CV_8UC3, cv::Scalar(1, 2, 3));
  for (const auto& [ext, image] : {std::pair{".bmp", grey}, {".bmp", colour}, {".pgm", grey}, {".ppm", colour}}) {
    EXPECT_EQ(decodeMono8(encode(ext, image), std::string("frame") + ext).size(), grey.size()) << ext;
  }
}

}  // namespace
}  // namespace sg
