// What the arlight-maps subcommands share: reading probes and shininess lists, writing maps,
// contact sheets and JSON, the terminal progress bar, the reference cache.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "arlight/common/projection.hpp"
#include "arlight/lighting/lighting.hpp"

namespace arlight::maps {

inline const char* kDefaultShininess = "1,10,20,40,80,160,320,1280";

// "1,10,20" -> {1, 10, 20}; InputError for anything that is not a number >= 1.
std::vector<double> parse_shininess(const std::string& list);

// "anglemap" | "latlong" | "cube"; InputError otherwise.
Projection parse_projection_arg(const std::string& name);

// Loads a probe (reporting sanitized values on stderr) and resamples it to `layout`. A capture
// that arlight-capture wrote with --fill none (its arlight:fill attribute) has its black texels
// filled first, at its own resolution, as `fill` says (none | mean | estimate).
EnvMap load_working_map(const std::string& path, const EnvLayout& layout,
                        const std::string& fill = "estimate");

// Checks --size against the methods: mipmap's MIP chain needs a power of two.
void check_size(int size, const std::vector<lighting::MethodSpec>& methods);

// "sh:35" -> "sh35": a method name usable in file names.
std::string file_stem(const lighting::MethodSpec& method);
std::string shininess_label(double s);  // 10 -> "10", 2.5 -> "2.5"

// Writes DIR/STEM.exr (half float, projection and shininess in the metadata) and DIR/STEM.png.
std::filesystem::path write_map(const std::filesystem::path& dir, const std::string& stem,
                                const EnvMap& map, double shininess, double exposure_stops,
                                const std::string& description);

// One row per method, one column per shininess (as thesis Fig. 6.4), labelled, one exposure.
struct SheetRow {
  std::string name;
  const std::vector<EnvMap>* maps;
};
void write_contact_sheet(const std::filesystem::path& path, const std::vector<SheetRow>& rows,
                         const std::vector<double>& shininess, double exposure_stops);

void write_json(const std::filesystem::path& path, const nlohmann::json& j);

// A progress bar on stderr while tiles finish, only when stderr is a terminal.
class ProgressBar {
 public:
  explicit ProgressBar(std::string label);
  ~ProgressBar();
  lighting::Hooks hooks();

 private:
  std::string label_;
  bool tty_;
  int last_ = -1;
};

// SHA-256 of a file's bytes, hex.
std::string file_sha256(const std::filesystem::path& path);

// Default cache folder: $XDG_CACHE_HOME/arlight, else ~/.cache/arlight, else /tmp/arlight-cache.
std::filesystem::path default_cache_dir();

}  // namespace arlight::maps
