// Google Benchmark of the Section III segmentation and the detection.
//
//  - Per stage on the real KITTI pairs (1242x375, 128 offsets): the serial
//    reference and the fast path on 1 and 2 TBB threads.
//  - The whole segmentation (features of both images + every stage), the
//    detection (segmentation + localization + tracking) and OpenCV StereoBM
//    (128 disparities, block 15, one thread) on the same pairs.
//  - The localization alone (symmetry candidates, filters, stereo refinement,
//    ground contact, HOG shape validation; no tracking) on a fixed
//    segmentation of each frame, computed once outside the timed loop, so the
//    figure does not move with the segmentation: KITTI pairs and synthetic
//    scenes (seeds 1000-1007, 1242x375), serial reference and fast path on
//    one thread, fast path on two (parallel bands of axes and boxes).
//  - Cost as work grows: the segmentation, the correlation and StereoBM on
//    analytic scenes of 640x480, 1242x375 and 1920x1080 with 64, 128 and 256
//    offsets (StereoBM with as many disparities).
//
// After the runs a summary prints the ratios measured in this process: fast
// path vs reference per stage, 2 threads vs 1, StereoBM vs segmentation.
// Every benchmark measures wall-clock time (UseRealTime); frames cycle over the
// loaded pairs, reading and set-up are outside the timed loop.
#include <algorithm>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <tbb/global_control.h>

#include "../tests/unit/vision/analytic_scene.hpp"
#include "../tests/unit/vision/test_helpers.hpp"
#include "io/synthetic_scene.hpp"
#include "vision/detector.hpp"
#include "vision/segmenter.hpp"
#include "vision/simd_match.hpp"

namespace {

// One stereo pair with its feature images and the stage inputs computed once.
struct Frame {
  cv::Mat left, right;
  sg::StereoRig rig;
  cv::Mat left_features, right_features;
  cv::Mat score, matches;  // correlation of the feature images
  sg::GroundProfile ground;
  cv::Mat remaining, labels;  // after removal
  std::vector<std::uint8_t> changed_rows;
};

struct FrameSet {
  std::string name;
  int offsets = 128;
  std::vector<Frame> frames;
};

Frame prepareFrame(const cv::Mat& left, const cv::Mat& right, const sg::StereoRig& rig, int offsets) {
  Frame f{left, right, rig, {}, {}, {}, {}, {}, {}, {}, {}};
  sg::FeatureExtractor fx;
  fx.computeReference(left, f.left_features);
  fx.computeReference(right, f.right_features);
  sg::CorrelationParams cp;
  cp.offsets = offsets;
  sg::Correlator corr(cp);
  corr.computeReference(f.left_features, f.right_features, f.score, f.matches);
  sg::GroundEstimator g;
  g.compute(f.score, f.matches, rig, nullptr, 0, f.ground);
  g.estimateRoll(f.left_features, f.right_features, rig, f.ground);
  sg::FeatureRemover remover;
  remover.computeReference(f.left_features, f.right_features, f.ground, f.remaining, f.labels, f.changed_rows);
  return f;
}

// The real KITTI pairs, loaded once.
const FrameSet& kitti() {
  static const FrameSet set = [] {
    FrameSet s;
    s.name = "kitti";
    for (const sg::test::RealPair& p : sg::test::loadKittiRigPairs())
      s.frames.push_back(prepareFrame(p.left, p.right, p.rig, s.offsets));
    return s;
  }();
  return set;
}

// Analytic scene of a given size (textured ground, background, three boxes), cached.
const FrameSet& analytic(int width, int height, int offsets) {
  static std::map<std::tuple<int, int, int>, std::unique_ptr<FrameSet>> cache;
  auto& slot = cache[{width, height, offsets}];
  if (!slot) {
    sg::test::AnalyticSceneParams p;
    p.width = width;
    p.height = height;
    p.focal_px = 721.5 * width / 1242.0;
    p.boxes = {{-1.5, 8.0, 0.8, 1.8}, {2.0, 14.0, 1.2, 1.5}, {0.5, 25.0, 0.6, 1.7}};
    const sg::test::AnalyticScene scene = sg::test::renderAnalyticScene(p);
    slot = std::make_unique<FrameSet>();
    slot->name = std::to_string(width) + "x" + std::to_string(height);
    slot->offsets = offsets;
    slot->frames.push_back(prepareFrame(scene.left, scene.right, scene.rig, offsets));
  }
  return *slot;
}

// A frame with its segmentation, the fixed input of the localization benchmarks.
struct SegmentedFrame {
  cv::Mat left, right;
  sg::StereoRig rig;
  sg::SegmentationResult segmentation;
};

std::vector<SegmentedFrame> segmentAll(const std::vector<std::pair<cv::Mat, cv::Mat>>& images,
                                       const std::vector<sg::StereoRig>& rigs) {
  std::vector<SegmentedFrame> out;
  sg::FeatureExtractor fx;
  sg::Segmenter seg;
  for (std::size_t i = 0; i < images.size(); ++i) {
    SegmentedFrame f{images[i].first, images[i].second, rigs[i], {}};
    seg.reset();
    sg::segmentPair(fx, seg, f.left, f.right, f.rig, f.segmentation);
    out.push_back(std::move(f));
  }
  return out;
}

const std::vector<SegmentedFrame>& segmentedKitti() {
  static const std::vector<SegmentedFrame> set = [] {
    std::vector<std::pair<cv::Mat, cv::Mat>> images;
    std::vector<sg::StereoRig> rigs;
    for (const sg::test::RealPair& p : sg::test::loadKittiRigPairs()) {
      images.emplace_back(p.left, p.right);
      rigs.push_back(p.rig);
    }
    return segmentAll(images, rigs);
  }();
  return set;
}

const std::vector<SegmentedFrame>& segmentedSynthetic() {
  static const std::vector<SegmentedFrame> set = [] {
    std::vector<std::pair<cv::Mat, cv::Mat>> images;
    std::vector<sg::StereoRig> rigs;
    for (std::uint64_t seed = 1000; seed < 1008; ++seed) {
      const sg::StereoPair p = sg::renderSyntheticScene(sg::randomSceneParams(seed, 1242, 375), seed);
      images.emplace_back(p.left, p.right);
      rigs.push_back(p.rig);
    }
    return segmentAll(images, rigs);
  }();
  return set;
}

// Runs `body(frame)` once per iteration, cycling over the frames, with at most `threads` TBB threads.
void run(benchmark::State& state, const FrameSet& set, int threads, const std::function<void(const Frame&)>& body) {
  if (set.frames.empty()) {
    state.SkipWithError("no frames (real pairs missing under SG_SHARED_DATA_DIR?)");
    return;
  }
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
  std::size_t i = 0;
  body(set.frames[0]);  // warm-up: scratch sized, threads started
  for (auto _ : state) {
    body(set.frames[i]);
    i = (i + 1) % set.frames.size();
  }
  state.counters["frames"] = static_cast<double>(set.frames.size());
}

enum class Impl { kReference, kFast };

void registerStage(const std::string& stage, Impl impl, int threads,
                   std::function<std::function<void(const Frame&)>()> make_body) {
  const std::string name = "stage/" + stage + "/" + (impl == Impl::kReference ? "reference" : "fast") +
                           "/threads:" + std::to_string(threads);
  benchmark::RegisterBenchmark(name.c_str(), [threads, make_body](benchmark::State& state) {
    run(state, kitti(), threads, make_body());
  })->Unit(benchmark::kMillisecond)->UseRealTime();
}

// Per-stage benchmarks on the KITTI pairs. Each body owns its stage object and outputs.
void registerStages() {
  for (Impl impl : {Impl::kReference, Impl::kFast}) {
    const bool ref = impl == Impl::kReference;
    for (int threads : ref ? std::vector<int>{1} : std::vector<int>{1, 2}) {
      registerStage("features", impl, threads, [ref] {
        auto fx = std::make_shared<sg::FeatureExtractor>();
        auto out = std::make_shared<cv::Mat>();
        return [=](const Frame& f) {
          if (ref) {
            fx->computeReference(f.left, *out);
            fx->computeReference(f.right, *out);
          } else {
            fx->compute(f.left, *out);
            fx->compute(f.right, *out);
          }
          benchmark::DoNotOptimize(out->data);
        };
      });
      registerStage("correlation", impl, threads, [ref] {
        auto c = std::make_shared<sg::Correlator>();
        auto s = std::make_shared<cv::Mat>(), m = std::make_shared<cv::Mat>();
        return [=](const Frame& f) {
          if (ref) c->computeReference(f.left_features, f.right_features, *s, *m);
          else c->compute(f.left_features, f.right_features, *s, *m);
          benchmark::DoNotOptimize(s->data);
        };
      });
      registerStage("ground", impl, threads, [ref] {
        auto g = std::make_shared<sg::GroundEstimator>();
        auto profile = std::make_shared<sg::GroundProfile>();
        return [=](const Frame& f) {
          if (ref) {
            g->computeReference(f.score, f.matches, f.rig, nullptr, 0, *profile);
            g->estimateRollReference(f.left_features, f.right_features, f.rig, *profile);
          } else {
            g->compute(f.score, f.matches, f.rig, nullptr, 0, *profile);
            g->estimateRoll(f.left_features, f.right_features, f.rig, *profile);
          }
          benchmark::DoNotOptimize(profile->offset_per_row.data());
        };
      });
      registerStage("removal", impl, threads, [ref] {
        auto r = std::make_shared<sg::FeatureRemover>();
        auto rem = std::make_shared<cv::Mat>(), lab = std::make_shared<cv::Mat>();
        auto rows = std::make_shared<std::vector<std::uint8_t>>();
        return [=](const Frame& f) {
          if (ref) r->computeReference(f.left_features, f.right_features, f.ground, *rem, *lab, *rows);
          else r->compute(f.left_features, f.right_features, f.ground, *rem, *lab, *rows);
          benchmark::DoNotOptimize(rem->data);
        };
      });
      registerStage("correlation_after_removal", impl, threads, [ref] {
        auto c = std::make_shared<sg::Correlator>();
        auto s = std::make_shared<cv::Mat>(), m = std::make_shared<cv::Mat>();
        return [=](const Frame& f) {
          if (ref) {
            c->computeReference(f.remaining, f.right_features, *s, *m);
          } else {
            f.score.copyTo(*s);
            f.matches.copyTo(*m);
            c->updateRows(f.left_features, f.remaining, f.right_features, f.changed_rows, *s, *m);
          }
          benchmark::DoNotOptimize(s->data);
        };
      });
    }
  }
}

void registerWhole(const std::string& prefix, const std::function<const FrameSet&()>& set, int offsets,
                   const std::vector<int>& thread_counts, bool detection) {
  for (int threads : thread_counts) {
    benchmark::RegisterBenchmark(("segmentation/" + prefix + "/threads:" + std::to_string(threads)).c_str(),
                                 [=](benchmark::State& state) {
                                   sg::SegmenterParams sp;
                                   sp.correlation.offsets = offsets;
                                   sg::FeatureExtractor fx;
                                   sg::Segmenter seg(sp);
                                   sg::SegmentationResult r;
                                   run(state, set(), threads, [&](const Frame& f) {
                                     seg.reset();
                                     sg::segmentPair(fx, seg, f.left, f.right, f.rig, r);
                                   });
                                 })
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  }
  if (detection) {
    for (int threads : thread_counts) {
      benchmark::RegisterBenchmark(("detection/" + prefix + "/threads:" + std::to_string(threads)).c_str(),
                                   [=](benchmark::State& state) {
                                     sg::DetectorParams dp;
                                     dp.segmenter.correlation.offsets = offsets;
                                     dp.tracking = false;  // frames are unrelated
                                     sg::Detector det(dp);
                                     sg::DetectionResult r;
                                     run(state, set(), threads, [&](const Frame& f) {
                                       det.reset();
                                       det.compute(f.left, f.right, f.rig, 0.0, r);
                                     });
                                   })
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime();
    }
  }
  benchmark::RegisterBenchmark(("stereobm/" + prefix + "/threads:1").c_str(),
                               [=](benchmark::State& state) {
                                 const int previous = cv::getNumThreads();
                                 cv::setNumThreads(1);
                                 cv::Ptr<cv::StereoBM> bm = cv::StereoBM::create(offsets, 15);
                                 cv::Mat disparity;
                                 run(state, set(), 1, [&](const Frame& f) { bm->compute(f.left, f.right, disparity); });
                                 cv::setNumThreads(previous);
                               })
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
}

// Localization on a fixed segmentation: the reference and the fast path on one
// thread, and the fast path's parallel bands on two.
void registerLocalization() {
  const std::pair<const char*, const std::vector<SegmentedFrame>& (*)()> sets[] = {
      {"kitti", segmentedKitti}, {"synthetic", segmentedSynthetic}};
  const std::pair<Impl, int> variants[] = {{Impl::kReference, 1}, {Impl::kFast, 1}, {Impl::kFast, 2}};
  for (const auto& [name, frames] : sets) {
    for (const auto& [impl, threads] : variants) {
      const bool ref = impl == Impl::kReference;
      const std::string bench = std::string("localization/") + name + "/" + (ref ? "reference" : "fast") +
                                "/threads:" + std::to_string(threads);
      benchmark::RegisterBenchmark(bench.c_str(), [ref, threads = threads, frames = frames](benchmark::State& state) {
        const std::vector<SegmentedFrame>& set = frames();
        if (set.empty()) {
          state.SkipWithError("no frames (real pairs missing under SG_SHARED_DATA_DIR?)");
          return;
        }
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
        sg::HumanLocalizer loc{sg::LocalizerParams{}};
        std::vector<sg::HumanDetection> out;
        std::size_t boxes = 0;
        auto body = [&](const SegmentedFrame& f) {
          if (ref) loc.computeReference(f.left, f.right, f.rig, f.segmentation, out);
          else loc.compute(f.left, f.right, f.rig, f.segmentation, out);
          benchmark::DoNotOptimize(out.data());
        };
        body(set[0]);  // warm-up: scratch sized
        std::size_t i = 0;
        long n = 0;
        for (auto _ : state) {
          body(set[i]);
          boxes += out.size();
          ++n;
          i = (i + 1) % set.size();
        }
        state.counters["frames"] = static_cast<double>(set.size());
        state.counters["humans_per_frame"] = n > 0 ? static_cast<double>(boxes) / static_cast<double>(n) : 0.0;
      })->Unit(benchmark::kMillisecond)->UseRealTime();
    }
  }
}

void registerSweep() {
  const int sizes[][2] = {{640, 480}, {1242, 375}, {1920, 1080}};
  for (const auto& wh : sizes) {
    for (int offsets : {64, 128, 256}) {
      const int w = wh[0], h = wh[1];
      const std::string prefix =
          "sweep/" + std::to_string(w) + "x" + std::to_string(h) + "/offsets:" + std::to_string(offsets);
      registerWhole(prefix, [=]() -> const FrameSet& { return analytic(w, h, offsets); }, offsets, {1}, false);
      benchmark::RegisterBenchmark(("correlation/" + prefix + "/threads:1").c_str(),
                                   [=](benchmark::State& state) {
                                     sg::CorrelationParams cp;
                                     cp.offsets = offsets;
                                     sg::Correlator c(cp);
                                     cv::Mat s, m;
                                     run(state, analytic(w, h, offsets), 1, [&](const Frame& f) {
                                       c.compute(f.left_features, f.right_features, s, m);
                                     });
                                   })
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime();
    }
  }
}

// Keeps every run's adjusted real time (ms) by name for the summary; per
// name the smallest over repetitions and the median aggregate when present.
class Collector : public benchmark::ConsoleReporter {
 public:
  struct Figures {
    double min_ms = 0.0;  // wall clock
    double median_ms = 0.0;
    double cpu_min_ms = 0.0;  // CPU time of the benchmark's thread
    double cpu_median_ms = 0.0;
  };
  std::map<std::string, Figures> figures;

  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs) {
      if (run.error_occurred) continue;
      const double ms = run.GetAdjustedRealTime();
      const double cpu = run.GetAdjustedCPUTime();
      Figures& f = figures[run.run_name.str()];
      if (run.run_type == Run::RT_Aggregate) {
        if (run.aggregate_name == "median") {
          f.median_ms = ms;
          f.cpu_median_ms = cpu;
        }
        continue;
      }
      f.min_ms = f.min_ms == 0.0 ? ms : std::min(f.min_ms, ms);
      f.cpu_min_ms = f.cpu_min_ms == 0.0 ? cpu : std::min(f.cpu_min_ms, cpu);
      if (f.median_ms == 0.0) f.median_ms = ms;  // single repetition: the run itself
      if (f.cpu_median_ms == 0.0) f.cpu_median_ms = cpu;
    }
    ConsoleReporter::ReportRuns(runs);
  }
};

// Ratio of two benchmarks: on CPU time when both run on one thread (a busy machine
// inflates wall-clock time by waiting), on wall-clock time for thread-count scaling.
void printRatio(const Collector& c, const std::string& label, const std::string& slow, const std::string& fast,
                bool wall = false) {
  const auto a = c.figures.find(slow), b = c.figures.find(fast);
  if (a == c.figures.end() || b == c.figures.end()) return;
  const Collector::Figures& x = a->second;
  const Collector::Figures& y = b->second;
  const double med = wall ? x.median_ms / y.median_ms : x.cpu_median_ms / y.cpu_median_ms;
  // With --benchmark_report_aggregates_only the single runs never reach the reporter: no minimum.
  const bool have_min = wall ? (x.min_ms > 0.0 && y.min_ms > 0.0) : (x.cpu_min_ms > 0.0 && y.cpu_min_ms > 0.0);
  if (!have_min) {
    std::printf("  %-60s %7.2fx (median) %8s (min) %s\n", label.c_str(), med, "-", wall ? "wall" : "cpu");
    return;
  }
  const double mn = wall ? x.min_ms / y.min_ms : x.cpu_min_ms / y.cpu_min_ms;
  std::printf("  %-60s %7.2fx (median) %7.2fx (min) %s\n", label.c_str(), med, mn, wall ? "wall" : "cpu");
}

void printSummary(const Collector& c) {
  std::printf("\nsummary (vector kernels: %s)\n", sg::simd::kernelName());
  std::printf("  %-60s %9s %9s %9s %9s (ms)\n", "benchmark", "wall med", "wall min", "cpu med", "cpu min");
  for (const auto& [name, f] : c.figures)
    std::printf("  %-60s %9.3f %9.3f %9.3f %9.3f\n", name.c_str(), f.median_ms, f.min_ms, f.cpu_median_ms,
                f.cpu_min_ms);
  std::printf("\nratios\n");
  for (const char* stage : {"features", "correlation", "ground", "removal", "correlation_after_removal"}) {
    const std::string s = std::string("stage/") + stage;
    printRatio(c, s + ": reference / fast (1 thread)", s + "/reference/threads:1/real_time",
               s + "/fast/threads:1/real_time");
    printRatio(c, s + ": fast 1 thread / 2 threads", s + "/fast/threads:1/real_time", s + "/fast/threads:2/real_time",
               true);
  }
  for (const char* set : {"kitti", "synthetic"}) {
    const std::string l = std::string("localization/") + set;
    printRatio(c, l + ": reference / fast (1 thread)", l + "/reference/threads:1/real_time",
               l + "/fast/threads:1/real_time");
    printRatio(c, l + ": fast 1 thread / 2 threads", l + "/fast/threads:1/real_time", l + "/fast/threads:2/real_time",
               true);
  }
  printRatio(c, "segmentation kitti: 1 thread / 2 threads", "segmentation/kitti/threads:1/real_time",
             "segmentation/kitti/threads:2/real_time", true);
  printRatio(c, "kitti: StereoBM / segmentation (1 thread each)", "stereobm/kitti/threads:1/real_time",
             "segmentation/kitti/threads:1/real_time");
  for (const auto& [name, f] : c.figures) {
    (void)f;
    const std::string tag = "segmentation/sweep/";
    if (name.rfind(tag, 0) != 0) continue;
    const std::string rest = name.substr(tag.size());
    printRatio(c, "sweep " + rest.substr(0, rest.find("/threads")) + ": StereoBM / segmentation",
               "stereobm/sweep/" + rest, name);
  }
}

}  // namespace

int main(int argc, char** argv) {
  registerStages();
  registerWhole("kitti", kitti, 128, {1, 2}, true);
  registerLocalization();
  registerSweep();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  Collector collector;
  benchmark::RunSpecifiedBenchmarks(&collector);
  printSummary(collector);
  benchmark::Shutdown();
  return 0;
}
