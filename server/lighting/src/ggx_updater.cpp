// GgxUpdater: the GGX chain of a changing environment (ggx.hpp), recomputing only the output
// tiles a change can move past the tolerance.
#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <optional>

#include "ggx_detail.hpp"

namespace arlight::lighting {

namespace {

// One level's tiles as the updater judges them: a cone (centre, radius tau) around each tile's
// texels, and the texels' pixels.
struct LevelTiles {
  std::vector<glm::dvec3> centre;
  std::vector<double> tau;
  std::vector<std::vector<std::size_t>> pixels;
};

LevelTiles level_tiles(const EnvLayout& layout) {
  const detail::OutputTexels texels_of = detail::ggx_tiles(layout);
  LevelTiles out;
  for (const detail::Tile& tile : texels_of.tiles()) {
    const detail::TileTexels t = texels_of.collect(tile);
    const detail::TileCone cone = detail::tile_cone(t);
    out.centre.push_back(cone.centre);
    out.tau.push_back(cone.tau);
    out.pixels.push_back(t.pixels);
  }
  return out;
}

}  // namespace

struct GgxUpdater::State {
  GgxChainSpec spec;
  double tolerance = 0.02;
  int levels = 0;
  std::vector<LevelTiles> tiles;           // per level (level 0 unused)
  std::optional<EnvMap> base;              // per texel, the value it had when it last changed
  std::optional<GgxChain> last;
  std::vector<std::vector<float>> debt;    // per level, per tile: the drift skipped so far
  std::vector<double> recomputed;
  double changed = 1.0;
};

GgxUpdater::GgxUpdater(GgxChainSpec spec, double tolerance) : state_(std::make_unique<State>()) {
  if (!(tolerance >= 0.0) || !std::isfinite(tolerance))
    throw std::invalid_argument("tolerance " + std::to_string(tolerance) + " is not >= 0");
  State& st = *state_;
  st.levels = detail::ggx_chain_levels(spec);
  st.spec = spec;
  st.tolerance = tolerance;
  st.tiles.resize(std::size_t(st.levels));
  st.debt.resize(std::size_t(st.levels));
  for (int k = 1; k < st.levels; ++k) {
    const int f = spec.face >> k;
    st.tiles[std::size_t(k)] = level_tiles(EnvLayout(Projection::Cube, f, 6 * f));
    st.debt[std::size_t(k)].assign(st.tiles[std::size_t(k)].centre.size(), 0.0f);
  }
}

GgxUpdater::~GgxUpdater() = default;
GgxUpdater::GgxUpdater(GgxUpdater&&) noexcept = default;
GgxUpdater& GgxUpdater::operator=(GgxUpdater&&) noexcept = default;

std::span<const double> GgxUpdater::recomputed() const { return state_->recomputed; }
double GgxUpdater::changed() const { return state_->changed; }
const GgxChainSpec& GgxUpdater::spec() const { return state_->spec; }

const GgxChain& GgxUpdater::update(const EnvMap& input, const Hooks& hooks,
                                   std::span<const float> measured) {
  detail::check_measured(input, measured, "GgxUpdater");
  State& st = *state_;
  const bool follow = st.last && st.base && st.base->layout == input.layout;
  if (!follow) {
    GgxChain chain = detail::ggx_chain(input, st.spec, hooks, nullptr, nullptr);
    st.base = input;
    st.last = std::move(chain);
    for (auto& d : st.debt) std::fill(d.begin(), d.end(), 0.0f);
    st.recomputed.assign(std::size_t(st.levels), 1.0);
    st.changed = 1.0;
    return *st.last;
  }
  EnvMap base = *st.base;
  const detail::InputChanges changes = detail::find_changes(
      input, base, st.tolerance, measured, MapUpdater::kEstimatedTolerance);
  st.changed = changes.share;
  if (changes.centre.empty()) {  // nothing changed: the last chain stands
    st.recomputed.assign(std::size_t(st.levels), 0.0);
    return *st.last;
  }
  // Which tiles a change can move past the tolerance (their debt included): the value of a tile's
  // texel moves by at most sum over cones of power x the lobe at the cone's nearest approach,
  // over the lobe's integral (the sums' denominator), against the tile's smallest value.
  std::vector<std::vector<char>> redo(std::size_t(st.levels));
  std::vector<std::vector<float>> debt = st.debt;
  std::vector<double> recomputed(std::size_t(st.levels), 1.0);
  const double floor = 0.1 * changes.mean;
  for (int k = 1; k < st.levels; ++k) {
    const LevelTiles& lt = st.tiles[std::size_t(k)];
    const GgxLevel& was = st.last->levels[std::size_t(k)];
    const double scale = 1.0 / detail::ggx_lobe_integral(was.roughness);
    auto& flags = redo[std::size_t(k)];
    flags.assign(lt.centre.size(), 0);
    std::size_t count = 0;
    const float* prev = was.map.image.data();
    for (std::size_t t = 0; t < lt.centre.size(); ++t) {
      if (lt.pixels[t].empty()) continue;
      double least = std::numeric_limits<double>::infinity();
      for (const std::size_t p : lt.pixels[t]) {
        const float* v = prev + 3 * p;
        const double top = std::max({v[0], v[1], v[2]});
        least = std::min(least, std::max(double(std::min({v[0], v[1], v[2]})), 0.01 * top));
      }
      const double budget = st.tolerance * (std::max(least, 0.0) + floor);
      double drift = debt[std::size_t(k)][t];
      for (std::size_t c = 0; c < changes.centre.size() && drift <= budget; ++c) {
        const double angle = std::acos(std::clamp(glm::dot(lt.centre[t], changes.centre[c]), -1.0, 1.0));
        const double nearest = std::max(0.0, angle - lt.tau[t] - changes.radius[c]);
        drift += changes.power[c] * scale * detail::ggx_lobe_value(was.roughness, std::cos(nearest));
      }
      if (drift > budget || !std::isfinite(drift)) {
        flags[t] = 1;
        ++count;
        debt[std::size_t(k)][t] = 0.0f;
      } else {
        debt[std::size_t(k)][t] = float(drift);
      }
    }
    recomputed[std::size_t(k)] = double(count) / double(std::max<std::size_t>(1, lt.centre.size()));
  }
  GgxChain chain = detail::ggx_chain(input, st.spec, hooks, &*st.last, &redo);
  st.base = std::move(base);
  st.last = std::move(chain);
  st.debt = std::move(debt);
  st.recomputed = std::move(recomputed);
  return *st.last;
}

}  // namespace arlight::lighting
