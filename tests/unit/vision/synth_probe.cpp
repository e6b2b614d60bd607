// Diagnostic: per-seed statistics of the segmentation on synthetic scenes (not a test).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <yaml-cpp/yaml.h>

#include "config/yaml_params.hpp"
#include "io/synthetic_scene.hpp"
#include "test_helpers.hpp"
#include "vision/segmenter.hpp"
#include "vision/visualize.hpp"

using namespace sg;

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::atoi(argv[1]) : 10;
  const int w = argc > 2 ? std::atoi(argv[2]) : 1242;
  const int h = argc > 3 ? std::atoi(argv[3]) : 375;
  int found = 0, wanted = 0, spurious = 0;
  // Per terrain profile (flat, uphill, downhill, slope change) and ground texture (textured,
  // weak): scenes, scenes with at least 90 % of their ground rows within +-1, the mean share,
  // and the scenes whose ground is the measured line.
  struct GroundTally {
    int scenes = 0, within = 0, measured = 0;
    double share = 0.0;
  };
  GroundTally ground_tally[4][2] = {};
  const int first = std::getenv("FIRST") ? std::atoi(std::getenv("FIRST")) : 1;
  for (int seed = first; seed < first + n; ++seed) {
    const auto t0 = std::chrono::steady_clock::now();
    SyntheticSceneParams sp = randomSceneParams(static_cast<std::uint64_t>(seed), w, h);
    if (const char* g = std::getenv("GAIN"); g && *g) sp.right_gain = std::atof(g);  // GAIN=1: cameras of equal gain
    const StereoPair pair = renderSyntheticScene(sp, static_cast<std::uint64_t>(seed));
    const auto t1 = std::chrono::steady_clock::now();
    FeatureExtractor fx;
    SegmenterParams sgp;
    // SG_PROBE_YAML='{ground: {...}, obstacles: {...}}': any segmentation parameter.
    if (const char* yaml = std::getenv("SG_PROBE_YAML")) loadParams(YAML::Load(yaml), sgp, "SG_PROBE_YAML");
    if (const char* v = std::getenv("PEAK")) sgp.obstacles.min_peak_matches = std::atoi(v);
    if (const char* v = std::getenv("FEAT")) sgp.obstacles.min_cluster_features = std::atoi(v);
    if (const char* v = std::getenv("FRAC")) sgp.obstacles.min_match_fraction = std::atof(v);
    if (const char* v = std::getenv("EXCESS")) sgp.obstacles.min_row_excess = std::atoi(v);
    if (const char* v = std::getenv("SUPPORT")) sgp.obstacles.min_support_fraction = std::atof(v);
    if (const char* v = std::getenv("ITER")) sgp.obstacles.max_iterations = std::atoi(v);
    if (const char* v = std::getenv("MAXOBS")) sgp.obstacles.max_obstacles = std::atoi(v);
    if (const char* v = std::getenv("WPEAK")) sgp.obstacles.weak_peak_matches = std::atoi(v);
    if (const char* v = std::getenv("WFEAT")) sgp.obstacles.weak_cluster_features = std::atoi(v);
    if (const char* v = std::getenv("CELL")) sgp.obstacles.cell_px = std::atoi(v);
    if (const char* v = std::getenv("REACH")) sgp.obstacles.cell_reach = std::atoi(v);
    if (const char* v = std::getenv("CELLMIN")) sgp.obstacles.min_cell_matches = std::atoi(v);
    if (const char* v = std::getenv("GBAND")) sgp.ground.profile_band_rows = std::atoi(v);
    if (const char* v = std::getenv("GAP")) sgp.obstacles.gap_px = std::atoi(v);
    if (const char* v = std::getenv("EXTENT")) sgp.obstacles.extent_fraction = std::atof(v);
    if (const char* v = std::getenv("UNGROWN")) sgp.obstacles.ungrown_retry = std::atoi(v) != 0;
    if (const char* v = std::getenv("PLAIN")) sgp.obstacles.join_plain_faces = std::atoi(v) != 0;
    if (const char* v = std::getenv("TRIM")) sgp.obstacles.trim_occluded_left = std::atoi(v) != 0;
    if (const char* v = std::getenv("RANGE")) sgp.obstacles.max_range_m = std::atof(v);
    Segmenter seg(sgp);
    SegmentationResult r;
    // EXEMPT=1: a removal that never takes an object's features (the ceiling of a better removal).
    if (std::getenv("EXEMPT")) seg.setRemovalExemptions(&pair.truth->object_id);
    segmentPair(fx, seg, pair.left, pair.right, pair.rig, r);
    const SceneTruth& t = *pair.truth;
    // Left pixels the right camera sees too (a left-right occlusion test on the true disparities).
    const cv::Mat seen_right = test::seenByTheRightCamera(t.disparity);
    int rows = 0, ok = 0;
    for (std::size_t y = 0; y < t.ground_offset_per_row.size(); ++y) {
      if (!std::isfinite(t.ground_offset_per_row[y])) continue;
      ++rows;
      ok += std::abs(r.ground.offset_per_row[y] - t.ground_offset_per_row[y]) <= 1.0f;
    }
    {
      GroundTally& g = ground_tally[static_cast<int>(sp.terrain) & 3][sp.weak_ground_texture ? 1 : 0];
      const double share = rows > 0 ? static_cast<double>(ok) / rows : 0.0;
      ++g.scenes;
      g.within += share >= 0.9 ? 1 : 0;
      g.measured += r.ground.source == GroundSource::kHough ? 1 : 0;
      g.share += share;
    }
    // The ground model over every visible ground pixel: within 1 of the true disparity.
    long ground_px = 0, ground_ok = 0;
    for (int y = std::max(r.ground.horizon_row, 0); y < pair.left.rows; ++y)
      for (int x = 0; x < pair.left.cols; ++x) {
        if (t.object_id.at<std::uint16_t>(y, x) != 0) continue;
        const float model = r.ground.groundOffsetAt(y, static_cast<float>(x));
        ++ground_px;
        ground_ok += std::abs(model - t.disparity.at<float>(y, x)) <= 1.0f;
      }
    std::printf("ground pixels %ld / %ld\n", ground_ok, ground_px);
    if (std::getenv("DUMP_GROUND_AT")) {
      const int xs[] = {50, 300, 621, 900, 1200};
      for (int y = std::max(r.ground.horizon_row, 0); y < pair.left.rows; y += 5) {
        std::printf("   y %3d", y);
        for (const int x : xs) {
          const float model = r.ground.groundOffsetAt(y, static_cast<float>(x));
          const bool g = t.object_id.at<std::uint16_t>(y, x) == 0;
          std::printf(" | x%4d %6.2f %6.2f%s", x, static_cast<double>(model), static_cast<double>(t.disparity.at<float>(y, x)), g ? " " : "*");
        }
        std::printf("\n");
      }
    }
    std::printf("seed %d terrain %d slope %.3f weak %d shadows %d trans %.3f: ground %s %d/%d bg %.1f/%.1f  render %.0f ms seg %.0f ms\n", seed,
                static_cast<int>(sp.terrain), sp.slope, sp.weak_ground_texture, sp.shadows, sp.transversal_slope,
                toString(r.ground.source), ok, rows, static_cast<double>(r.ground.background_offset),
                static_cast<double>(t.background_offset),
                std::chrono::duration<double, std::milli>(t1 - t0).count(), r.timing_ms["total"]);
    if (std::getenv("DUMP_GROUND")) {
      std::printf("   ground horizon %d per_column %.4f vertices %zu\n", r.ground.horizon_row,
                  static_cast<double>(r.ground.offset_per_column), r.ground.vertices.size());
      const std::size_t step = std::string(std::getenv("DUMP_GROUND")) == "all" ? 1 : 10;
      for (std::size_t y = 0; y < t.ground_offset_per_row.size(); y += step)
        std::printf("   row %3zu truth %6.2f found %6.2f\n", y, static_cast<double>(t.ground_offset_per_row[y]),
                    static_cast<double>(r.ground.offset_per_row[y]));
    }
    if (const char* spec = std::getenv("DUMPROW")) {
      // DUMPROW=y,x0,x1,d: row y over columns x0..x1, left features and the right ones d to the left, the
      // raw images the same way, and the true disparity x10.
      int y = 0, x0 = 0, x1 = 0, dd = 0;
      std::sscanf(spec, "%d,%d,%d,%d", &y, &x0, &x1, &dd);
      std::printf("   L  ");
      for (int x = x0; x <= x1; ++x) std::printf("%4d", r.left_features.at<std::uint8_t>(y, x));
      std::printf("\n   R  ");
      for (int x = x0; x <= x1; ++x)
        std::printf("%4d", x - dd >= 0 ? r.right_features.at<std::uint8_t>(y, x - dd) : -1);
      std::printf("\n   Li ");
      for (int x = x0; x <= x1; ++x) std::printf("%4d", pair.left.at<std::uint8_t>(y, x));
      std::printf("\n   Ri ");
      for (int x = x0; x <= x1; ++x) std::printf("%4d", x - dd >= 0 ? pair.right.at<std::uint8_t>(y, x - dd) : -1);
      std::printf("\n   D  ");
      for (int x = x0; x <= x1; ++x)
        std::printf("%4.0f", 10.0 * static_cast<double>(pair.truth->disparity.at<float>(y, x)));
      std::printf("\n");
    }
    if (const char* spec = std::getenv("DUMPLAB")) {
      // DUMPLAB=x0,x1,y0,y1,d: per pixel the label (. none, u unassigned, g ground, b background,
      // digit obstacle), upper case where the pixel matches the right image at d (+-1, window).
      int x0 = 0, x1 = 0, y0 = 0, y1 = 0, dd = 0;
      std::sscanf(spec, "%d,%d,%d,%d,%d", &x0, &x1, &y0, &y1, &dd);
      std::vector<std::uint8_t> m(static_cast<std::size_t>(pair.left.cols));
      for (int y = y0; y <= y1; ++y) {
        windowMatchRowReference(r.left_features.ptr<std::uint8_t>(y), r.right_features.ptr<std::uint8_t>(y),
                                pair.left.cols, x0, x1 + 1, dd - 1, dd + 1, sgp.obstacles.grey_tolerance,
                                sgp.obstacles.match_half_window_px, m.data());
        std::printf("   y %3d ", y);
        for (int x = x0; x <= x1; ++x) {
          const int lab = r.labels.at<std::uint8_t>(y, x);
          char c = lab == kLabelNone ? '.' : lab == kLabelUnassigned ? 'u' : lab == kLabelGround ? 'g'
                   : lab == kLabelBackground ? 'b' : static_cast<char>('0' + (lab - kLabelFirstObstacle) % 10);
          if (m[static_cast<std::size_t>(x)] && c >= 'a') c = static_cast<char>(c - 32);
          if (m[static_cast<std::size_t>(x)] && c >= '0' && c <= '9') c = '*';
          const int obj = t.object_id.at<std::uint16_t>(y, x);
          if (std::getenv("DUMPDIFF")) {
            // the smallest |left - right| over d-1..d+1 of the raw images, in steps of 4 grey levels
            int best = 255;
            for (int k = dd - 1; k <= dd + 1; ++k)
              if (x - k >= 0)
                best = std::min(best, std::abs(static_cast<int>(pair.left.at<std::uint8_t>(y, x)) -
                                               static_cast<int>(pair.right.at<std::uint8_t>(y, x - k))));
            c = best / 4 > 9 ? '+' : static_cast<char>('0' + best / 4);
          }
          std::printf("%c%c", c, obj >= 2 ? '|' : ' ');
        }
        std::printf("\n");
      }
    }
    cv::Mat canvas;
    const char* draw_dir = std::getenv("DRAW");
    if (draw_dir) {
      // Left image with every feature in its label colour (visualize.hpp); truth green (wanted) / yellow, found red.
      // RAW=1: the left image without labels; RAW=2: the right image.
      const int raw = std::getenv("RAW") ? std::atoi(std::getenv("RAW")) : 0;
      cv::cvtColor(raw == 2 ? pair.right : pair.left, canvas, cv::COLOR_GRAY2BGR);
      for (int y = 0; y < (raw ? 0 : canvas.rows); ++y)
        for (int x = 0; x < canvas.cols; ++x)
          if (const int label = r.labels.at<std::uint8_t>(y, x); label != kLabelNone) {
            const cv::Scalar c = labelColour(label);  // the colours of the segment pictures
            canvas.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<std::uint8_t>(c[0]), static_cast<std::uint8_t>(c[1]),
                                                   static_cast<std::uint8_t>(c[2]));
          }
    }
    std::vector<int> used(r.obstacles.size(), 0);
    std::vector<cv::Rect> missed;
    for (std::size_t k = 0; k < t.objects.size(); ++k) {
      const ObjectLabel& o = t.objects[k];
      const cv::Rect box(cv::Point(static_cast<int>(o.box[0]), static_cast<int>(o.box[1])),
                         cv::Point(static_cast<int>(o.box[2]) + 1, static_cast<int>(o.box[3]) + 1));
      const double d_true = pair.rig.focal_px * pair.rig.baseline_m / o.location_m[2];
      const bool want = t.object_visible_px[k] > 0 && box.height > 40 && o.location_m[2] < 30.0;
      int best = -1;
      double best_iou = 0;
      for (std::size_t j = 0; j < r.obstacles.size(); ++j) {
        const double v = test::iou(r.obstacles[j].box, box);
        if (v > best_iou) { best_iou = v; best = static_cast<int>(j); }
      }
      if (best >= 0 && best_iou > 0.2) used[static_cast<std::size_t>(best)] = 1;
      bool hit = false;  // as the acceptance test
      const test::DisparitySpread d_surface = test::visibleDisparities(t.disparity, t.object_id, k);
      for (const ObstacleCluster& c : r.obstacles) hit = hit || test::clusterFindsObject(c, box, d_true, d_surface);
      // SPREAD=1: the visible surface's disparities (10th to 90th percentile) the offset is judged by.
      if (std::getenv("SPREAD") && want)
        std::printf("   spread of visible disparities %.1f - %.1f\n", d_surface.low, d_surface.high);
      if (want) { ++wanted; found += hit; }
      if (!hit && t.object_visible_px[k] > 0 && (want || o.type == "Pedestrian")) missed.push_back(box);
      if (draw_dir && std::getenv("MATCHED") && !hit && want) {
        // MATCHED=1: unassigned features of the object that match at its offset (+-tolerance, the
        // obstacle stage's window) drawn white, those that do not drawn black.
        const int dd = static_cast<int>(std::lround(d_true));
        const int dtol = sgp.obstacles.offset_tolerance_px;
        std::vector<std::uint8_t> matched(static_cast<std::size_t>(pair.left.cols));
        int white = 0, black = 0;
        for (int y = box.y; y < box.y + box.height; ++y) {
          windowMatchRowReference(r.left_features.ptr<std::uint8_t>(y), r.right_features.ptr<std::uint8_t>(y),
                                  pair.left.cols, box.x, box.x + box.width, dd - dtol, dd + dtol,
                                  sgp.obstacles.grey_tolerance, sgp.obstacles.match_half_window_px, matched.data());
          for (int x = box.x; x < box.x + box.width; ++x) {
            if (t.object_id.at<std::uint16_t>(y, x) != k + 2 || r.labels.at<std::uint8_t>(y, x) != kLabelUnassigned) continue;
            const bool m = matched[static_cast<std::size_t>(x)] != 0;
            (m ? white : black)++;
            canvas.at<cv::Vec3b>(y, x) = m ? cv::Vec3b(255, 255, 255) : cv::Vec3b(0, 0, 0);
          }
        }
        std::printf("   unassigned object features matching at d %d: %d, not: %d\n", dd, white, black);
      }
      if (draw_dir && t.object_visible_px[k] > 0) {
        cv::rectangle(canvas, box, want ? cv::Scalar(0, 255, 0) : cv::Scalar(0, 255, 255), 1);
        cv::putText(canvas, std::to_string(static_cast<int>(std::lround(d_true))), box.tl() + cv::Point(0, -2),
                    cv::FONT_HERSHEY_PLAIN, 0.9, cv::Scalar(0, 255, 0));
      }
      // Share of the visible surface that carries features: plain faces show only their edges.
      // And where its features went: removed as ground or background, or left unassigned (the rest
      // are in obstacles).
      int with_features = 0, as_ground = 0, as_background = 0, unassigned = 0, visible_left = 0, visible_both = 0;
      for (int y = 0; y < t.object_id.rows; ++y)
        for (int x = 0; x < t.object_id.cols; ++x) {
          if (t.object_id.at<std::uint16_t>(y, x) != k + 2) continue;
          ++visible_left;
          visible_both += seen_right.at<std::uint8_t>(y, x);
          if (r.left_features.at<std::uint8_t>(y, x) == 0) continue;
          ++with_features;
          const int label = r.labels.at<std::uint8_t>(y, x);
          as_ground += label == kLabelGround;
          as_background += label == kLabelBackground;
          unassigned += label == kLabelUnassigned;
        }
      const double per_feature = 100.0 / std::max(1, with_features);
      if (std::getenv("SNR") && o.type == "Pedestrian" && !hit && t.object_visible_px[k] > 0) {
        // Unassigned left features matching the right at the person's offset (within the obstacle
        // stage's offset and grey tolerances, pixel by pixel), in the person's columns over its rows,
        // against the same count in windows of its width elsewhere on those rows.
        const int dd = static_cast<int>(std::lround(d_true));
        const int dtol = sgp.obstacles.offset_tolerance_px;
        std::vector<std::uint8_t> matched(static_cast<std::size_t>(pair.left.cols));
        auto countIn = [&](int x0) {
          int hits = 0;
          for (int y = box.y; y < box.y + box.height; ++y) {
            const std::uint8_t* lab = r.labels.ptr<std::uint8_t>(y);
            windowMatchRowReference(r.left_features.ptr<std::uint8_t>(y), r.right_features.ptr<std::uint8_t>(y),
                                    pair.left.cols, x0, x0 + box.width, dd - dtol, dd + dtol,
                                    sgp.obstacles.grey_tolerance, 0, matched.data());
            for (int x = x0; x < x0 + box.width; ++x) hits += lab[x] == kLabelUnassigned && matched[static_cast<std::size_t>(x)];
          }
          return hits;
        };
        const int signal = countIn(box.x);
        std::vector<int> noise;
        for (int x0 = 0; x0 + box.width <= pair.left.cols; x0 += box.width)
          if (x0 + box.width <= box.x - box.width || x0 >= box.x + 2 * box.width) noise.push_back(countIn(x0));
        std::sort(noise.begin(), noise.end());
        const double mean = std::accumulate(noise.begin(), noise.end(), 0.0) / std::max<std::size_t>(1, noise.size());
        double var = 0.0;
        for (const int v : noise) var += (v - mean) * (v - mean);
        const double sd = std::sqrt(var / std::max<std::size_t>(1, noise.size()));
        const int above = static_cast<int>(noise.end() - std::upper_bound(noise.begin(), noise.end(), signal - 1));
        std::printf("SNR z %.1f h %d w %d signal %d noise mean %.1f sd %.1f z-score %.1f windows at least as high %d of %zu\n",
                    o.location_m[2], box.height, box.width, signal, mean, sd, (signal - mean) / std::max(sd, 1e-9), above,
                    noise.size());
      }
      std::printf("   truth %-10s z %5.1f d %5.1f box [%d %d %d %d] vis %d feat %3.0f%% %s | best iou %.2f d %d %s"
                  " | features ground %.0f%% background %.0f%% unassigned %.0f%% | seen by the right camera %.0f%%\n", o.type.c_str(), o.location_m[2], d_true,
                  box.x, box.y, box.x + box.width - 1, box.y + box.height - 1, t.object_visible_px[k],
                  100.0 * with_features / std::max(1, t.object_visible_px[k]), want ? "WANT" : "    ",
                  best_iou, best >= 0 ? r.obstacles[static_cast<std::size_t>(best)].offset_px : -1, want ? (hit ? "ok" : "MISS") : "",
                  as_ground * per_feature, as_background * per_feature, unassigned * per_feature,
                  100.0 * visible_both / std::max(1, visible_left));
    }
    for (std::size_t j = 0; j < r.obstacles.size(); ++j) {
      // Spurious: overlaps no truth object.
      const auto& ob = r.obstacles[j];
      int on_objects = 0;
      for (int y = ob.box.y; y < ob.box.y + ob.box.height; ++y)
        for (int x = ob.box.x; x < ob.box.x + ob.box.width; ++x)
          if (r.labels.at<std::uint8_t>(y, x) == ob.label && t.object_id.at<std::uint16_t>(y, x) >= 2) ++on_objects;
      const bool spur = on_objects < ob.feature_count / 2;
      spurious += spur;
      if (draw_dir) {
        cv::rectangle(canvas, ob.box, cv::Scalar(0, 0, 255), 1);
        cv::putText(canvas, std::to_string(ob.offset_px), cv::Point(ob.box.x, ob.box.y + ob.box.height + 11),
                    cv::FONT_HERSHEY_PLAIN, 0.9, cv::Scalar(0, 0, 255));
      }
      std::printf("   found d %d [%d-%d] box [%d %d %d %d] feat %d on-objects %d %s\n", ob.offset_px, ob.min_offset_px, ob.max_offset_px, ob.box.x, ob.box.y,
                  ob.box.x + ob.box.width - 1, ob.box.y + ob.box.height - 1, ob.feature_count, on_objects, spur ? "SPURIOUS" : "");
    }
    if (draw_dir) {
      cv::imwrite(std::string(draw_dir) + "/seed" + std::to_string(seed) + ".png", canvas);
      // A 4x zoom of every missed object, with 24 pixels around it.
      for (std::size_t k = 0; k < missed.size(); ++k) {
        const cv::Rect roi = (missed[k] + cv::Size(48, 48) - cv::Point(24, 24)) & cv::Rect(0, 0, canvas.cols, canvas.rows);
        cv::Mat zoom;
        cv::resize(canvas(roi), zoom, {}, 4, 4, cv::INTER_NEAREST);
        cv::imwrite(std::string(draw_dir) + "/seed" + std::to_string(seed) + "_miss" + std::to_string(k) + ".png", zoom);
      }
    }
  }
  const char* terrain_names[4] = {"flat", "uphill", "downhill", "slope change"};
  std::printf("ground rows within +-1 by terrain (scenes with >= 90 %% of their rows / scenes, mean share, "
              "measured line):\n");
  for (int t = 0; t < 4; ++t)
    for (int weak = 0; weak < 2; ++weak) {
      const GroundTally& g = ground_tally[t][weak];
      if (g.scenes == 0) continue;
      std::printf("  %-12s %-8s %3d / %3d  mean %.3f  measured %d\n", terrain_names[t], weak ? "weak" : "textured",
                  g.within, g.scenes, g.share / g.scenes, g.measured);
    }
  std::printf("found %d / %d, spurious %d over %d frames\n", found, wanted, spurious, n);
}
