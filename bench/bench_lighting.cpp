// Irradiance and reflection maps, all 8 thesis shininess values (1 ... 1280), of 512 x 512
// angle maps of two real probes, by every method. Each method's counters give the worst mean
// and max error over the 8 maps against accurate (eqs. 6.1/6.2) and its speed-up over accurate
// measured in this same run. Results: bench/RESULTS.md.
#include <benchmark/benchmark.h>

#include <map>
#include <string>

#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/lighting/lighting.hpp"

using namespace arlight;

namespace {

const std::vector<double> kShininess = {1, 10, 20, 40, 80, 160, 320, 1280};

const EnvMap& probe(const std::string& name) {
  static std::map<std::string, EnvMap> cache;
  auto it = cache.find(name);
  if (it == cache.end()) {
    const EnvMap src =
        load_envmap(std::string(ARLIGHT_SOURCE_DIR) + "/data/probes/" + name + ".exr").env;
    it = cache.emplace(name, resample(src, EnvLayout::for_size(Projection::AngleMap, 512))).first;
  }
  return it->second;
}

struct Reference {
  lighting::ComputedMapSet maps;
  double seconds = 0.0;
};
std::map<std::string, Reference>& references() {
  static std::map<std::string, Reference> r;
  return r;
}

void BM_Maps(benchmark::State& state, const std::string& probe_name, const std::string& method) {
  const EnvMap& env = probe(probe_name);
  const lighting::MethodSpec spec = lighting::parse_method(method);
  // Warm the per-layout texel tables so every method is timed on the same footing.
  (void)texel_table(env.layout);
  lighting::ComputedMapSet last;
  for (auto _ : state) last = lighting::compute_maps(env, kShininess, env.layout, spec);
  const double seconds = last.total_seconds;
  if (spec.method == lighting::Method::Accurate) references()[probe_name] = {last, seconds};
  auto ref = references().find(probe_name);
  if (ref == references().end()) return;
  double worst_mean = 0.0, worst_max = 0.0;
  for (std::size_t k = 0; k < kShininess.size(); ++k) {
    const lighting::MapError e = lighting::map_error(ref->second.maps.maps[k], last.maps[k]);
    worst_mean = std::max(worst_mean, e.mean);
    worst_max = std::max(worst_max, e.max);
    state.counters["max_s" + std::to_string(int(kShininess[k]))] = e.max;
  }
  state.counters["worst_mean"] = worst_mean;
  state.counters["worst_max"] = worst_max;
  state.counters["x_faster"] = ref->second.seconds / seconds;
}

// Accurate first: the others' errors and speed-ups are measured against it.
const bool registered = [] {
  for (const char* p : {"venice", "park"})
    for (const char* m : {"accurate", "auto", "sh:35", "mipmap", "bounded", "importance:64"}) {
      auto* b = benchmark::RegisterBenchmark((std::string("BM_Maps/") + p + "/" + m).c_str(),
                                             BM_Maps, std::string(p), std::string(m));
      b->Unit(benchmark::kMillisecond)->UseRealTime();
      // One run of the slow methods is minutes of signal already.
      if (std::string(m) == "accurate" || std::string(m) == "bounded") b->Iterations(1);
    }
  return true;
}();

}  // namespace

namespace {

// What arlightd computes for a session (issue 16 §3): the 8 maps of a map set at 128² (or the
// given size) with the auto method on all cores, from the capture's own layout (a cube map of
// face 192 for --map-size 512) or from it reduced to a smaller face (range 1). Counters: the
// worst mean and max error (eqs. 6.1/6.2) over the 8 maps against the set from face 192.
void BM_SessionMapSet(benchmark::State& state) {
  static const EnvMap full = resample(probe("venice"), EnvLayout::for_size(Projection::Cube, 192));
  const EnvLayout out = EnvLayout::for_size(Projection::AngleMap, int(state.range(0)));
  const int face = int(state.range(1));
  const lighting::MethodSpec spec = lighting::parse_method("auto");
  const lighting::ComputedMapSet reference = lighting::compute_maps(full, kShininess, out, spec);
  const EnvMap input =
      face == 192 ? full : reduce(full, EnvLayout::for_size(Projection::Cube, face));
  (void)texel_table(input.layout), (void)texel_table(out);
  lighting::ComputedMapSet last;
  for (auto _ : state) last = lighting::compute_maps(input, kShininess, out, spec);
  double worst_mean = 0.0, worst_max = 0.0;
  for (std::size_t k = 0; k < kShininess.size(); ++k) {
    const lighting::MapError e = lighting::map_error(reference.maps[k], last.maps[k]);
    worst_mean = std::max(worst_mean, e.mean);
    worst_max = std::max(worst_max, e.max);
  }
  state.counters["worst_mean"] = worst_mean;
  state.counters["worst_max"] = worst_max;
}
BENCHMARK(BM_SessionMapSet)
    ->Args({32, 192})
    ->Args({128, 192})
    ->Args({128, 96})
    ->Args({128, 64})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
