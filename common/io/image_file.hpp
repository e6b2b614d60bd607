#pragma once
// Reading stereo images from files as mono8, with errors that name the file.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace sg {

// Reads an 8-bit image (png, pgm, ppm, jpg, bmp) and converts colour to grey.
// Throws InputError naming the file when it is missing, empty, truncated (PNG
// without its IEND chunk, JPEG without its end marker), not decodable, or not
// 8-bit: 16-bit images are rejected rather than scaled, because no scale is
// right for every sensor and a silent guess would change every feature threshold.
// Refused before decoding: other formats renamed, headers over 16384 pixels a
// side, headers declaring more pixels than the file can hold (PNM and BMP
// samples, PNG rows at deflate's best ratio), run-length coded BMP, and JPEGs
// whose decoding the file size does not bound (arithmetic coding, more than 64
// scans, less coded data than one bit per 8x8 block).
cv::Mat readMono8(const std::string& path);

// The same checks and conversion on the bytes of an image file already in
// memory; `what` names it in messages (a path, a topic, a field).
cv::Mat decodeMono8(const std::vector<unsigned char>& bytes, const std::string& what);

// True for the image file extensions the sources accept (case-insensitive):
// .png .pgm .ppm .pnm .jpg .jpeg .bmp.
bool isImageFileName(const std::string& path);

// The image files directly inside `dir`, sorted by name. Throws InputError when
// `dir` is not a directory.
std::vector<std::string> listImageFiles(const std::string& dir);

}  // namespace sg
