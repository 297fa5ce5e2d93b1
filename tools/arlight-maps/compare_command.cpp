// arlight-maps compare: several methods' maps of one probe, timed and measured against the
// accurate method with thesis eqs. 6.1/6.2, printed like thesis Tables 6.1/6.2.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>

#include "arlight/common/hdr_io.hpp"
#include "commands.hpp"
#include "maps_io.hpp"

namespace arlight::maps {

namespace {

namespace fs = std::filesystem;

struct CompareOptions {
  std::string input;
  std::string methods = "accurate,mipmap,sh:35,bounded,importance:64,auto";
  std::string shininess = kDefaultShininess;
  int size = 256;
  std::string projection = "anglemap";
  std::string fill = "estimate";
  bool no_cache = false;
  std::string cache_dir;
  std::string out = "out/compare";
  std::string json;
};

struct Reference {
  std::vector<EnvMap> maps;
  double seconds = 0.0;
  bool cached = false;
};

// The accurate maps are cached on disk by the input's SHA-256, layout and shininess list: they
// take minutes at 512 and never change.
fs::path reference_dir(const CompareOptions& o, const fs::path& cache) {
  std::string key =
      file_sha256(o.input).substr(0, 24) + "_" + o.projection + std::to_string(o.size) + "_s";
  for (double s : parse_shininess(o.shininess)) key += "-" + shininess_label(s);
  return cache / "accurate-v1" / key;
}

bool load_reference(const fs::path& dir, const EnvLayout& layout, std::size_t count,
                    Reference& ref) {
  try {
    const auto meta = nlohmann::json::parse(std::ifstream(dir / "meta.json"));
    std::vector<EnvMap> maps;
    for (std::size_t k = 0; k < count; ++k) {
      LoadedEnvMap m = load_envmap(dir / ("s" + std::to_string(k) + ".exr"), layout.projection());
      if (!(m.env.layout == layout)) return false;
      maps.push_back(std::move(m.env));
    }
    ref.maps = std::move(maps);
    ref.seconds = meta.at("seconds").get<double>();
    ref.cached = true;
    return true;
  } catch (const std::exception&) {
    return false;  // missing or damaged cache: recompute
  }
}

void save_reference(const fs::path& dir, const Reference& ref) {
  fs::create_directories(dir);
  for (std::size_t k = 0; k < ref.maps.size(); ++k) {
    ImageMetadata md;
    md.projection = ref.maps[k].layout.projection();
    write_exr(dir / ("s" + std::to_string(k) + ".exr"), ref.maps[k].image.view(), md,
              ExrPixel::Float);
  }
  write_json(dir / "meta.json", {{"seconds", ref.seconds}});  // last: marks the entry complete
}

std::string percent(double fraction) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f%%", 100.0 * fraction);
  return buf;
}

int run_compare(const CompareOptions& o) {
  std::vector<std::string> names;
  std::vector<lighting::MethodSpec> methods;
  {
    std::stringstream in(o.methods);
    std::string item;
    while (std::getline(in, item, ',')) {
      methods.push_back(lighting::parse_method(item));
      names.push_back(item);
    }
    if (methods.empty()) throw InputError("--methods: empty list");
  }
  const std::vector<double> shininess = parse_shininess(o.shininess);
  check_size(o.size, methods);
  const EnvLayout layout = EnvLayout::for_size(parse_projection_arg(o.projection), o.size);
  const EnvMap input = load_working_map(o.input, layout, o.fill);

  const fs::path cache = o.cache_dir.empty() ? default_cache_dir() : fs::path(o.cache_dir);
  const fs::path ref_dir = reference_dir(o, cache);
  Reference ref;
  if (o.no_cache || !load_reference(ref_dir, layout, shininess.size(), ref)) {
    ProgressBar bar("accurate");
    lighting::ComputedMapSet set = lighting::compute_maps(input, shininess, layout,
                                                  lighting::parse_method("accurate"), bar.hooks());
    ref.maps = std::move(set.maps);
    ref.seconds = set.total_seconds;
    try {
      save_reference(ref_dir, ref);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "arlight-maps: cannot cache the reference in %s: %s\n", ref_dir.c_str(),
                   e.what());
    }
  }

  struct Row {
    std::string name;
    double seconds;
    bool cached;
    std::vector<EnvMap> maps;
    std::vector<lighting::MapError> errors;
  };
  std::vector<Row> rows;
  for (std::size_t m = 0; m < methods.size(); ++m) {
    Row row{names[m], 0.0, false, {}, {}};
    if (methods[m].method == lighting::Method::Accurate) {
      row.seconds = ref.seconds, row.cached = ref.cached, row.maps = ref.maps;
    } else {
      ProgressBar bar(names[m]);
      lighting::ComputedMapSet set =
          lighting::compute_maps(input, shininess, layout, methods[m], bar.hooks());
      row.seconds = set.total_seconds;
      row.maps = std::move(set.maps);
    }
    for (std::size_t k = 0; k < shininess.size(); ++k)
      row.errors.push_back(lighting::map_error(ref.maps[k], row.maps[k]));
    rows.push_back(std::move(row));
  }

  // Tables shaped like thesis Tables 6.1 / 6.2: one row per shininess, one column per method.
  std::printf("%s, %s %d (%dx%d), %zu maps; errors against accurate (eqs. 6.1, 6.2)\n\n",
              o.input.c_str(), o.projection.c_str(), o.size, layout.width(), layout.height(),
              shininess.size());
  auto header = [&](const char* title) {
    std::printf("%-18s", title);
    for (const Row& r : rows) std::printf(" %14s", r.name.c_str());
    std::printf("\n");
  };
  header("seconds");
  std::printf("%-18s", "");
  for (const Row& r : rows) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3f%s", r.seconds, r.cached ? " (cache)" : "");
    std::printf(" %14s", buf);
  }
  std::printf("\n\n");
  for (int table = 0; table < 2; ++table) {
    header(table == 0 ? "mean error, s" : "max error, s");
    for (std::size_t k = 0; k < shininess.size(); ++k) {
      std::printf("%-18s", shininess_label(shininess[k]).c_str());
      for (const Row& r : rows)
        std::printf(" %14s", percent(table == 0 ? r.errors[k].mean : r.errors[k].max).c_str());
      std::printf("\n");
    }
    std::printf("\n");
  }

  nlohmann::json j;
  j["size"] = o.size;
  j["projection"] = o.projection;
  j["input"] = o.input;
  j["methods"] = nlohmann::json::array();
  for (const Row& r : rows) {
    nlohmann::json mj{{"name", r.name}, {"seconds", r.seconds}, {"maps", nlohmann::json::array()}};
    if (r.cached) mj["cached"] = true;
    for (std::size_t k = 0; k < shininess.size(); ++k)
      mj["maps"].push_back({{"shininess", shininess[k]},
                            {"mean_error", r.errors[k].mean},
                            {"max_error", r.errors[k].max}});
    j["methods"].push_back(mj);
  }
  j["reference_seconds"] = ref.seconds;
  fs::create_directories(o.out);
  const fs::path json_path = o.json.empty() ? fs::path(o.out) / "compare.json" : fs::path(o.json);
  write_json(json_path, j);
  std::vector<SheetRow> sheet_rows;
  for (const Row& r : rows) sheet_rows.push_back({r.name, &r.maps});
  const fs::path sheet = fs::path(o.out) / "contact_sheet.png";
  write_contact_sheet(sheet, sheet_rows, shininess, auto_exposure_stops(input.image.view()));
  std::printf("wrote %s, %s\n", json_path.c_str(), sheet.c_str());
  return 0;
}

}  // namespace

Runner add_compare_command(CLI::App& app) {
  auto o = std::make_shared<CompareOptions>();
  CLI::App* sub = app.add_subcommand(
      "compare", "Time several methods and measure their errors against accurate");
  sub->add_option("--input", o->input, "HDR environment map")->required();
  sub->add_option("--methods", o->methods, "comma-separated methods, e.g. sh:35,importance:64")
      ->capture_default_str();
  add_map_options(sub, &o->shininess, &o->size, &o->projection, &o->fill);
  sub->add_flag("--no-cache", o->no_cache,
                "recompute the accurate reference so all timings come from this run");
  sub->add_option("--cache-dir", o->cache_dir,
                  "where accurate references are cached (default ~/.cache/arlight)");
  sub->add_option("--out", o->out, "output folder (contact sheet, JSON)")->capture_default_str();
  sub->add_option("--json", o->json, "write the JSON report here (default DIR/compare.json)");
  return [o] { return run_compare(*o); };
}

}  // namespace arlight::maps
