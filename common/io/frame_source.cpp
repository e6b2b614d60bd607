#include "io/frame_source.hpp"

#include "config/errors.hpp"
#include "io/kitti_source.hpp"
#include "io/pairs_source.hpp"
#include "io/synthetic_source.hpp"

namespace sg {

std::unique_ptr<FrameSource> openFrameSource(const std::string& spec, const std::string& calib_path) {
  if (spec == "synthetic" || spec.rfind("synthetic:", 0) == 0) {
    return std::make_unique<SyntheticSource>(parseSyntheticSeed(spec), calib_path);
  }
  const auto colon = spec.find(':');
  const std::string kind = colon == std::string::npos ? spec : spec.substr(0, colon);
  const std::string dir = colon == std::string::npos ? "" : spec.substr(colon + 1);
  if (kind == "pairs" || kind == "kitti") {
    if (dir.empty()) throw InputError("frame source '" + spec + "': missing directory (" + kind + ":DIR)");
    if (kind == "pairs") return std::make_unique<PairsSource>(dir, calib_path);
    return std::make_unique<KittiSource>(dir, calib_path);
  }
  throw InputError("frame source '" + spec + "': unknown kind '" + kind +
                   "' (expected synthetic[:SEED], pairs:DIR or kitti:DIR)");
}

}  // namespace sg
