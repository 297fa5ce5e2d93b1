#include "maps_io.hpp"

#include <openssl/evp.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "arlight/capture/fill.hpp"
#include "arlight/common/atomic_file.hpp"
#include "arlight/common/error.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/common/number_list.hpp"
#include "arlight/common/resample.hpp"

namespace arlight::maps {

namespace fs = std::filesystem;

std::vector<double> parse_shininess(const std::string& list) {
  const std::vector<double> out = parse_number_list(list, "--shininess '" + list + "'");
  for (double s : out)
    if (!(s >= 1.0)) {
      std::ostringstream text;
      text << s;
      throw InputError("--shininess '" + list + "': " + text.str() +
                       " is below 1 (1 is the irradiance map, > 1 a Phong lobe cos^s)");
    }
  if (out.empty()) throw InputError("--shininess: empty list");
  return out;
}

Projection parse_projection_arg(const std::string& name) {
  const auto p = parse_projection(name);
  if (!p) throw InputError("--projection '" + name + "': use anglemap, latlong or cube");
  return *p;
}

EnvMap load_working_map(const std::string& path, const EnvLayout& layout, const std::string& fill) {
  LoadedEnvMap probe = load_envmap(path);
  if (!probe.info.sanitized.clean())
    std::fprintf(stderr, "arlight-maps: %s: %s\n", path.c_str(),
                 probe.info.sanitized.summary().c_str());
  const capture::Fill how = capture::fill_from_name(fill, "--fill");
  if (probe.info.metadata.fill == "none" && how != capture::Fill::None)
    probe.env = capture::fill_black_texels(probe.env, how);
  if (probe.env.layout == layout) return std::move(probe.env);
  return resample(probe.env, layout);
}

void check_size(int size, const std::vector<lighting::MethodSpec>& methods) {
  for (const auto& m : methods)
    if (m.method == lighting::Method::Mipmap && (size & (size - 1)) != 0)
      throw InputError("--size " + std::to_string(size) +
                       ": the mipmap method needs a power of two (its MIP chain halves the "
                       "map down to 1x1, thesis eq. 4.1)");
}

std::string file_stem(const lighting::MethodSpec& method) {
  std::string n = method.name();
  std::erase(n, ':');
  return n;
}

std::string shininess_label(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", s);
  return buf;
}

fs::path write_map(const fs::path& dir, const std::string& stem, const EnvMap& map,
                   double shininess, double exposure_stops, const std::string& description) {
  ImageMetadata md;
  md.projection = map.layout.projection();
  md.shininess = shininess;
  md.description = description;
  const fs::path exr = dir / (stem + ".exr");
  write_exr(exr, map.image.view(), md, ExrPixel::Half);
  write_png_preview(dir / (stem + ".png"), map.image.view(), {exposure_stops});
  return exr;
}

namespace {

// Shrinks a map by 2x steps until it is at most `max_width` wide.
Image thumbnail(const Image& img, int max_width) {
  Image t = copy_image(img.view());
  while (t.width() > max_width) t = downsample2x(t.view());
  return t;
}

}  // namespace

void write_contact_sheet(const fs::path& path, const std::vector<SheetRow>& rows,
                         const std::vector<double>& shininess, double exposure_stops) {
  constexpr int kCell = 160, kGap = 4, kLabelW = 150, kLabelH = 22;
  std::vector<std::vector<Image>> thumbs;
  int cell_w = 1, cell_h = 1;
  for (const SheetRow& r : rows) {
    auto& row = thumbs.emplace_back();
    for (const EnvMap& m : *r.maps) {
      row.push_back(thumbnail(m.image, kCell));
      cell_w = std::max(cell_w, row.back().width());
      cell_h = std::max(cell_h, row.back().height());
    }
  }
  const int cols = int(shininess.size());
  const int width = kLabelW + cols * (cell_w + kGap);
  const int height = kLabelH + int(rows.size()) * (cell_h + kGap);
  Image sheet(width, height);
  cv::Mat canvas(height, width, CV_32FC3, sheet.data());
  // Labels are drawn far above white so the preview's tone curve saturates them.
  const cv::Scalar white(1e6, 1e6, 1e6);
  for (int c = 0; c < cols; ++c)
    cv::putText(canvas, "s = " + shininess_label(shininess[std::size_t(c)]),
                {kLabelW + c * (cell_w + kGap) + 4, kLabelH - 6}, cv::FONT_HERSHEY_SIMPLEX, 0.5,
                white, 1, cv::LINE_AA);
  for (std::size_t r = 0; r < rows.size(); ++r) {
    const int y0 = kLabelH + int(r) * (cell_h + kGap);
    cv::putText(canvas, rows[r].name, {6, y0 + cell_h / 2 + 5}, cv::FONT_HERSHEY_SIMPLEX, 0.5,
                white, 1, cv::LINE_AA);
    for (std::size_t c = 0; c < thumbs[r].size(); ++c) {
      const Image& t = thumbs[r][c];
      const int x0 = kLabelW + int(c) * (cell_w + kGap);
      for (int y = 0; y < t.height(); ++y)
        for (int x = 0; x < t.width(); ++x) sheet.set(x0 + x, y0 + y, t.at(x, y));
    }
  }
  write_png_preview(path, sheet.view(), {exposure_stops});
}

void write_json(const fs::path& path, const nlohmann::json& j) {
  if (path.has_parent_path()) fs::create_directories(path.parent_path());
  write_file_atomically(path, j.dump(2) + "\n");
}

ProgressBar::ProgressBar(std::string label) : label_(std::move(label)), tty_(isatty(2) != 0) {}

ProgressBar::~ProgressBar() {
  if (tty_ && last_ >= 0) std::fprintf(stderr, "\r\033[K");
}

lighting::Hooks ProgressBar::hooks() {
  lighting::Hooks h;
  if (!tty_) return h;
  h.on_tile = [this](const lighting::TileDone& t) {
    const int percent = int(100 * t.done / std::max<std::size_t>(1, t.total));
    if (percent == last_) return;
    last_ = percent;
    constexpr int kWidth = 30;
    const int filled = percent * kWidth / 100;
    std::fprintf(stderr, "\r%-14s [%s%s] %3d%%", label_.c_str(),
                 std::string(std::size_t(filled), '#').c_str(),
                 std::string(std::size_t(kWidth - filled), '.').c_str(), percent);
    std::fflush(stderr);
  };
  return h;
}

std::string file_sha256(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError("'" + path.string() + "': cannot read");
  EVP_MD_CTX* ctx = EVP_MD_CTX_new();
  EVP_DigestInit_ex(ctx, EVP_sha256(), nullptr);
  char buf[1 << 16];
  while (f.read(buf, sizeof buf) || f.gcount() > 0)
    EVP_DigestUpdate(ctx, buf, std::size_t(f.gcount()));
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned len = 0;
  EVP_DigestFinal_ex(ctx, md, &len);
  EVP_MD_CTX_free(ctx);
  std::string hex;
  for (unsigned i = 0; i < len; ++i) {
    char b[3];
    std::snprintf(b, sizeof b, "%02x", md[i]);
    hex += b;
  }
  return hex;
}

fs::path default_cache_dir() {
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return fs::path(x) / "arlight";
  if (const char* h = std::getenv("HOME"); h && *h) return fs::path(h) / ".cache" / "arlight";
  return fs::temp_directory_path() / "arlight-cache";
}

}  // namespace arlight::maps
