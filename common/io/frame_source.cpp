#include "io/frame_source.hpp"

#include "config/errors.hpp"

namespace sg {

std::unique_ptr<FrameSource> openFrameSource(const std::string& spec, const std::string& /*calib_path*/) {
  throw InputError("frame source '" + spec + "': not available yet");
}

}  // namespace sg
