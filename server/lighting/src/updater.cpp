// MapUpdater: maps that follow a changing environment (issue 16 §3). It finds the input texels
// that changed, groups them in cones, and lets method auto recompute what those reach
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

namespace {

// Changed texels are grouped by the cells of this cube grid (~4 degrees at most from a cell's
// centre): fine enough that a cone's radius adds little to a lobe's window, coarse enough that
// testing a block of outputs against every changed cone costs little.
constexpr int kChangeFace = 16;

}  // namespace

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
  if (!measured.empty() && measured.size() != input.layout.texel_count())
    throw std::invalid_argument("MapUpdater: " + std::to_string(measured.size()) +
                                " measured shares for " +
                                std::to_string(input.layout.texel_count()) + " texels");
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
    const auto table = texel_table(input.layout);
    const float* now = input.image.data();
    float* was = base.image.data();
    double mean_y = 0.0;
    for (std::size_t i = 0; i < table->size(); ++i) {
      const float* p = now + 3 * std::size_t(table->index[i]);
      mean_y += table->solid_angle[i] * luminance(glm::dvec3(p[0], p[1], p[2]));
    }
    mean_y /= 4.0 * std::numbers::pi;
    const double tolerance = st.tolerance, floor = 0.1 * mean_y;
    memory.tolerance = tolerance, memory.mean = mean_y;
    // The changed texels' directions, summed per cell of a coarse cube grid.
    const EnvLayout cells = EnvLayout::for_size(Projection::Cube, kChangeFace);
    std::vector<glm::dvec3> sum(cells.texel_count(), glm::dvec3(0.0));
    std::vector<std::uint32_t> cell_of;
    std::vector<std::size_t> moved;
    for (std::size_t i = 0; i < table->size(); ++i) {
      const std::size_t at = 3 * std::size_t(table->index[i]);
      const double estimated =
          measured.empty() ? 0.0 : 1.0 - std::clamp(double(measured[table->index[i]]), 0.0, 1.0);
      const double texel_tolerance = tolerance * (1.0 + (kEstimatedTolerance - 1.0) * estimated);
      bool changed = false;
      for (int c = 0; c < 3; ++c)
        changed |=
            std::abs(double(now[at + c]) - was[at + c]) >
            texel_tolerance * (std::max(std::abs(now[at + c]), std::abs(was[at + c])) + floor);
      // A texel that is not finite cannot be compared; it counts as changed.
      for (int c = 0; c < 3; ++c) changed |= !std::isfinite(now[at + c]);
      if (!changed) continue;
      double moved_by = 0.0;
      for (int c = 0; c < 3; ++c) {
        moved_by = std::max(moved_by, std::abs(double(now[at + c]) - was[at + c]));
        was[at + c] = now[at + c];
      }
      memory.changed_power += std::isfinite(moved_by) ? moved_by * table->solid_angle[i]
                                                      : std::numeric_limits<double>::infinity();
      const glm::dvec3 d(table->x[i], table->y[i], table->z[i]);
      const glm::ivec2 t = cells.dir_to_texel(d);
      const std::uint32_t cell = std::uint32_t(t.y * cells.width() + t.x);
      sum[cell] += d;
      moved.push_back(i);
      cell_of.push_back(cell);
    }
    st.changed = double(moved.size()) / double(std::max<std::size_t>(1, table->size()));
    // Each cell's cone: its changed texels' mean direction and the widest angle to one of them.
    std::vector<double> min_cos(cells.texel_count(), 1.0);
    for (glm::dvec3& s : sum)
      if (glm::dot(s, s) > 0.0) s = glm::normalize(s);
    for (std::size_t m = 0; m < moved.size(); ++m) {
      const std::size_t i = moved[m];
      const glm::dvec3 d(table->x[i], table->y[i], table->z[i]);
      min_cos[cell_of[m]] = std::min(min_cos[cell_of[m]], glm::dot(sum[cell_of[m]], d));
    }
    for (std::size_t c = 0; c < sum.size(); ++c)
      if (glm::dot(sum[c], sum[c]) > 0.0) {
        memory.changed.push_back(sum[c]);
        memory.max_radius =
            std::max(memory.max_radius, std::acos(std::clamp(min_cos[c], -1.0, 1.0)) + 1e-9);
      }
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
