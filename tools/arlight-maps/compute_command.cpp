// arlight-maps compute: one method's irradiance and reflection maps of a probe.
#include <cstdio>
#include <filesystem>
#include <memory>

#include "arlight/common/hdr_io.hpp"
#include "commands.hpp"
#include "maps_io.hpp"

namespace arlight::maps {

namespace {

namespace fs = std::filesystem;

struct ComputeOptions {
  std::string input;
  std::string method = "auto";
  std::string shininess = kDefaultShininess;
  int size = 512;
  std::string projection = "anglemap";
  std::string fill = "estimate";
  int sh_order = 35;
  int samples = 64;
  std::string out = "out/maps";
  std::string json;
};

int run_compute(const ComputeOptions& o) {
  const lighting::MethodSpec method = lighting::parse_method(o.method, o.sh_order, o.samples);
  const std::vector<double> shininess = parse_shininess(o.shininess);
  check_size(o.size, {method});
  const EnvLayout layout = EnvLayout::for_size(parse_projection_arg(o.projection), o.size);
  const EnvMap input = load_working_map(o.input, layout, o.fill);

  lighting::ComputedMapSet set;
  {
    ProgressBar bar(method.name());
    set = lighting::compute_maps(input, shininess, layout, method, bar.hooks());
  }

  fs::create_directories(o.out);
  const double exposure = auto_exposure_stops(input.image.view());
  nlohmann::json j;
  j["method"] = method.name();
  j["seconds"] = set.total_seconds;
  j["size"] = o.size;
  j["projection"] = o.projection;
  j["input"] = o.input;
  j["maps"] = nlohmann::json::array();
  std::printf("%s maps of %s, %s %d (%dx%d):\n", method.name().c_str(), o.input.c_str(),
              o.projection.c_str(), o.size, layout.width(), layout.height());
  for (std::size_t k = 0; k < shininess.size(); ++k) {
    const std::string stem = file_stem(method) + "_s" + shininess_label(shininess[k]);
    const fs::path file =
        write_map(o.out, stem, set.maps[k], shininess[k], exposure,
                  method.name() + " map, s = " + shininess_label(shininess[k]) + ", of " + o.input);
    j["maps"].push_back({{"shininess", shininess[k]},
                         {"seconds", set.seconds[k]},
                         {"file", file.string()},
                         {"plan", set.plans[k]}});
    std::printf("  s = %-6s %8.3f s  %s\n", shininess_label(shininess[k]).c_str(), set.seconds[k],
                file.c_str());
  }
  std::printf("  total      %8.3f s\n", set.total_seconds);
  const fs::path sheet = fs::path(o.out) / "contact_sheet.png";
  write_contact_sheet(sheet, {{method.name(), &set.maps}}, shininess, exposure);
  write_png_preview(fs::path(o.out) / "input.png", input.image.view(), {exposure});
  const fs::path json_path = o.json.empty() ? fs::path(o.out) / "maps.json" : fs::path(o.json);
  write_json(json_path, j);
  std::printf("  wrote %s, %s\n", sheet.c_str(), json_path.c_str());
  return 0;
}

}  // namespace

void add_map_options(CLI::App* sub, std::string* shininess, int* size, std::string* projection,
                     std::string* fill) {
  sub->add_option("--shininess", *shininess,
                  "comma-separated shininess list: 1 = irradiance, s > 1 = Phong cos^s")
      ->capture_default_str();
  sub->add_option("--size", *size, "N: N x N angle map, 2N x N lat-long, N x N per cube face")
      ->capture_default_str()
      ->check(CLI::Range(4, 4096));
  sub->add_option("--projection", *projection, "anglemap, latlong or cube")->capture_default_str();
  sub->add_option("--fill", *fill,
                  "a capture written with arlight-capture --fill none (unseen texels black): "
                  "estimate them from the seen ones (estimate), use their mean (mean) or keep "
                  "them black (none); other maps are used as they are")
      ->capture_default_str()
      ->check(CLI::IsMember({"none", "mean", "estimate"}));
}

Runner add_compute_command(CLI::App& app) {
  auto o = std::make_shared<ComputeOptions>();
  CLI::App* sub =
      app.add_subcommand("compute", "Irradiance and reflection maps of a probe by one method");
  sub->add_option("--input", o->input, "HDR environment map (EXR, HDR, PFM, PNG, JPEG, WebP)")
      ->required();
  sub->add_option("--method", o->method,
                  "accurate, mipmap, sh[:N], bounded, importance[:K] or auto")
      ->capture_default_str();
  add_map_options(sub, &o->shininess, &o->size, &o->projection, &o->fill);
  sub->add_option("--sh-order", o->sh_order, "SH order of the sh method")
      ->capture_default_str()
      ->check(CLI::Range(1, 128));
  sub->add_option("--samples", o->samples, "lobe samples per texel of the importance method")
      ->capture_default_str()
      ->check(CLI::Range(1, 65536));
  sub->add_option("--out", o->out, "output folder")->capture_default_str();
  sub->add_option("--json", o->json, "write the JSON report here (default DIR/maps.json)");
  return [o] { return run_compute(*o); };
}

}  // namespace arlight::maps
