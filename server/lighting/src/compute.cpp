// compute_maps(): request checking and dispatch, tiling, progress, cancellation, errors.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <numbers>
#include <numeric>

#include "arlight/common/error.hpp"
#include "job.hpp"
#include "kernels.hpp"

namespace arlight::lighting {

namespace detail {

OutputTexels::OutputTexels(const EnvLayout& layout, int kTile)
    : table_(texel_table(layout)), entry_(layout.texel_count(), -1) {
  for (std::size_t i = 0; i < table_->size(); ++i) entry_[table_->index[i]] = std::int32_t(i);
  // Cube faces split at face borders so a tile never spans two faces.
  const int w = layout.width(), h = layout.height();
  const int band = layout.projection() == Projection::Cube ? layout.face_size() : h;
  for (int y0 = 0; y0 < h; y0 += band)
    for (int y = y0; y < y0 + band; y += kTile)
      for (int x = 0; x < w; x += kTile)
        tiles_.push_back({x, y, std::min(kTile, w - x), std::min(kTile, y0 + band - y)});
}

void Progress::tile_done(int map, const Tile& tile) {
  std::lock_guard lock(mutex_);
  ++done_;
  if (hooks_.on_tile) hooks_.on_tile({map, tile.x, tile.y, tile.width, tile.height, done_, total_});
}

void for_each_tile(std::span<const Tile> tiles, const Progress& progress,
                   const std::function<void(const Tile&)>& fn) {
  progress.check();
  tbb::parallel_for(std::size_t(0), tiles.size(), [&](std::size_t i) {
    progress.check();
    FlushDenormals ftz;
    fn(tiles[i]);
  });
  progress.check();
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

ComputedMapSet joint_result(std::vector<EnvMap> maps, std::chrono::steady_clock::time_point t0,
                    std::vector<std::string> plans) {
  ComputedMapSet result;
  const double share = seconds_since(t0) / double(std::max<std::size_t>(1, maps.size()));
  result.seconds.assign(maps.size(), share);
  result.maps = std::move(maps);
  result.plans = std::move(plans);
  return result;
}

std::vector<EnvMap> blank_maps(const Job& job) {
  return std::vector<EnvMap>(job.shininess.size(), EnvMap(job.output.layout()));
}

std::vector<int> ascending_order(std::span<const double> shininess) {
  std::vector<int> order(shininess.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return shininess[std::size_t(a)] < shininess[std::size_t(b)];
  });
  return order;
}

double lobe_sigma(double s) {
  // E[theta^2] under the density cos^s(theta) sin(theta) on [0, pi/2], by Simpson's rule over
  // the range where the lobe is not negligible; sigma per axis = sqrt(E / 2).
  const double hi = std::min(std::numbers::pi / 2, 14.0 / std::sqrt(s));
  constexpr int kSteps = 2000;
  const double h = hi / kSteps;
  double m0 = 0.0, m2 = 0.0;
  for (int i = 0; i <= kSteps; ++i) {
    const double t = i * h, wgt = (i == 0 || i == kSteps) ? 1.0 : (i % 2 ? 4.0 : 2.0);
    const double f = std::pow(std::max(0.0, std::cos(t)), s) * std::sin(t) * wgt;
    m0 += f, m2 += f * t * t;
  }
  return std::sqrt(m2 / m0 / 2.0);
}

}  // namespace detail

std::string MethodSpec::name() const {
  switch (method) {
    case Method::Accurate:
      return "accurate";
    case Method::Mipmap:
      return "mipmap";
    case Method::Sh:
      return "sh:" + std::to_string(sh_order);
    case Method::Bounded:
      return "bounded";
    case Method::Importance:
      return "importance:" + std::to_string(samples);
    case Method::Auto:
      return "auto";
  }
  return "?";
}

MethodSpec parse_method(std::string_view text, int default_sh_order, int default_samples) {
  const std::string valid =
      "accurate, mipmap, sh, sh:N (N = 1..128), bounded, importance, importance:K (K = "
      "1..65536), auto";
  auto bad = [&](const std::string& why) {
    return InputError("method '" + std::string(text) + "': " + why + " (valid: " + valid + ")");
  };
  const std::size_t colon = text.find(':');
  const std::string_view head = text.substr(0, colon);
  MethodSpec spec;
  spec.sh_order = default_sh_order;
  spec.samples = default_samples;
  if (head == "accurate")
    spec.method = Method::Accurate;
  else if (head == "mipmap")
    spec.method = Method::Mipmap;
  else if (head == "sh")
    spec.method = Method::Sh;
  else if (head == "bounded")
    spec.method = Method::Bounded;
  else if (head == "importance")
    spec.method = Method::Importance;
  else if (head == "auto")
    spec.method = Method::Auto;
  else
    throw bad("unknown method");
  if (colon != std::string_view::npos) {
    const std::string_view arg = text.substr(colon + 1);
    int value = 0;
    const auto [end, ec] = std::from_chars(arg.data(), arg.data() + arg.size(), value);
    if (ec != std::errc() || end != arg.data() + arg.size())
      throw bad("'" + std::string(arg) + "' is not a whole number");
    if (spec.method == Method::Sh) {
      if (value < 1 || value > 128) throw bad("SH order out of range");
      spec.sh_order = value;
    } else if (spec.method == Method::Importance) {
      if (value < 1 || value > 65536) throw bad("sample count out of range");
      spec.samples = value;
    } else {
      throw bad("'" + std::string(head) + "' takes no parameter");
    }
  }
  if (spec.sh_order < 1 || spec.sh_order > 128) throw bad("SH order out of range");
  if (spec.samples < 1 || spec.samples > 65536) throw bad("sample count out of range");
  return spec;
}

namespace detail {

void check_shininess(std::span<const double> shininess) {
  if (shininess.empty()) throw std::invalid_argument("no shininess given");
  for (double s : shininess)
    if (!(s >= 1.0) || !std::isfinite(s))
      throw std::invalid_argument("shininess " + std::to_string(s) + " is not a number >= 1");
}

ComputedMapSet compute(const EnvMap& input, std::span<const double> shininess, const OutputTexels& texels,
               const MethodSpec& method, const Hooks& hooks, AutoMemory* memory) {
  check_shininess(shininess);
  const auto t0 = std::chrono::steady_clock::now();
  Progress progress(hooks, texels.tiles().size() * shininess.size());
  const Job job{input, {shininess.begin(), shininess.end()}, texels, method, progress};
  ComputedMapSet result;
  switch (method.method) {
    case Method::Accurate:
      result = run_direct(job, false);
      break;
    case Method::Bounded:
      result = run_direct(job, true);
      break;
    case Method::Mipmap:
      result = run_mipmap(job);
      break;
    case Method::Sh:
      result = run_sh(job);
      break;
    case Method::Importance:
      result = run_importance(job);
      break;
    case Method::Auto:
      result = run_auto(job, memory);
      break;
  }
  result.shininess = job.shininess;
  result.total_seconds = seconds_since(t0);
  return result;
}

}  // namespace detail

ComputedMapSet compute_maps(const EnvMap& input, std::span<const double> shininess, const EnvLayout& output,
                    const MethodSpec& method, const Hooks& hooks) {
  return detail::compute(input, shininess, detail::OutputTexels(output), method, hooks, nullptr);
}

MapError map_error(const EnvMap& reference, const EnvMap& test) {
  if (!(reference.layout == test.layout))
    throw std::invalid_argument("map_error: the maps have different layouts");
  const auto table = texel_table(reference.layout);
  const float* a = reference.image.data();
  const float* v = test.image.data();
  double mean_ref = 0.0;
  for (std::size_t i = 0; i < table->size(); ++i)
    for (int c = 0; c < 3; ++c) mean_ref += a[3 * std::size_t(table->index[i]) + c];
  const double n = 3.0 * double(table->size());
  mean_ref /= n;
  // An all-black reference: any difference counts in full, none counts as 0.
  const double eps = std::max(1e-4 * mean_ref, 1e-30);
  MapError e;
  double sum = 0.0;
  for (std::size_t i = 0; i < table->size(); ++i)
    for (int c = 0; c < 3; ++c) {
      const std::size_t k = 3 * std::size_t(table->index[i]) + c;
      const double rel = std::abs(double(a[k]) - double(v[k])) / (double(a[k]) + eps);
      sum += rel;
      e.max = std::max(e.max, rel);
    }
  e.mean = n > 0 ? sum / n : 0.0;
  return e;
}

}  // namespace arlight::lighting
