// Writes the generated part of the seed corpus (tests/fuzz/corpus/): images in
// every accepted and rejected format, OpenCV calibration files written by
// cv::FileStorage, ROS camera_info pairs, and serialized DDS samples of every
// type. Run once after a format changes:
//   make_fuzz_seeds tests/fuzz/corpus
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "dds/conversions.hpp"
#include "dds/stage_metrics.hpp"
#include "dds_cdr.hpp"

namespace fs = std::filesystem;

namespace {

void writeBytes(const fs::path& path, const std::vector<std::uint8_t>& bytes) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()),
                                              static_cast<std::streamsize>(bytes.size()));
}

void writeText(const fs::path& path, const std::string& prefix, const std::string& text) {
  std::vector<std::uint8_t> bytes(prefix.begin(), prefix.end());
  bytes.insert(bytes.end(), text.begin(), text.end());
  writeBytes(path, bytes);
}

std::string readText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void images(const fs::path& dir) {
  cv::Mat grey(24, 32, CV_8UC1);
  cv::randu(grey, 0, 256);
  cv::Mat colour(24, 32, CV_8UC3);
  cv::randu(colour, 0, 256);
  cv::Mat deep(24, 32, CV_16UC1);
  cv::randu(deep, 0, 65536);
  const struct {
    const char* name;
    const char* ext;
    cv::Mat image;
  } kImages[] = {{"grey.png", ".png", grey},   {"colour.png", ".png", colour}, {"deep16.png", ".png", deep},
                 {"grey.pgm", ".pgm", grey},   {"colour.ppm", ".ppm", colour}, {"grey.jpg", ".jpg", grey},
                 {"colour.jpg", ".jpg", colour}, {"grey.bmp", ".bmp", grey},   {"deep16.pgm", ".pgm", deep}};
  for (const auto& item : kImages) {
    std::vector<std::uint8_t> bytes;
    cv::imencode(item.ext, item.image, bytes);
    writeBytes(dir / item.name, bytes);
    if (std::string(item.ext) == ".png") {
      bytes.resize(bytes.size() / 2);
      writeBytes(dir / (std::string("truncated_") + item.name), bytes);
    }
  }
}

// A raw stereo pair: two cameras 0.3 m apart, slight rotation and distortion.
void opencvCalibrations(const fs::path& dir) {
  const cv::Mat m1 = (cv::Mat_<double>(3, 3) << 500, 0, 320, 0, 500, 240, 0, 0, 1);
  const cv::Mat m2 = (cv::Mat_<double>(3, 3) << 505, 0, 318, 0, 505, 242, 0, 0, 1);
  const cv::Mat d1 = (cv::Mat_<double>(1, 5) << -0.1, 0.01, 0, 0, 0);
  const cv::Mat d2 = (cv::Mat_<double>(1, 5) << -0.12, 0.02, 0.001, 0, 0);
  cv::Mat r;
  cv::Rodrigues(cv::Vec3d(0.01, -0.02, 0.005), r);
  const cv::Mat t = (cv::Mat_<double>(3, 1) << -0.3, 0.002, 0.001);
  const cv::Size size(640, 480);
  cv::Mat r1, r2, p1, p2, q;
  cv::stereoRectify(m1, d1, m2, d2, size, r, t, r1, r2, p1, p2, q, cv::CALIB_ZERO_DISPARITY, 0.0, size);
  for (const char* ext : {".yaml", ".xml"}) {
    for (const bool rectified : {false, true}) {
      const std::string name = std::string("raw") + (rectified ? "_rectified" : "") + ext;
      const fs::path tmp = fs::temp_directory_path() / ("sg_seed" + std::string(ext));
      {
        cv::FileStorage fs_out(tmp.string(), cv::FileStorage::WRITE);
        fs_out << "image_width" << size.width << "image_height" << size.height;
        fs_out << "M1" << m1 << "D1" << d1 << "M2" << m2 << "D2" << d2 << "R" << r << "T" << t;
        if (rectified) fs_out << "R1" << r1 << "R2" << r2 << "P1" << p1 << "P2" << p2;
        fs_out << "camera_height_m" << 1.6;
      }
      // Byte 0 of a seed selects the file name: 0 = .yaml, 1 = .xml (fuzz_calib_opencv.cpp).
      writeText(dir / name, std::string(1, std::string(ext) == ".xml" ? '\x01' : '\x00'), readText(tmp));
      fs::remove(tmp);
    }
  }
  writeText(dir / "plain_projections.yaml", std::string(1, '\x00'),
            "P1: [721.5, 0, 609.6, 0, 0, 721.5, 172.9, 0, 0, 0, 1, 0]\n"
            "P2: [721.5, 0, 609.6, -389.6, 0, 721.5, 172.9, 0, 0, 0, 1, 0]\n"
            "image_width: 1242\nimage_height: 375\ncamera_height_m: 1.65\ncamera_pitch_rad: 0.01\n");
  writeText(dir / "plain_raw_sized.yaml", std::string(1, '\xa3'),
            "M1: {rows: 3, cols: 3, data: [60, 0, 32, 0, 60, 24, 0, 0, 1]}\n"
            "D1: [0.01, 0, 0, 0, 0]\n"
            "M2: {rows: 3, cols: 3, data: [60, 0, 31, 0, 60, 24, 0, 0, 1]}\n"
            "D2: []\nR: [0, 0.01, 0]\nT: [-0.2, 0, 0]\n");
}

void rosCalibrations(const fs::path& dir) {
  const auto info = [](double tx, double k1) {
    return "image_width: 64\nimage_height: 48\ncamera_name: cam\n"
           "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [60, 0, 32, 0, 60, 24, 0, 0, 1]\n"
           "distortion_model: plumb_bob\n"
           "distortion_coefficients:\n  rows: 1\n  cols: 5\n  data: [" +
           std::to_string(k1) +
           ", 0, 0, 0, 0]\n"
           "rectification_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n"
           "projection_matrix:\n  rows: 3\n  cols: 4\n  data: [60, 0, 32, " +
           std::to_string(tx) + ", 0, 60, 24, 0, 0, 0, 1, 0]\n";
  };
  writeText(dir / "pair_rectified", std::string(1, '\x00'), info(0, 0) + "\n#right\n" + info(-12, 0));
  writeText(dir / "pair_distorted_sized", std::string(1, '\xb3'), info(0, 0.05) + "\n#right\n" + info(-12, -0.02));
}

template <class T>
void writeSample(const fs::path& path, std::uint8_t type, const T& sample, const dds_topic_descriptor_t& desc) {
  std::vector<std::uint8_t> bytes{type, 0};
  const auto cdr = sg::fuzz::toCdr(&sample, desc);
  bytes.insert(bytes.end(), cdr.begin(), cdr.end());
  writeBytes(path, bytes);
}

void ddsSamples(const fs::path& dir) {
  using namespace sg;
  dds::FrameInfo info;
  info.frame_id = 7;
  info.capture_time_ns = 1700000000000000000;
  info.source = "000007";
  info.sample_seq = 7;
  StereoRig rig;
  rig.focal_px = 60;
  rig.cx_px = 16;
  rig.cy_px = 12;
  rig.baseline_m = 0.5;
  rig.width = 32;
  rig.height = 24;
  rig.mounting = Mounting{1.5, 0.02};
  cv::Mat left(24, 32, CV_8UC1);
  cv::randu(left, 0, 256);
  cv::Mat right = left.clone();

  dds::StereoFrameData stereo{info, rig, left, right};
  sg_idl_StereoFrame stereo_msg{};
  dds::fillStereoFrame(stereo, stereo_msg);
  writeSample(dir / "stereo_frame", 0, stereo_msg, sg_idl_StereoFrame_desc);

  dds::FeatureFrameData features{info, rig, left, right, left, right};
  sg_idl_FeatureFrame feature_msg{};
  dds::fillFeatureFrame(features, feature_msg);
  writeSample(dir / "feature_frame", 1, feature_msg, sg_idl_FeatureFrame_desc);

  dds::SegmentationData seg;
  seg.info = info;
  seg.rig = rig;
  seg.result.ground.offset_per_row.assign(24, std::numeric_limits<float>::quiet_NaN());
  for (int row = 12; row < 24; ++row) seg.result.ground.offset_per_row[static_cast<std::size_t>(row)] = 0.5f * (row - 12);
  seg.result.ground.horizon_row = 12;
  seg.result.ground.background_offset = 1.0f;
  seg.result.ground.vertices = {{0.0f, 12.0f}, {6.0f, 24.0f}};
  ObstacleCluster o;
  o.label = kLabelFirstObstacle;
  o.offset_px = 5;
  o.min_offset_px = 4;
  o.max_offset_px = 6;
  o.box = cv::Rect(10, 4, 6, 14);
  o.feature_count = 40;
  seg.result.obstacles.push_back(o);
  seg.result.labels = cv::Mat(24, 32, CV_8UC1, cv::Scalar(0));
  seg.result.labels(o.box).setTo(o.label);
  seg.result.timing_ms = {{"features", 0.2}, {"total", 1.5}};
  dds::SegmentationEncoder seg_encoder;
  sg_idl_Segmentation seg_msg{};
  seg_encoder.fill(seg, seg_msg);
  writeSample(dir / "segmentation", 2, seg_msg, sg_idl_Segmentation_desc);

  dds::DetectionsData det;
  det.info = info;
  det.width = 32;
  det.height = 24;
  HumanDetection h;
  h.box = cv::Rect2f(10, 4, 6, 14);
  h.score = 0.8f;
  h.offset_px = 5;
  h.distance_m = 6;
  h.distance_sigma_m = 0.3f;
  h.position_m = Eigen::Vector3f(-0.5f, 0.2f, 6.0f);
  h.ground_contact_row = 18;
  h.cluster_label = o.label;
  h.track_id = 3;
  h.confirmed = true;
  det.detections = {h, h};
  det.timing_ms = {{"localization", 0.4}};
  dds::DetectionsEncoder det_encoder;
  sg_idl_HumanDetections det_msg{};
  det_encoder.fill(det, det_msg);
  writeSample(dir / "human_detections", 3, det_msg, sg_idl_HumanDetections_desc);

  dds::StageStats stats("features");
  stats.received(5);
  stats.published(12.0);
  stats.dropped(dds::kDropSuperseded, 2);
  stats.dropped(dds::kDropMalformed, 1);
  sg_idl_StageMetrics metrics_msg{};
  stats.fillMetrics(metrics_msg, true);
  writeSample(dir / "stage_metrics", 4, metrics_msg, sg_idl_StageMetrics_desc);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_fuzz_seeds CORPUS_DIR\n");
    return 2;
  }
  const fs::path corpus = argv[1];
  images(corpus / "image");
  opencvCalibrations(corpus / "calib_opencv");
  rosCalibrations(corpus / "calib_ros");
  ddsSamples(corpus / "dds_samples");
  std::printf("seeds written under %s\n", corpus.c_str());
  return 0;
}
