#include "io/image_file.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <iterator>

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
  checkComplete(path, bytes);
  cv::Mat image;
  try {
    image = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    fail(path, "cannot decode the image: " + e.msg);
  }
  if (image.empty()) fail(path, "not a readable image (corrupt, truncated or not an image file)");
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
