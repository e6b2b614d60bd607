#pragma once
// The crew display page (services/display/assets/*), compiled into the binary
// by embed_assets.cmake: the display needs no files and no network at run time.
#include <cstddef>
#include <string_view>

namespace sg::display_assets {

struct Asset {
  std::string_view path;          // URL path, e.g. "/index.html"
  std::string_view content_type;  // e.g. "text/html; charset=utf-8"
  const unsigned char* data;
  std::size_t size;
};

// The asset served at `path`, or nullptr.
const Asset* find(std::string_view path);

}  // namespace sg::display_assets
