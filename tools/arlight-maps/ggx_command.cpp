// arlight-maps ggx: the GGX-prefiltered chain of a probe (the split sum's specular part) as
// KTX2, and with --latlong each level in the probe's own lat-long layout.
// arlight-maps export: the light files every engine reads (specular.ktx2, light.json,
// lighting.gltf; common/light_files.hpp).
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/common/light_files.hpp"
#include "arlight/common/light_sources.hpp"
#include "arlight/common/sh.hpp"
#include "arlight/lighting/ggx.hpp"
#include "commands.hpp"
#include "maps_io.hpp"

namespace arlight::maps {

namespace {

struct GgxOptions {
  std::string input;
  int face = 256;
  int min_face = 16;
  std::string out = "out/ggx";
  bool latlong = false;
  std::string json;
  int lights = 0;  // export: small, bright lights taken out of the SH and the chain
};

void add_chain_options(CLI::App* sub, GgxOptions& o) {
  sub->add_option("--input", o.input, "HDR environment map (EXR or HDR; any projection)")
      ->required()->check(CLI::ExistingFile);
  sub->add_option("--face", o.face, "level 0's face edge in texels (a power of two)")
      ->capture_default_str();
  sub->add_option("--min-face", o.min_face, "the last level's face edge (a power of two)")
      ->capture_default_str();
  sub->add_option("--out", o.out, "output directory")->capture_default_str();
}

LoadedEnvMap load_probe(const std::string& path) {
  LoadedEnvMap probe = load_envmap(path);
  if (!probe.info.sanitized.clean())
    std::fprintf(stderr, "arlight-maps: %s: %s\n", path.c_str(), probe.info.sanitized.summary().c_str());
  return probe;
}

lighting::GgxChain chain_of(const EnvMap& env, const GgxOptions& o) {
  lighting::GgxChainSpec spec;
  spec.face = o.face;
  spec.min_face = o.min_face;
  return lighting::compute_ggx_chain(env, spec);
}

int run_ggx(const GgxOptions& o) {
  namespace fs = std::filesystem;
  const LoadedEnvMap probe = load_probe(o.input);
  const lighting::GgxChain chain = chain_of(probe.env, o);
  fs::create_directories(o.out);
  const auto maps = chain.maps();
  LightFilesInput light;
  light.specular = maps;
  light.roughness = chain.roughness();
  write_specular_ktx2(fs::path(o.out) / "specular.ktx2", light);

  nlohmann::json j;
  j["input"] = o.input;
  j["level_mapping"] = lighting::kGgxLevelMapping;
  j["seconds"] = chain.total_seconds;
  j["levels"] = nlohmann::json::array();
  for (const auto& l : chain.levels)
    j["levels"].push_back({{"level", l.level}, {"roughness", l.roughness},
                           {"face", l.map.layout.face_size()}, {"seconds", l.seconds}});
  if (o.latlong) {
    // Each level again in the probe's own lat-long layout, so that probe and level compare
    // texel by texel (level 0, the mirror, is the probe itself), over one pyramid of the probe.
    const bool latlong_input = probe.env.layout.projection() == Projection::LatLong;
    const EnvLayout layout =
        latlong_input ? probe.env.layout : EnvLayout::for_size(Projection::LatLong, o.face);
    const std::vector<double> rough(light.roughness.begin() + 1, light.roughness.end());
    std::vector<EnvMap> levels = lighting::ggx_prefilter(probe.env, rough, layout);
    levels.insert(levels.begin(), latlong_input ? probe.env : resample(probe.env, layout));
    for (const auto& l : chain.levels) {
      const EnvMap& map = levels[std::size_t(l.level)];
      ImageMetadata md;
      md.projection = Projection::LatLong;
      md.description = "GGX prefilter of " + o.input + ", level " + std::to_string(l.level) +
                       ", roughness " + std::to_string(l.roughness) + "; " + lighting::kGgxLevelMapping;
      write_exr(fs::path(o.out) / ("ggx_m" + std::to_string(l.level) + ".exr"), map.image.view(), md,
                ExrPixel::Half);
    }
  }
  if (!o.json.empty()) write_json(o.json, j);
  std::printf("GGX chain of %s: %zu levels, face %d to %d, %.3f s -> %s/specular.ktx2\n", o.input.c_str(),
              chain.levels.size(), o.face, chain.levels.back().map.layout.face_size(),
              chain.total_seconds, o.out.c_str());
  return 0;
}

int run_export(const GgxOptions& o) {
  const LoadedEnvMap probe = load_probe(o.input);
  // With --lights the SH and the chain are of the room less its lights (issue 51 §1); the
  // primary light stays the whole room's.
  const SpecularSplit split = split_specular_lights(probe.env, {.max_lights = o.lights});
  const lighting::GgxChain chain = chain_of(split.residual, o);
  const auto maps = chain.maps();
  LightFilesInput light;
  light.sh = sh_project(split.residual, 3);
  light.primary = primary_light(probe.env, sh_project(probe.env, 3));
  light.lights = split.lights;
  light.specular = maps;
  light.roughness = chain.roughness();
  light.source = o.input;
  write_light_files(o.out, light);
  std::printf("light of %s -> %s/{specular.ktx2, light.json, lighting.gltf}%s\n", o.input.c_str(),
              o.out.c_str(),
              light.lights.empty() ? ""
                                   : (", " + std::to_string(light.lights.size()) +
                                      " lights apart").c_str());
  return 0;
}

}  // namespace

Runner add_ggx_command(CLI::App& app) {
  auto o = std::make_shared<GgxOptions>();
  CLI::App* sub = app.add_subcommand(
      "ggx", "GGX-prefiltered radiance chain (glTF roughness per mip level) as KTX2");
  add_chain_options(sub, *o);
  sub->add_flag("--latlong", o->latlong, "also write each level as DIR/ggx_m<L>.exr in the input's lat-long layout");
  sub->add_option("--json", o->json, "write the levels, their roughness and timings as JSON");
  return [o] { return run_ggx(*o); };
}

Runner add_export_command(CLI::App& app) {
  auto o = std::make_shared<GgxOptions>();
  CLI::App* sub = app.add_subcommand(
      "export", "the light files engines read: specular.ktx2, light.json (SH-9, primary light), lighting.gltf");
  add_chain_options(sub, *o);
  sub->add_option("--lights", o->lights,
                  "take up to N small, bright lights out of the SH and the chain and write them "
                  "as directional lights (light.json lights, lighting.gltf KHR_lights_punctual)")
      ->capture_default_str()->check(CLI::Range(0, kMaxSpecularLights));
  return [o] { return run_export(*o); };
}

}  // namespace arlight::maps
