#include "io/image_file.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <utility>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "config/errors.hpp"

namespace sg {

namespace {

namespace fs = std::filesystem;

[[noreturn]] void fail(const std::string& path, const std::string& message) { throw InputError(path + ": " + message); }

std::string lowerExtension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

bool hasPngSignature(const std::vector<unsigned char>& bytes) {
  static constexpr std::array<unsigned char, 8> kSignature{0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  return bytes.size() >= kSignature.size() && std::equal(kSignature.begin(), kSignature.end(), bytes.begin());
}

bool hasJpegSignature(const std::vector<unsigned char>& bytes) {
  return bytes.size() >= 3 && bytes[0] == 0xff && bytes[1] == 0xd8 && bytes[2] == 0xff;
}

bool hasBmpSignature(const std::vector<unsigned char>& bytes) {
  return bytes.size() >= 2 && bytes[0] == 'B' && bytes[1] == 'M';
}

// As OpenCV's PxM decoder recognises it: "P1".."P6" and white space. Anything
// looser would let cv::imdecode try its other decoders on the file (found by
// tests/fuzz: "P41111..." with "DICM" at offset 128 went to the DICOM reader).
bool hasPnmSignature(const std::vector<unsigned char>& bytes) {
  return bytes.size() >= 3 && bytes[0] == 'P' && bytes[1] >= '1' && bytes[1] <= '6' && std::isspace(bytes[2]) != 0;
}

constexpr long long kMaxImageSide = 16384;  // the largest image a rig may describe (camera/stereo_rig.hpp)

std::uint32_t bigEndian(const std::vector<unsigned char>& b, std::size_t at, int bytes) {
  std::uint32_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | b[at + static_cast<std::size_t>(i)];
  return v;
}

std::int64_t littleEndianSigned32(const std::vector<unsigned char>& b, std::size_t at) {
  const std::uint32_t v = static_cast<std::uint32_t>(b[at]) | (static_cast<std::uint32_t>(b[at + 1]) << 8) |
                          (static_cast<std::uint32_t>(b[at + 2]) << 16) | (static_cast<std::uint32_t>(b[at + 3]) << 24);
  return static_cast<std::int32_t>(v);
}

// Width and height the header declares, read before a decoder allocates for
// them (a 40-byte PGM header can ask for gigabytes). Nothing when the header is
// too short to tell; the decoder then fails on it.
std::optional<std::pair<std::int64_t, std::int64_t>> declaredSize(const std::vector<unsigned char>& b) {
  if (hasPngSignature(b)) {
    if (b.size() < 24 || !std::equal(b.begin() + 12, b.begin() + 16, "IHDR")) return std::nullopt;
    return std::pair<std::int64_t, std::int64_t>{bigEndian(b, 16, 4), bigEndian(b, 20, 4)};
  }
  if (hasBmpSignature(b)) {
    if (b.size() < 26) return std::nullopt;
    if (littleEndianSigned32(b, 14) == 12) {  // OS/2 header: 16-bit sizes
      return std::pair<std::int64_t, std::int64_t>{b[18] | (b[19] << 8), b[20] | (b[21] << 8)};
    }
    const std::int64_t height = littleEndianSigned32(b, 22);
    return std::pair<std::int64_t, std::int64_t>{littleEndianSigned32(b, 18), height < 0 ? -height : height};
  }
  if (hasPnmSignature(b)) {
    std::int64_t values[2] = {-1, -1};
    std::size_t i = 2;
    for (std::int64_t& value : values) {
      while (i < b.size() && (std::isspace(b[i]) != 0 || b[i] == '#')) {
        if (b[i] == '#') {
          while (i < b.size() && b[i] != '\n' && b[i] != '\r') ++i;
        } else {
          ++i;
        }
      }
      std::int64_t v = 0;
      int digits = 0;
      for (; i < b.size() && std::isdigit(b[i]) != 0; ++i, ++digits) {
        if (v <= kMaxImageSide) v = v * 10 + (b[i] - '0');  // stop growing once too large
      }
      if (digits == 0) return std::nullopt;
      value = v;
    }
    return std::pair<std::int64_t, std::int64_t>{values[0], values[1]};
  }
  if (hasJpegSignature(b)) {
    std::size_t i = 2;
    while (i + 9 <= b.size() && b[i] == 0xff) {
      const unsigned marker = b[i + 1];
      if (marker == 0xff) {  // fill byte
        ++i;
        continue;
      }
      if (marker == 0x01 || (marker >= 0xd0 && marker <= 0xd9)) {  // no length field
        i += 2;
        continue;
      }
      if (marker >= 0xc0 && marker <= 0xcf && marker != 0xc4 && marker != 0xc8 && marker != 0xcc) {
        return std::pair<std::int64_t, std::int64_t>{bigEndian(b, i + 7, 2), bigEndian(b, i + 5, 2)};
      }
      i += 2 + bigEndian(b, i + 2, 2);
    }
  }
  return std::nullopt;
}

// The decoders print to stderr and (JPEG) return half-grey images on truncated
// files; check the end markers first so a truncated file is a clean error.
void checkComplete(const std::string& path, const std::vector<unsigned char>& bytes) {
  if (hasPngSignature(bytes)) {
    static constexpr std::array<unsigned char, 8> kIend{'I', 'E', 'N', 'D', 0xae, 0x42, 0x60, 0x82};
    const std::size_t window = std::min<std::size_t>(bytes.size(), 64);
    const auto tail = bytes.end() - static_cast<std::ptrdiff_t>(window);
    if (std::search(tail, bytes.end(), kIend.begin(), kIend.end()) == bytes.end()) {
      fail(path, "truncated PNG image (no IEND chunk)");
    }
  } else if (hasJpegSignature(bytes)) {
    const std::size_t window = std::min<std::size_t>(bytes.size(), 4096);
    static constexpr std::array<unsigned char, 2> kEoi{0xff, 0xd9};
    const auto tail = bytes.end() - static_cast<std::ptrdiff_t>(window);
    if (std::search(tail, bytes.end(), kEoi.begin(), kEoi.end()) == bytes.end()) {
      fail(path, "truncated JPEG image (no end-of-image marker)");
    }
  }
}

}  // namespace

bool isImageFileName(const std::string& path) {
  const std::string ext = lowerExtension(path);
  return ext == ".png" || ext == ".pgm" || ext == ".ppm" || ext == ".pnm" || ext == ".jpg" || ext == ".jpeg" ||
         ext == ".bmp";
}

std::vector<std::string> listImageFiles(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError(dir + ": directory not found");
  std::vector<std::string> files;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    if (entry.is_regular_file(ec) && isImageFileName(entry.path().string())) {
      files.push_back(entry.path().filename().string());
    }
  }
  if (ec) throw InputError(dir + ": cannot list the directory: " + ec.message());
  std::sort(files.begin(), files.end());
  return files;
}

cv::Mat readMono8(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) fail(path, "image file not found");
  if (!fs::is_regular_file(path, ec)) fail(path, "not a regular file");
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open the image file");
  const std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return decodeMono8(bytes, path);
}

cv::Mat decodeMono8(const std::vector<unsigned char>& bytes, const std::string& what) {
  const std::string& path = what;
  if (bytes.empty()) fail(path, "empty image file");
  // Only the formats the sources document go to a decoder: cv::imdecode would
  // also hand a renamed TIFF, EXR, DICOM or JPEG 2000 file to its decoder.
  if (!hasPngSignature(bytes) && !hasJpegSignature(bytes) && !hasBmpSignature(bytes) && !hasPnmSignature(bytes)) {
    fail(path, "not a PNG, JPEG, BMP or PNM image (unknown file signature)");
  }
  if (const auto size = declaredSize(bytes);
      size && (size->first < 1 || size->second < 1 || size->first > kMaxImageSide || size->second > kMaxImageSide)) {
    fail(path, "header declares a " + std::to_string(size->first) + "x" + std::to_string(size->second) +
                   " image; accepted are 1..16384 pixels a side");
  }
  checkComplete(path, bytes);
  cv::Mat image;
  try {
    image = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    fail(path, "cannot decode the image: " + e.msg);
  }
  if (image.empty()) fail(path, "not a readable image (corrupt, truncated or not an image file)");
  // The header check reads the first frame header; a JPEG with a second one decodes at that size.
  if (image.cols > kMaxImageSide || image.rows > kMaxImageSide) {
    fail(path, "decodes to a " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                   " image; accepted are 1..16384 pixels a side");
  }
  if (image.depth() != CV_8U) {
    fail(path, "image has " + std::to_string(8 * image.elemSize1()) +
                   "-bit samples; only 8-bit images are accepted (convert it first)");
  }
  switch (image.channels()) {
    case 1:
      return image;
    case 3: {
      cv::Mat grey;
      cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
      return grey;
    }
    case 4: {
      cv::Mat grey;
      cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
      return grey;
    }
    default:
      fail(path, "image has " + std::to_string(image.channels()) + " channels, expected 1, 3 or 4");
  }
}

}  // namespace sg
