// arlight-maps diff: the maps of two environment maps (same method) compared with thesis
// eqs. 6.1/6.2, e.g. a captured environment against the true one.
#include <cstdio>
#include <memory>
#include <numbers>

#include "arlight/common/error.hpp"
#include "commands.hpp"
#include "maps_io.hpp"

namespace arlight::maps {

namespace {

struct DiffOptions {
  std::string reference, test;
  std::string method = "auto";
  std::string shininess = kDefaultShininess;
  int size = 128;
  std::string projection = "anglemap";
  std::string fill = "estimate";
  std::string json;
  bool match_scale = false;
};

// Mean luminance over the sphere (by solid angle).
double mean_luminance(const EnvMap& env) {
  const auto table = texel_table(env.layout);
  double sum = 0.0;
  for (std::size_t i = 0; i < table->size(); ++i) {
    const float* p = env.image.data() + 3 * std::size_t(table->index[i]);
    sum += table->solid_angle[i] * double(luminance(p[0], p[1], p[2]));
  }
  return sum / (4.0 * std::numbers::pi);
}

int run_diff(const DiffOptions& o) {
  const lighting::MethodSpec method = lighting::parse_method(o.method);
  const std::vector<double> shininess = parse_shininess(o.shininess);
  check_size(o.size, {method});
  const EnvLayout layout = EnvLayout::for_size(parse_projection_arg(o.projection), o.size);
  const EnvMap ref_env = load_working_map(o.reference, layout, o.fill);
  EnvMap test_env = load_working_map(o.test, layout, o.fill);
  double scale = 1.0;
  if (o.match_scale) {
    // One global scale, so that maps whose absolute scale is unknown (frames of unknown
    // exposure) are judged on everything else.
    const double ref_mean = mean_luminance(ref_env), test_mean = mean_luminance(test_env);
    if (!(test_mean > 0.0)) throw InputError("--match-scale: " + o.test + " is black");
    scale = ref_mean / test_mean;
    for (float& v : test_env.image.storage()) v = float(v * scale);
  }
  const lighting::ComputedMapSet ref = lighting::compute_maps(ref_env, shininess, layout, method);
  const lighting::ComputedMapSet test = lighting::compute_maps(test_env, shininess, layout, method);
  nlohmann::json j;
  j["method"] = method.name();
  j["reference"] = o.reference;
  j["test"] = o.test;
  j["scale"] = scale;
  j["maps"] = nlohmann::json::array();
  std::printf("%s maps of %s against %s (eqs. 6.1, 6.2):\n", method.name().c_str(), o.test.c_str(),
              o.reference.c_str());
  std::printf("  %-8s %10s %10s\n", "s", "mean", "max");
  for (std::size_t k = 0; k < shininess.size(); ++k) {
    const lighting::MapError e = lighting::map_error(ref.maps[k], test.maps[k]);
    j["maps"].push_back(
        {{"shininess", shininess[k]}, {"mean_error", e.mean}, {"max_error", e.max}});
    std::printf("  %-8s %9.2f%% %9.2f%%\n", shininess_label(shininess[k]).c_str(), 100 * e.mean,
                100 * e.max);
  }
  if (!o.json.empty()) write_json(o.json, j);
  return 0;
}

}  // namespace

Runner add_diff_command(CLI::App& app) {
  auto o = std::make_shared<DiffOptions>();
  CLI::App* sub =
      app.add_subcommand("diff", "Compare the maps of two environment maps (eqs. 6.1/6.2)");
  sub->add_option("--reference", o->reference, "the reference environment map")->required();
  sub->add_option("--test", o->test, "the environment map to judge")->required();
  sub->add_option("--method", o->method, "method both map sets are computed with")
      ->capture_default_str();
  add_map_options(sub, &o->shininess, &o->size, &o->projection, &o->fill);
  sub->add_option("--json", o->json, "write the JSON report here");
  sub->add_flag("--match-scale", o->match_scale,
                "scale the test map so its mean luminance is the reference's first (the scale "
                "is in the report)");
  return [o] { return run_diff(*o); };
}

}  // namespace arlight::maps
