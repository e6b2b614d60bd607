// Google Benchmark of the Section III stages on an analytic scene (textured
// ground, background, three boxes): arguments are image width x offsets; the
// height follows the KITTI aspect ratio (width * 375 / 1242).
#include <benchmark/benchmark.h>

#include <tbb/global_control.h>

#include "../tests/unit/vision/analytic_scene.hpp"
#include "vision/segmenter.hpp"

namespace {

sg::test::AnalyticScene sceneOfWidth(int width) {
  sg::test::AnalyticSceneParams p;
  p.width = width;
  p.height = width * 375 / 1242;
  p.focal_px = 721.5 * width / 1242.0;
  p.boxes = {{-1.5, 8.0, 0.8, 1.8}, {2.0, 14.0, 1.2, 1.5}, {0.5, 25.0, 0.6, 1.7}};
  return sg::test::renderAnalyticScene(p);
}

struct Prepared {
  sg::test::AnalyticScene scene;
  cv::Mat left_features, right_features;
};

Prepared prepare(int width) {
  Prepared p{sceneOfWidth(width), {}, {}};
  sg::FeatureExtractor fx;
  fx.computeReference(p.scene.left, p.left_features);
  fx.computeReference(p.scene.right, p.right_features);
  return p;
}

void BM_FeaturesSerial(benchmark::State& state) {
  const Prepared p = prepare(static_cast<int>(state.range(0)));
  sg::FeatureExtractor fx;
  cv::Mat out;
  for (auto _ : state) {
    fx.computeReference(p.scene.left, out);
    benchmark::DoNotOptimize(out.data);
  }
}

void BM_FeaturesTbb(benchmark::State& state) {
  const Prepared p = prepare(static_cast<int>(state.range(0)));
  sg::FeatureExtractor fx;
  cv::Mat out;
  for (auto _ : state) {
    fx.compute(p.scene.left, out);
    benchmark::DoNotOptimize(out.data);
  }
}

void BM_CorrelationSerial(benchmark::State& state) {
  const Prepared p = prepare(static_cast<int>(state.range(0)));
  sg::CorrelationParams cp;
  cp.offsets = static_cast<int>(state.range(1));
  sg::Correlator c(cp);
  cv::Mat score, matches;
  for (auto _ : state) {
    c.computeReference(p.left_features, p.right_features, score, matches);
    benchmark::DoNotOptimize(score.data);
  }
}

void BM_CorrelationTbb(benchmark::State& state) {
  const Prepared p = prepare(static_cast<int>(state.range(0)));
  sg::CorrelationParams cp;
  cp.offsets = static_cast<int>(state.range(1));
  sg::Correlator c(cp);
  cv::Mat score, matches;
  for (auto _ : state) {
    c.compute(p.left_features, p.right_features, score, matches);
    benchmark::DoNotOptimize(score.data);
  }
}

void BM_Ground(benchmark::State& state) {
  const Prepared p = prepare(static_cast<int>(state.range(0)));
  sg::CorrelationParams cp;
  cp.offsets = static_cast<int>(state.range(1));
  sg::Correlator c(cp);
  cv::Mat score, matches;
  c.compute(p.left_features, p.right_features, score, matches);
  sg::GroundEstimator g;
  sg::GroundProfile profile;
  for (auto _ : state) {
    g.compute(score, p.scene.rig, nullptr, 0, profile);
    benchmark::DoNotOptimize(profile.offset_per_row.data());
  }
}

void BM_Segmentation(benchmark::State& state) {
  const Prepared p = prepare(static_cast<int>(state.range(0)));
  sg::SegmenterParams sp;
  sp.correlation.offsets = static_cast<int>(state.range(1));
  sg::FeatureExtractor fx;
  sg::Segmenter seg(sp);
  sg::SegmentationResult r;
  for (auto _ : state) {
    sg::segmentPair(fx, seg, p.scene.left, p.scene.right, p.scene.rig, r);
    benchmark::DoNotOptimize(r.labels.data);
  }
}

void sizes(benchmark::internal::Benchmark* b) {
  for (int width : {621, 1242})
    for (int offsets : {64, 128}) b->Args({width, offsets});
}

}  // namespace

BENCHMARK(BM_FeaturesSerial)->Arg(621)->Arg(1242)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FeaturesTbb)->Arg(621)->Arg(1242)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_CorrelationSerial)->Apply(sizes)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CorrelationTbb)->Apply(sizes)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Ground)->Apply(sizes)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Segmentation)->Apply(sizes)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
