// Render time of the synthetic scene generator: one 1242x375 stereo frame
// (both images and the ground truth), serial (one core) and TBB row bands.
#include <cstdint>

#include <benchmark/benchmark.h>

#include "io/synthetic_scene.hpp"

namespace {

void renderFrames(benchmark::State& state, sg::SyntheticSceneRenderer::Execution execution) {
  std::uint64_t seed = 0;
  sg::StereoPair pair;
  for (auto _ : state) {
    // Eight different scenes in turn: terrain, people and obstacles vary.
    const sg::SyntheticSceneParams params = sg::randomSceneParams(seed % 8);
    sg::SyntheticSceneRenderer renderer(params);
    renderer.compute(seed % 8, pair, execution);
    benchmark::DoNotOptimize(pair.left.data);
    ++seed;
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_SyntheticStereoFrameSerial(benchmark::State& state) {
  renderFrames(state, sg::SyntheticSceneRenderer::Execution::kSerial);
}
void BM_SyntheticStereoFrameParallel(benchmark::State& state) {
  renderFrames(state, sg::SyntheticSceneRenderer::Execution::kParallel);
}

BENCHMARK(BM_SyntheticStereoFrameSerial)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_SyntheticStereoFrameParallel)->Unit(benchmark::kMillisecond)->MinTime(2.0);

}  // namespace

BENCHMARK_MAIN();
