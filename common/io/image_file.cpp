#include "io/image_file.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <optional>
#include <string>
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

// What a header declares, read before a decoder allocates for it (a 40-byte
// PGM header can ask for gigabytes): the size, and the least number of file
// bytes a complete image of that size needs. A decoder allocates the whole
// image from the header and only then finds the data missing, so a header
// the file is far too short for is refused here. Nothing when the header is
// too short to tell; the decoder then fails on it. JPEG: checkJpegLayout.
struct DeclaredLayout {
  std::int64_t width = 0, height = 0;
  std::int64_t min_bytes = 0;  // 0: not bounded here
  std::string bound;           // how min_bytes was found, for the message
};

std::int64_t littleEndian16(const std::vector<unsigned char>& b, std::size_t at) { return b[at] | (b[at + 1] << 8); }

bool validSize(std::int64_t width, std::int64_t height) {
  return width >= 1 && height >= 1 && width <= kMaxImageSide && height <= kMaxImageSide;
}

// PNG: the pixel data is deflate-compressed, whose best case codes a 258-byte
// match in 2 bits, so the file holds at least 1/1032 of the filtered rows.
std::optional<DeclaredLayout> pngLayout(const std::vector<unsigned char>& b) {
  if (b.size() < 26 || !std::equal(b.begin() + 12, b.begin() + 16, "IHDR")) return std::nullopt;
  DeclaredLayout layout{bigEndian(b, 16, 4), bigEndian(b, 20, 4), 0, ""};
  const int bit_depth = b[24];
  static constexpr std::array<int, 7> kChannels{1, 0, 3, 1, 2, 0, 4};  // by colour type
  const int channels = b[25] < kChannels.size() ? kChannels[b[25]] : 0;
  if (validSize(layout.width, layout.height) && channels > 0 && bit_depth >= 1 && bit_depth <= 16) {
    const std::int64_t row_bytes = 1 + (layout.width * channels * bit_depth + 7) / 8;
    layout.min_bytes = (layout.height * row_bytes + 1031) / 1032;
    layout.bound = "at 1032:1, deflate's best ratio";
  }
  return layout;
}

// BMP: uncompressed rows (padded to 4 bytes) from the data offset on. Run-length
// coded BMPs are refused: two bytes can end the image, so their data bounds
// nothing, and cameras do not write them.
std::optional<DeclaredLayout> bmpLayout(const std::string& path, const std::vector<unsigned char>& b) {
  if (b.size() < 30) return std::nullopt;
  const std::int64_t header = littleEndianSigned32(b, 14);
  DeclaredLayout layout;
  std::int64_t bits = 0, compression = 0;
  if (header == 12) {  // OS/2 header: 16-bit sizes
    layout.width = littleEndian16(b, 18);
    layout.height = littleEndian16(b, 20);
    bits = littleEndian16(b, 24);
  } else {
    if (b.size() < 34) return std::nullopt;
    layout.width = littleEndianSigned32(b, 18);
    const std::int64_t height = littleEndianSigned32(b, 22);
    layout.height = height < 0 ? -height : height;
    bits = littleEndian16(b, 28);
    compression = littleEndianSigned32(b, 30);
  }
  if (compression == 1 || compression == 2) {
    fail(path, "run-length coded BMP (compression " + std::to_string(compression) +
                   "); only uncompressed BMP is accepted");
  }
  if (validSize(layout.width, layout.height) && header > 0 && bits >= 1 && bits <= 32) {
    const std::int64_t stride = (layout.width * bits + 31) / 32 * 4;
    const std::int64_t data_offset = littleEndianSigned32(b, 10) & 0xffffffffLL;  // after headers and palette
    layout.min_bytes = data_offset + stride * layout.height;
    layout.bound = "uncompressed rows";
  }
  return layout;
}

// PNM, walked as OpenCV's PxM decoder reads it: before a number white space
// and comments ('#' to the end of the line), after it one byte of any kind
// (consumed). Binary data (P4-P6) is raw bytes; text data (P1 one character
// a pixel, P2/P3 a digit and a separator a sample) at least as many.
std::optional<DeclaredLayout> pnmLayout(const std::vector<unsigned char>& b) {
  std::size_t i = 2;
  const auto readNumber = [&]() -> std::optional<std::int64_t> {
    while (i < b.size() && std::isdigit(b[i]) == 0) {
      if (b[i] == '#') {
        while (i < b.size() && b[i] != '\n' && b[i] != '\r') ++i;
        ++i;
      } else if (std::isspace(b[i]) != 0) {
        ++i;
      } else {
        return std::nullopt;  // the decoder refuses it
      }
    }
    if (i >= b.size()) return std::nullopt;
    std::int64_t v = 0;
    for (; i < b.size() && std::isdigit(b[i]) != 0; ++i) {
      if (v <= std::numeric_limits<std::int32_t>::max()) v = v * 10 + (b[i] - '0');  // stop growing once too large
    }
    ++i;  // the byte that ended the number
    return v;
  };
  const auto width = readNumber();
  const auto height = width ? readNumber() : std::nullopt;
  if (!height) return std::nullopt;
  DeclaredLayout layout{*width, *height, 0, ""};
  const char kind = static_cast<char>(b[1]);
  const int channels = kind == '3' || kind == '6' ? 3 : 1;
  std::int64_t sample_bytes = 1;
  if (kind != '1' && kind != '4') {
    const auto maxval = readNumber();
    if (!maxval) return layout;
    if (*maxval > 255) sample_bytes = 2;
  }
  if (!validSize(layout.width, layout.height)) return layout;
  const std::int64_t header = static_cast<std::int64_t>(std::min(i, b.size()));
  const std::int64_t samples = layout.width * layout.height * channels;
  switch (kind) {
    case '1': layout.min_bytes = header + samples; break;
    case '4': layout.min_bytes = header + (layout.width + 7) / 8 * layout.height; break;
    case '2':
    case '3': layout.min_bytes = header + 2 * samples - 1; break;
    default: layout.min_bytes = header + samples * sample_bytes; break;
  }
  layout.bound = kind <= '3' ? "as text samples" : "as binary samples";
  return layout;
}

std::optional<DeclaredLayout> declaredLayout(const std::string& path, const std::vector<unsigned char>& b) {
  if (hasPngSignature(b)) return pngLayout(b);
  if (hasBmpSignature(b)) return bmpLayout(path, b);
  if (hasPnmSignature(b)) return pnmLayout(b);
  return std::nullopt;
}

// JPEG: the decoder's work is not bounded by the file size. libjpeg decodes
// every scan over the whole image and, when the entropy-coded data ends early,
// goes on with zeros (a warning OpenCV cannot turn into an error), so a few
// hundred bytes can declare a 12079x12602 colour image (tests/fuzz: 3.4 s) or a
// progressive one with dozens of scans over it (> 10 s). Walked here over the
// marker segments as libjpeg walks them (segments skipped by their length,
// bytes between markers passed over, as libjpeg does with a warning), before
// any decoding:
//  - every frame header: 1..16384 pixels a side, 1..4 components with sampling
//    factors 1..4;
//  - arithmetic coding (SOF9..SOF15) is refused: the bound below needs Huffman
//    codes, and cameras do not write it;
//  - at most kMaxJpegScans scans. The standard progressive scripts have 6
//    (grey) and 10 (colour) scans; each scan costs a pass over its blocks;
//  - enough entropy-coded data for the declared size: Huffman coding spends at
//    least one bit on the DC coefficient of every 8x8 block of every component
//    (a code is at least one bit long), so a complete image has at least
//    blocks / 8 bytes of it. Less means the decoder would invent the rest.
constexpr int kMaxJpegScans = 64;

struct JpegFrame {
  std::int64_t width = 0, height = 0;
  std::int64_t blocks = 0;  // 8x8 blocks over all components
  bool arithmetic = false;
  unsigned marker = 0;
};

std::string hexMarker(unsigned marker) {
  static const char* const kDigits = "0123456789ABCDEF";
  return std::string("0xFF") + kDigits[(marker >> 4) & 0xf] + kDigits[marker & 0xf];
}

JpegFrame readJpegFrame(const std::string& path, const std::vector<unsigned char>& b, std::size_t at,
                        std::size_t length, unsigned marker) {
  // at: the first byte after the length field; length counts itself.
  if (length < 8) fail(path, "JPEG frame header (" + hexMarker(marker) + ") is too short");
  JpegFrame f;
  f.marker = marker;
  f.height = bigEndian(b, at + 1, 2);
  f.width = bigEndian(b, at + 3, 2);
  f.arithmetic = marker >= 0xc9;
  if (f.width < 1 || f.height < 1 || f.width > kMaxImageSide || f.height > kMaxImageSide) {
    fail(path, "header declares a " + std::to_string(f.width) + "x" + std::to_string(f.height) +
                   " image; accepted are 1..16384 pixels a side");
  }
  const std::size_t components = b[at + 5];
  if (components < 1 || components > 4 || length < 8 + 3 * components) {
    fail(path, "JPEG frame header declares " + std::to_string(components) + " components; accepted are 1..4");
  }
  std::int64_t h_max = 1, v_max = 1;
  for (std::size_t c = 0; c < components; ++c) {
    const unsigned sampling = b[at + 7 + 3 * c];
    const std::int64_t h = sampling >> 4, v = sampling & 0xf;
    if (h < 1 || h > 4 || v < 1 || v > 4) {
      fail(path, "JPEG component " + std::to_string(c + 1) + " has sampling factors " + std::to_string(h) + "x" +
                     std::to_string(v) + "; accepted are 1..4");
    }
    h_max = std::max(h_max, h);
    v_max = std::max(v_max, v);
  }
  for (std::size_t c = 0; c < components; ++c) {
    const unsigned sampling = b[at + 7 + 3 * c];
    const std::int64_t cols = (f.width * (sampling >> 4) + h_max - 1) / h_max;
    const std::int64_t rows = (f.height * (sampling & 0xf) + v_max - 1) / v_max;
    f.blocks += ((cols + 7) / 8) * ((rows + 7) / 8);
  }
  return f;
}

void checkJpegLayout(const std::string& path, const std::vector<unsigned char>& b) {
  std::optional<JpegFrame> largest;
  int scans = 0;
  std::int64_t entropy_bytes = 0;  // bytes outside marker segments after the first scan header
  std::size_t i = 2;
  const std::size_t n = b.size();
  while (i < n) {
    if (b[i] != 0xff) {  // entropy-coded data, or bytes libjpeg skips with a warning
      if (scans > 0) ++entropy_bytes;
      ++i;
      continue;
    }
    std::size_t j = i + 1;
    while (j < n && b[j] == 0xff) ++j;  // fill bytes
    if (j >= n) break;
    const unsigned marker = b[j];
    if (marker == 0x00 || (marker >= 0xd0 && marker <= 0xd7) || marker == 0x01 || marker == 0xd8) {
      if (marker == 0x00 && scans > 0) ++entropy_bytes;  // stuffed 0xFF data byte
      i = j + 1;
      continue;
    }
    if (marker == 0xd9) break;  // end of image: libjpeg reads no further
    if (j + 2 >= n) break;      // truncated; the decoder fails on it
    const std::size_t length = bigEndian(b, j + 1, 2);
    if (length < 2) fail(path, "JPEG segment " + hexMarker(marker) + " has a length below 2");
    if (j + 1 + length > n) break;  // runs past the end; the decoder fails on it
    const bool frame_header = marker >= 0xc0 && marker <= 0xcf && marker != 0xc4 && marker != 0xc8 && marker != 0xcc;
    if (frame_header) {
      const JpegFrame frame = readJpegFrame(path, b, j + 3, length, marker);
      if (frame.arithmetic) {
        fail(path, "arithmetic-coded JPEG (frame header " + hexMarker(marker) +
                       "); only Huffman-coded (baseline, extended or progressive) JPEG is accepted");
      }
      if (!largest || frame.blocks > largest->blocks) largest = frame;
    } else if (marker == 0xda) {
      if (++scans > kMaxJpegScans) {
        fail(path, "JPEG has more than " + std::to_string(kMaxJpegScans) +
                       " scans (start-of-scan markers); a progressive JPEG normally has 6 to 10");
      }
    }
    i = j + 1 + length;
  }
  if (largest && scans > 0 && entropy_bytes * 8 < largest->blocks) {
    fail(path, "JPEG declares a " + std::to_string(largest->width) + "x" + std::to_string(largest->height) +
                   " image (" + std::to_string(largest->blocks) + " blocks of 8x8) but holds only " +
                   std::to_string(entropy_bytes) + " bytes of coded data; a complete one needs at least " +
                   std::to_string((largest->blocks + 7) / 8) + " (one bit per block)");
  }
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
  if (const auto layout = declaredLayout(path, bytes)) {
    const std::string size = std::to_string(layout->width) + "x" + std::to_string(layout->height);
    if (!validSize(layout->width, layout->height)) {
      fail(path, "header declares a " + size + " image; accepted are 1..16384 pixels a side");
    }
    if (static_cast<std::int64_t>(bytes.size()) < layout->min_bytes) {
      fail(path, "header declares a " + size + " image, which needs at least " + std::to_string(layout->min_bytes) +
                     " bytes (" + layout->bound + "); the file has " + std::to_string(bytes.size()));
    }
  }
  checkComplete(path, bytes);
  if (hasJpegSignature(bytes)) checkJpegLayout(path, bytes);
  cv::Mat image;
  try {
    image = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    fail(path, "cannot decode the image: " + e.msg);
  }
  if (image.empty()) fail(path, "not a readable image (corrupt, truncated or not an image file)");
  // The header check reads the first frame header; a JPEG with a second one decodes at that size.
  if (!validSize(image.cols, image.rows)) {
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
