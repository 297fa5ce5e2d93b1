// Where an environment changed since the last time maps were made from it: the input side of
// MapUpdater and GgxUpdater (issue 16 §3, issue 34 §2).
#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "job.hpp"

namespace arlight::lighting::detail {

namespace {

// Changed texels are grouped by the cells of this cube grid (~4 degrees at most from a cell's
// centre): fine enough that a cone's radius adds little to a lobe's window, coarse enough that
// testing a block of outputs against every changed cone costs little.
constexpr int kChangeFace = 16;

}  // namespace

void check_measured(const EnvMap& input, std::span<const float> measured, const char* who) {
  if (!measured.empty() && measured.size() != input.layout.texel_count())
    throw std::invalid_argument(std::string(who) + ": " + std::to_string(measured.size()) +
                                " measured shares for " +
                                std::to_string(input.layout.texel_count()) + " texels");
}

InputChanges find_changes(const EnvMap& input, EnvMap& base, double tolerance,
                          std::span<const float> measured, double estimated_tolerance) {
  InputChanges out;
  const auto table = texel_table(input.layout);
  const float* now = input.image.data();
  float* was = base.image.data();
  double mean_y = 0.0;
  for (std::size_t i = 0; i < table->size(); ++i) {
    const float* p = now + 3 * std::size_t(table->index[i]);
    mean_y += table->solid_angle[i] * luminance(glm::dvec3(p[0], p[1], p[2]));
  }
  mean_y /= 4.0 * std::numbers::pi;
  out.mean = mean_y;
  const double floor = 0.1 * mean_y;
  // The changed texels' directions and change, summed per cell of a coarse cube grid.
  const EnvLayout cells = EnvLayout::for_size(Projection::Cube, kChangeFace);
  std::vector<glm::dvec3> sum(cells.texel_count(), glm::dvec3(0.0));
  std::vector<double> power(cells.texel_count(), 0.0);
  std::vector<std::uint32_t> cell_of;
  std::vector<std::size_t> moved;
  for (std::size_t i = 0; i < table->size(); ++i) {
    const std::size_t at = 3 * std::size_t(table->index[i]);
    const double estimated =
        measured.empty() ? 0.0 : 1.0 - std::clamp(double(measured[table->index[i]]), 0.0, 1.0);
    const double texel_tolerance = tolerance * (1.0 + (estimated_tolerance - 1.0) * estimated);
    bool changed = false;
    for (int c = 0; c < 3; ++c)
      changed |= std::abs(double(now[at + c]) - was[at + c]) >
                 texel_tolerance * (std::max(std::abs(now[at + c]), std::abs(was[at + c])) + floor);
    // A texel that is not finite cannot be compared; it counts as changed.
    for (int c = 0; c < 3; ++c) changed |= !std::isfinite(now[at + c]);
    if (!changed) continue;
    double moved_by = 0.0;
    for (int c = 0; c < 3; ++c) {
      moved_by = std::max(moved_by, std::abs(double(now[at + c]) - was[at + c]));
      was[at + c] = now[at + c];
    }
    const double texel_power = std::isfinite(moved_by) ? moved_by * table->solid_angle[i]
                                                       : std::numeric_limits<double>::infinity();
    out.changed_power += texel_power;
    const glm::dvec3 d(table->x[i], table->y[i], table->z[i]);
    const glm::ivec2 t = cells.dir_to_texel(d);
    const std::uint32_t cell = std::uint32_t(t.y * cells.width() + t.x);
    sum[cell] += d;
    power[cell] += texel_power;
    moved.push_back(i);
    cell_of.push_back(cell);
  }
  out.share = double(moved.size()) / double(std::max<std::size_t>(1, table->size()));
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
      const double radius = std::acos(std::clamp(min_cos[c], -1.0, 1.0)) + 1e-9;
      out.centre.push_back(sum[c]);
      out.radius.push_back(radius);
      out.power.push_back(power[c]);
      out.max_radius = std::max(out.max_radius, radius);
    }
  return out;
}

}  // namespace arlight::lighting::detail
