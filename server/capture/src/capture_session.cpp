#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "capture_impl.hpp"

namespace arlight::capture {

CaptureSession::CaptureSession(const CameraIntrinsics& camera, CameraResponse response,
                               CaptureOptions options)
    : impl_(std::make_unique<Impl>(camera, std::move(response), std::move(options))) {}
CaptureSession::~CaptureSession() = default;
CaptureSession::CaptureSession(CaptureSession&&) noexcept = default;
CaptureSession& CaptureSession::operator=(CaptureSession&&) noexcept = default;

FrameResult CaptureSession::add_encoded(std::span<const std::uint8_t> bytes, const FrameInfo& info,
                                        int device) {
  Device& d = impl_->device(device);
  ++impl_->added;
  if (auto glanced = impl_->glance(d, bytes, info)) return std::move(*glanced);
  FrameResult result;
  const auto t0 = Clock::now();
  // A frame of the camera's size, or reduced by a power of two up to frame_reduction(); the
  // JPEG decoder reduces it the rest of the way in the DCT domain (fast_decode), since the map
  // and the alignment need no more.
  const int most = d.reduction;
  std::vector<JpegSize> sizes;
  for (int k = 1; k <= most; k *= 2)
    sizes.push_back({.width = d.camera.width / k,
                     .height = d.camera.height / k,
                     .scale = impl_->options.fast_decode ? most / k : 1});
  std::string why;
  std::size_t which = 0;
  const cv::Mat image = decode_jpeg_bgr(bytes, sizes, which, why);
  result.decode_ms = ms_since(t0);
  if (image.empty()) {
    result.skipped_reason =
        "cannot decode the image (" + std::to_string(bytes.size()) + " bytes): " + why;
    return result;
  }
  const int sent_reduced = 1 << which;  // sizes[k] is the camera's size / 2^k
  return impl_->add(d, image, info, result, sent_reduced * sizes[which].scale);
}

int CaptureSession::frame_reduction(int device) const { return impl_->device(device).reduction; }

FrameResult CaptureSession::add_image(const cv::Mat& bgr8, const FrameInfo& info, int device) {
  Device& d = impl_->device(device);
  ++impl_->added;
  for (int k = 2; k <= d.reduction; k *= 2)  // a reduced frame
    if (bgr8.cols == d.camera.width / k && bgr8.rows == d.camera.height / k)
      return impl_->add(d, bgr8, info, FrameResult{}, k);
  return impl_->add(d, bgr8, info, FrameResult{});
}

const EnvLayout& CaptureSession::layout() const { return impl_->options.layout; }
const CameraIntrinsics& CaptureSession::camera(int device) const {
  return impl_->device(device).camera;
}
const CameraResponse& CaptureSession::response(int device) const {
  return impl_->device(device).response;
}
const CaptureOptions& CaptureSession::options() const { return impl_->options; }

EnvMap CaptureSession::environment() const {
  if (impl_->options.fill == Fill::None) return measured_environment();
  impl_->refit_unseen();
  return impl_->unseen.filled({impl_->weighted_radiance, impl_->weight});
}

CaptureSession::Reduced CaptureSession::reduced_environment(const EnvLayout& to) const {
  const EnvLayout& from = impl_->options.layout;
  if (from.projection() != Projection::Cube || to.projection() != Projection::Cube ||
      to.face_size() > from.face_size() || from.face_size() % to.face_size() != 0)
    return {reduce(environment(), to), measured_share(from, impl_->weight, to)};
  const bool fill = impl_->options.fill != Fill::None;
  if (fill) impl_->refit_unseen();
  const int k = from.face_size() / to.face_size();
  // Every texel of a cube map is on the sphere, so its table is in texel order (the preview
  // of every map set used to copy it, 3 MB, on the frame's path).
  const std::vector<double>& omega = impl_->table->solid_angle;
  Reduced out{EnvMap(to), std::vector<float>(to.texel_count(), 0.0f)};
  const std::size_t w = std::size_t(from.width());
  for (int y = 0; y < to.height(); ++y)
    for (int x = 0; x < to.width(); ++x) {
      glm::dvec3 seen(0.0);
      double seen_omega = 0.0, all_omega = 0.0;
      for (int j = 0; j < k; ++j)
        for (int i = 0; i < k; ++i) {
          const std::size_t t = std::size_t(y * k + j) * w + std::size_t(x * k + i);
          all_omega += omega[t];
          if (!(impl_->weight[t] > 0.0f)) continue;
          seen += omega[t] * glm::dvec3(impl_->texel_radiance(t));
          seen_omega += omega[t];
        }
      const std::size_t at = std::size_t(y) * std::size_t(to.width()) + std::size_t(x);
      glm::dvec3 value = seen;
      if (fill && seen_omega < all_omega)
        value += (all_omega - seen_omega) * impl_->unseen.radiance(to.texel_dir(x, y));
      value /= all_omega;
      for (int c = 0; c < 3; ++c) out.env.image.data()[3 * at + std::size_t(c)] = float(value[c]);
      out.measured[at] = float(seen_omega / all_omega);
    }
  return out;
}

EnvMap CaptureSession::measured_environment() const {
  EnvMap env(impl_->options.layout);
  float* out = env.image.data();
  for (std::size_t t = 0; t < impl_->weight.size(); ++t) {
    const glm::vec3 l = impl_->texel_radiance(t);
    out[3 * t] = l.x, out[3 * t + 1] = l.y, out[3 * t + 2] = l.z;
  }
  return env;
}

std::vector<float> CaptureSession::weights() const { return impl_->weight; }

double CaptureSession::coverage() const {
  return impl_->covered_solid_angle / (4.0 * std::numbers::pi);
}

double CaptureSession::estimated_fraction() const {
  if (impl_->options.fill == Fill::None) return 0.0;
  impl_->refit_unseen();
  // The last fit's, less what was measured since (what remains for its model).
  return impl_->unseen.estimated_fraction() > 0.0 ? std::max(0.0, 1.0 - coverage()) : 0.0;
}

const ShCoeffs& CaptureSession::sh() const {
  if (impl_->options.fill == Fill::None) return impl_->sh;
  impl_->refit_unseen();
  return impl_->filled_sh;
}

const ShCoeffs& CaptureSession::measured_sh() const { return impl_->sh; }

const LightUncertainty& CaptureSession::uncertainty() const {
  Impl& m = *impl_;
  if (m.options.fill == Fill::None) return m.light_uncertainty;
  m.refit_unseen();
  if (m.uncertainty_fit != m.fits || m.uncertainty_clips != m.clipped_frames) {
    // The seen texels whose light is still hidden by clipping (check_clipped's test).
    std::vector<ClippedTexel> clipped;
    const TexelTable& table = *m.table;
    for (std::size_t i = 0; i < table.size(); ++i) {
      const std::size_t t = table.index[i];
      const float floor = m.clip_floor[t];
      if (!(floor > 0.0f) || !(m.weight[t] > 0.0f)) continue;
      const glm::vec3 l = m.texel_radiance(t);
      if (std::max({l.x, l.y, l.z}) >= Impl::kMeasuredShare * floor) continue;
      clipped.push_back({{table.x[i], table.y[i], table.z[i]},
                         table.solid_angle[i],
                         luminance(l),
                         double(floor)});
    }
    m.light_uncertainty = LightUncertainty(m.unseen.cells(), m.options.uncertainty, clipped);
    m.uncertainty_fit = m.fits, m.uncertainty_clips = m.clipped_frames;
  }
  return m.light_uncertainty;
}

std::size_t CaptureSession::frames_added() const { return impl_->added; }
std::size_t CaptureSession::fill_fits() const { return impl_->fits; }
std::size_t CaptureSession::frames_used() const { return impl_->used; }

Accumulators CaptureSession::accumulators() const {
  return {impl_->weighted_radiance, impl_->weight};
}

void CaptureSession::restore(const Accumulators& acc) {
  Impl& s = *impl_;
  if (acc.weight.size() != s.weight.size() ||
      acc.weighted_radiance.size() != s.weighted_radiance.size())
    throw std::invalid_argument("capture: accumulators of " + std::to_string(acc.weight.size()) +
                                " texels do not fit a map of " + std::to_string(s.weight.size()));
  for (std::size_t t = 0; t < acc.weight.size(); ++t)
    if (!std::isfinite(acc.weight[t]) || acc.weight[t] < 0.0f ||
        !std::isfinite(acc.weighted_radiance[3 * t]) ||
        !std::isfinite(acc.weighted_radiance[3 * t + 1]) ||
        !std::isfinite(acc.weighted_radiance[3 * t + 2]))
      throw std::invalid_argument(
          "capture: accumulators hold a non-finite or negative value at "
          "texel " +
          std::to_string(t));
  s.weighted_radiance = acc.weighted_radiance;
  s.weight = acc.weight;
  std::fill(s.clip_floor.begin(), s.clip_floor.end(), 0.0f);
  s.covered_solid_angle = 0.0;
  for (std::size_t i = 0; i < s.table->size(); ++i)
    if (s.weight[s.table->index[i]] > 0.0f) s.covered_solid_angle += s.table->solid_angle[i];
  s.sh = sh_project(measured_environment(), s.options.sh_order);
  s.unseen_stale = true;
  if (s.devices.front()->glancer) s.devices.front()->glancer->touch_all();  // its only one
}

EnvLayout capture_layout_for(int n) {
  return EnvLayout::for_size(Projection::Cube, std::max(8, (3 * n / 8 + 4) / 8 * 8));
}

std::vector<float> measured_share(const EnvLayout& layout, std::span<const float> weights,
                                  const EnvLayout& reduced) {
  if (weights.size() != layout.texel_count())
    throw std::invalid_argument("capture: " + std::to_string(weights.size()) +
                                " weights for a map of " + std::to_string(layout.texel_count()) +
                                " texels");
  EnvMap seen(layout);
  for (std::size_t i = 0; i < weights.size(); ++i)
    if (weights[i] > 0.0f)
      for (int c = 0; c < 3; ++c) seen.image.data()[3 * i + std::size_t(c)] = 1.0f;
  const EnvMap share = arlight::reduce(seen, reduced);
  std::vector<float> out(reduced.texel_count());
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = share.image.data()[3 * i];
  return out;
}

Accumulators convert_accumulators(const Accumulators& acc, const EnvLayout& from,
                                  const EnvLayout& to) {
  if (acc.weight.size() != from.texel_count() ||
      acc.weighted_radiance.size() != 3 * from.texel_count())
    throw std::invalid_argument("capture: accumulators of " + std::to_string(acc.weight.size()) +
                                " texels do not fit a " + std::to_string(from.width()) + "x" +
                                std::to_string(from.height()) + " map");
  if (from == to) return acc;
  Accumulators out;
  out.weight.assign(to.texel_count(), 0.0f);
  out.weighted_radiance.assign(3 * to.texel_count(), 0.0f);
  const TexelTable& table = *texel_table(to);
  for (std::size_t i = 0; i < table.size(); ++i) {
    const glm::ivec2 p = from.dir_to_texel({table.x[i], table.y[i], table.z[i]});
    const std::size_t s = std::size_t(std::clamp(p.y, 0, from.height() - 1)) * from.width() +
                          std::size_t(std::clamp(p.x, 0, from.width() - 1));
    const std::size_t t = table.index[i];
    out.weight[t] = acc.weight[s];
    std::copy_n(&acc.weighted_radiance[3 * s], 3, &out.weighted_radiance[3 * t]);
  }
  return out;
}

}  // namespace arlight::capture
