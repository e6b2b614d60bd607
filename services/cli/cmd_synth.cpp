// stereoguard synth: exports synthetic scenes (seeds S..S+N-1) in the KITTI
// layout, with label_2/ and disparity ground truth (disp_2/).
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "config/errors.hpp"
#include "io/kitti_format.hpp"
#include "io/synthetic_scene.hpp"

namespace sg::cli {

namespace {

struct SynthOptions {
  std::string out;
  int frames = 1;
  std::uint64_t seed = 0;
  int width = 1242;
  int height = 375;
};

void runSynth(const SynthOptions& o) {
  if (o.frames < 1 || o.frames > 1000000) throw InputError("--frames " + std::to_string(o.frames) + " must be within 1..1000000");
  if (o.width < 16 || o.width > 8192) throw InputError("--width " + std::to_string(o.width) + " must be within 16..8192");
  if (o.height < 16 || o.height > 8192) throw InputError("--height " + std::to_string(o.height) + " must be within 16..8192");
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (ec || !fs::is_directory(o.out)) throw InputError("--out '" + o.out + "': cannot create the folder");
  double camera_height = 0.0;
  for (int i = 0; i < o.frames; ++i) {
    const std::uint64_t seed = o.seed + static_cast<std::uint64_t>(i);
    const SyntheticSceneParams params = randomSceneParams(seed, o.width, o.height);
    const StereoPair pair = renderSyntheticScene(params, seed);
    writeKittiFrame(o.out, pair);
    camera_height = params.camera_height_m;
    std::cerr << "synth: frame " << (i + 1) << "/" << o.frames << " " << pair.id << " (" << pair.labels.size()
              << " objects)\n";
  }
  const fs::path height_file = fs::path(o.out) / "camera_height_m";
  std::ofstream h(height_file);
  h << camera_height << "\n";
  if (!h) throw InputError("cannot write '" + height_file.string() + "'");
}

}  // namespace

void addSynthCommand(CLI::App& app) {
  auto opts = std::make_shared<SynthOptions>();
  auto* cmd = app.add_subcommand("synth", "export synthetic scenes with ground truth in the KITTI layout");
  cmd->add_option("--out", opts->out, "output folder (image_2, image_3, calib, label_2, disp_2, camera_height_m)")
      ->required();
  cmd->add_option("--frames", opts->frames, "number of frames (seeds SEED..SEED+N-1)")->capture_default_str();
  cmd->add_option("--seed", opts->seed, "first seed")->capture_default_str();
  cmd->add_option("--width", opts->width, "image width (pixels); the focal length scales with it")->capture_default_str();
  cmd->add_option("--height", opts->height, "image height (pixels)")->capture_default_str();
  cmd->callback([opts] { runSynth(*opts); });
}

}  // namespace sg::cli
