// SH projection and reconstruction of a 512x512 angle map (thesis Table 6.3: order 35 took
// 36.6 s to project, 8.5 s with precomputed tables, and 5.7 s for the maps, on an Nvidia Shield).
#include <benchmark/benchmark.h>

#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/common/sh.hpp"

namespace {

using namespace arlight;

const EnvMap& probe_512() {
  static const EnvMap env =
      resample(load_envmap(std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/venice.exr").env,
               EnvLayout::for_size(Projection::AngleMap, 512));
  return env;
}

void BM_ShProject(benchmark::State& state) {
  const EnvMap& env = probe_512();
  const int order = int(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(sh_project(env, order));
  state.counters["texels"] = double(texel_table(env.layout)->size());
}
BENCHMARK(BM_ShProject)
    ->Arg(3)
    ->Arg(10)
    ->Arg(35)
    ->Arg(86)
    ->Arg(128)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_ShReconstruct(benchmark::State& state) {
  const EnvMap& env = probe_512();
  const ShCoeffs c = sh_project(env, int(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(sh_reconstruct(c, env.layout));
}
BENCHMARK(BM_ShReconstruct)->Arg(3)->Arg(35)->Arg(86)->Unit(benchmark::kMillisecond)->UseRealTime();

// The per-layout texel geometry (directions, exact solid angles) that sh_project caches.
void BM_TexelTableAngleMap512(benchmark::State& state) {
  int n = 512;
  for (auto _ : state) {
    // A new size each time defeats the cache (512, 513, ...).
    benchmark::DoNotOptimize(texel_table(EnvLayout::for_size(Projection::AngleMap, n)));
    n = n == 520 ? 512 : n + 1;
  }
}
BENCHMARK(BM_TexelTableAngleMap512)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_ResampleLatLongToAngleMap512(benchmark::State& state) {
  const EnvMap src = load_envmap(std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/venice.exr").env;
  const EnvLayout dst = EnvLayout::for_size(Projection::AngleMap, 512);
  for (auto _ : state) benchmark::DoNotOptimize(resample(src, dst));
}
BENCHMARK(BM_ResampleLatLongToAngleMap512)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
