// Lighting before the sweep is done: an estimate of the radiance of the directions the capture
// has not seen yet, fitted to the ones it has (issue 16 §1). Unseen texels used to count as
// black, so an object lit from a quarter-swept room came out far too dark.
//
// The model, in the world frame (+Y up), is an elevation profile plus a low-order residual:
//
//     L(d) = max(0, Z(d.y) + sum_{l < N, m} a_lm Y_lm(d))
//
//   Z      the dissertation's hemisphere lighting (§5.4.1: a sky/ceiling colour above, a
//          ground colour below, each the mean of what was seen of it, its colour prior §5.1),
//          refined from two hemispheres to `zones` equal-area elevation zones: a seen zone
//          takes the mean of what was seen of it; between seen zones Z is linear; beyond the
//          outermost seen zone it continues that zone's colour, rising or falling with the
//          trend of the last seen zones (at most a factor `trend_limit`), so the ceiling or
//          sky of a room swept at the horizon is its upper edge's colour, and the floor its
//          lower edge's. Further below, the floor leans towards a Lambertian ground of albedo
//          `ground_albedo` lit by the upper hemisphere (albedo / pi * E_up), as far as E_up
//          was measured: a room swept ceiling first gets its floor from its lamps or sky.
//   a_lm   a least-squares fit of SH of order N to what Z leaves over on the seen directions,
//          weighted by solid angle x confidence, with a Tikhonov penalty ridge * (1 + l(l+1))
//          that pulls the fit towards Z where the data say little (the unseen side).
//
// Both see the seen radiance with its lights clipped: texels above the `clip_quantile`
// quantile of the seen luminance enter at that luminance. A lamp or the sun that was seen is
// measured where it is; spread over the unseen part it would light objects several times too
// brightly (the mean fill of bench/RESULTS.md), while a light that was not seen yet cannot be
// guessed by any prior.
//
// Confidence of a measured texel: min(1, sum of its weights), where one well-exposed pixel
// weighs at most 1. Measured texels replace the estimate outright (filled maps keep every
// measured texel as it is); the confidence only weighs the fit.
//
// The fit runs on a coarse equal-area grid (zones x 2 zones of azimuth) whose cells aggregate
// the texels, so it costs one pass over the map plus a few thousand cells whatever the layout.
// Thread safety: an UnseenEstimator is a value; const members may run concurrently.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "arlight/common/image.hpp"
#include "arlight/common/projection.hpp"
#include "arlight/common/sh.hpp"

namespace arlight::capture {

// What unseen texels hold: none = black (the map as measured), mean = the mean radiance of
// the seen texels (a baseline), estimate = the model above.
enum class Fill { None, Mean, Estimate };
std::string_view fill_name(Fill fill);                  // "none", "mean", "estimate"
std::optional<Fill> parse_fill(std::string_view name);  // std::nullopt for anything else
// The same for a name from a user: InputError "<what>: expected none, mean or estimate, got
// '<name>'" (without "<what>: " when `what` is empty) for anything else.
Fill fill_from_name(std::string_view name, std::string_view what);

struct FillOptions {
  int zones = 32;  // equal-area elevation zones of the profile Z (and of the grid)
  // Seen texels brighter than this quantile of the seen luminance (by solid angle) enter the
  // fit at that luminance, their colour kept: a light that was seen is not spread over the
  // unseen part (1 = no limit).
  double clip_quantile = 0.9;
  double trend_limit = 2.0;  // how far beyond the seen zones Z may rise or fall (a factor)
  int trend_zones = 4;       // seen zones the trend is fitted to
  // The albedo of the unseen ground the profile leans towards below the lowest seen zone
  // (albedo / pi times the upper hemisphere's irradiance; 0 = the continuation alone).
  double ground_albedo = 0.1;
  int residual_order = 3;    // N: SH bands 0..N-1 of the residual; 0 = the profile alone
  double ridge = 1.0;        // Tikhonov weight, in steradians (the fit's weights sum to <= 4 pi)
};

// The accumulators a capture keeps, in a layout's texel order: sum(w L) (3 floats a texel)
// and sum(w) (1 float a texel; > 0 = measured). A plain map whose unseen texels are marked
// passes its radiance with w = 1 on the measured texels and 0 elsewhere.
struct MeasuredTexels {
  std::span<const float> weighted_radiance;
  std::span<const float> weight;
};

class UnseenEstimator {
 public:
  // Throws std::invalid_argument for options out of range: zones in [2, 256], residual order
  // in [0, 8], ridge > 0 when residual_order > 0, clip_quantile in (0, 1], trend_limit >= 1,
  // trend_zones >= 2, ground_albedo in [0, 1].
  UnseenEstimator(const EnvLayout& layout, Fill fill, FillOptions options = {});
  ~UnseenEstimator();
  UnseenEstimator(const UnseenEstimator&);
  UnseenEstimator& operator=(const UnseenEstimator&);
  UnseenEstimator(UnseenEstimator&&) noexcept;
  UnseenEstimator& operator=(UnseenEstimator&&) noexcept;

  // Refits the model to a map's measured texels. Throws std::invalid_argument when the spans
  // do not fit the layout. Texels with non-finite or negative values count as unseen.
  void fit(const MeasuredTexels& measured);

  Fill fill() const;
  const EnvLayout& layout() const;
  // The model's radiance towards dir (unit); 0 everywhere for Fill::None or before anything
  // was seen.
  glm::dvec3 radiance(glm::dvec3 dir) const;
  // Fractions of the sphere's solid angle measured (sum(w) > 0) and estimated at the last fit;
  // they sum to 1 except for Fill::None or an empty map, where nothing is estimated.
  double measured_fraction() const;
  double estimated_fraction() const;

  // SH (of `order`) of the model over the unseen solid angle only, integrated on the coarse
  // grid (each cell's unseen solid angle times the model and the basis at the cell's mean
  // direction): sh of the measured map (unseen = 0) plus this is the SH of the filled map, to
  // within 0.5 % of its DC term at order 8 (Fill.TheCaptureSessionsShIsThatOfItsFilledMap).
  ShCoeffs unseen_sh(int order) const;

  // Keeps an unseen_sh() of this fit true as the map grows without a refit: `unseen` loses
  // what the given texels (layout indices, measured since the fit) held of it, each texel's
  // solid angle at its cell's model value and direction as unseen_sh() integrates them, so
  // it stays the SH of the model over what is still unseen. Throws std::invalid_argument for
  // an index outside the layout or an order other than `unseen`'s.
  void remove_from_unseen_sh(ShCoeffs& unseen, std::span<const std::uint32_t> texels) const;

  // The filled map: each measured texel's sum(w L) / sum(w), the model on the others (and 0
  // outside an angle map's disk). All cores.
  EnvMap filled(const MeasuredTexels& measured) const;

  // The last fit on the coarse grid (zones x 2 zones cells of equal solid angle, row-major from
  // the bottom zone): what the uncertainty of the light (arlight/capture/uncertainty.hpp) is
  // estimated from. Valid until the next fit(); empty spans for Fill::None.
  struct Cells {
    int zones = 0, sectors = 0;
    std::span<const glm::dvec3> direction;      // the cell's mean direction (0 if it has none)
    std::span<const double> solid_angle;        // of its texels
    std::span<const double> seen;               // of that, measured
    std::span<const glm::dvec3> seen_radiance;  // mean measured radiance there, lights unclipped
    std::span<const glm::dvec3> model;          // the model at the cell's direction
  };
  Cells cells() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The filled map of a plain image whose unseen texels are black (all three channels exactly
// 0): what arlight-maps does with a capture written with --fill none.
EnvMap fill_black_texels(const EnvMap& env, Fill fill, const FillOptions& options = {});

}  // namespace arlight::capture
