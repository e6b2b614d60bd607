#include "io/frame_source.hpp"

#include "config/errors.hpp"
#include "io/kitti_source.hpp"
#include "io/pairs_source.hpp"
#include "io/synthetic_source.hpp"

namespace sg {

namespace {

std::string kindOf(const std::string& spec) { return spec.substr(0, spec.find(':')); }

}  // namespace

bool isRos2SourceSpec(const std::string& spec) { return spec.rfind("ros2:", 0) == 0; }

void checkFrameSourceKind(const std::string& spec) {
  const std::string kind = kindOf(spec);
  if (kind == "synthetic" || kind == "pairs" || kind == "kitti" || kind == "ros2") return;
  throw InputError("frame source '" + spec + "': unknown kind '" + kind + "' (expected " + kFrameSourceKinds + ")");
}

std::unique_ptr<FrameSource> openFrameSource(const std::string& spec, const std::string& calib_path) {
  if (spec == "synthetic" || spec.rfind("synthetic:", 0) == 0) {
    return std::make_unique<SyntheticSource>(parseSyntheticSeed(spec), calib_path);
  }
  checkFrameSourceKind(spec);
  const std::string kind = kindOf(spec);
  if (kind == "ros2") {
    if (!isRos2SourceSpec(spec)) throw InputError("frame source '" + spec + "': expected " + kRos2SourceForm);
    throw InputError("frame source '" + spec +
                     "': ROS 2 topics are read by the acquisition stage only (stereoguard run, "
                     "stereoguard-acquisition); this command reads synthetic[:SEED], pairs:DIR or kitti:DIR");
  }
  const auto colon = spec.find(':');
  const std::string dir = colon == std::string::npos ? "" : spec.substr(colon + 1);
  if (dir.empty()) throw InputError("frame source '" + spec + "': missing directory (" + kind + ":DIR)");
  if (kind == "pairs") return std::make_unique<PairsSource>(dir, calib_path);
  return std::make_unique<KittiSource>(dir, calib_path);
}

}  // namespace sg
