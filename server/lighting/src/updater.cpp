// MapUpdater: maps that follow a changing environment (issue 16 §3). It finds the input texels
// that changed, grouped in cones (changes.cpp), and lets method auto recompute what those reach
// (auto.cpp, AutoMemory).
#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <limits>
#include <numbers>
#include <optional>

#include "arlight/common/image.hpp"
#include "job.hpp"

namespace arlight::lighting {

struct MapUpdater::State {
  std::vector<double> shininess;
  detail::OutputTexels output;
  MethodSpec method;
  double tolerance;
  std::optional<EnvMap> base;  // per texel, the value it had when it last counted as changed
  detail::AutoMemory memory;
  ComputedMapSet last;
  std::vector<double> recomputed;
  double changed = 1.0;
};

MapUpdater::MapUpdater(std::vector<double> shininess, const EnvLayout& output, MethodSpec method,
                       double tolerance) {
  detail::check_shininess(shininess);
  if (!(tolerance >= 0.0) || !std::isfinite(tolerance))
    throw std::invalid_argument("tolerance " + std::to_string(tolerance) + " is not >= 0");
  state_ = std::make_unique<State>(State{std::move(shininess),
                                         detail::OutputTexels(output),
                                         method,
                                         tolerance,
                                         std::nullopt,
                                         {},
                                         {},
                                         {},
                                         1.0});
}

MapUpdater::~MapUpdater() = default;
MapUpdater::MapUpdater(MapUpdater&&) noexcept = default;
MapUpdater& MapUpdater::operator=(MapUpdater&&) noexcept = default;

std::span<const double> MapUpdater::recomputed() const { return state_->recomputed; }
double MapUpdater::changed() const { return state_->changed; }

const ComputedMapSet& MapUpdater::update(const EnvMap& input, const Hooks& hooks,
                                 std::span<const float> measured) {
  detail::check_measured(input, measured, "MapUpdater");
  State& st = *state_;
  detail::AutoMemory& memory = st.memory;
  const bool follow = st.method.method == Method::Auto && memory.valid && st.base &&
                      st.base->layout == input.layout;
  EnvMap base = follow ? *st.base : input;
  memory.valid = follow;
  memory.changed.clear();
  memory.max_radius = 0.0;
  memory.changed_power = 0.0;
  st.changed = 1.0;
  if (follow) {
    const detail::InputChanges changes =
        detail::find_changes(input, base, st.tolerance, measured, kEstimatedTolerance);
    memory.tolerance = st.tolerance, memory.mean = changes.mean;
    memory.changed = changes.centre;
    memory.max_radius = changes.max_radius;
    memory.changed_power = changes.changed_power;
    st.changed = changes.share;
  }
  try {
    st.last = detail::compute(input, st.shininess, st.output, st.method, hooks,
                              st.method.method == Method::Auto ? &memory : nullptr);
  } catch (...) {
    memory.valid = false;  // the next update computes everything
    throw;
  }
  st.base = std::move(base);
  st.recomputed = memory.valid && st.method.method == Method::Auto
                      ? memory.recomputed
                      : std::vector<double>(st.shininess.size(), 1.0);
  return st.last;
}

}  // namespace arlight::lighting
