#include "replay_report.hpp"

#include <nlohmann/json.hpp>
#include <sstream>

#include "arlight/common/atomic_file.hpp"
#include "arlight/common/hdr_io.hpp"
#include "arlight/net/session_light_files.hpp"

namespace fs = std::filesystem;

namespace arlight::replay_tool {

void write_replay_results(const fs::path& out, const std::string& json_path,
                          const client::Welcome& w, const client::Client& c, std::size_t sent) {
  fs::create_directories(out);
  const auto u = c.last_update();
  nlohmann::json j;
  j["session_id"] = w.session_id;
  j["resumed"] = w.resumed;
  j["frames_sent"] = sent;
  j["updates_received"] = c.updates_received();
  j["map_sets_completed"] = c.map_sets_completed();
  if (u) {
    j["frames_processed"] = u->frames_processed;
    j["frames_dropped"] = u->frames_dropped;
    j["coverage"] = u->coverage;
    j["estimated"] = u->estimated;
    j["sh_order"] = u->sh.order;
    j["sh"] = nlohmann::json::array();
    for (const auto& s : u->sh.c) j["sh"].push_back({s.x, s.y, s.z});
    j["dominant_direction"] = {u->dominant_direction.x, u->dominant_direction.y,
                               u->dominant_direction.z};
    j["dominant_colour"] = {u->dominant_colour.x, u->dominant_colour.y, u->dominant_colour.z};
    j["sun"] = {{"state", sun_state_name(u->sun_state)}};
    if (u->sun_state != SunState::Unknown)
      j["sun"]["direction"] = {u->sun_direction.x, u->sun_direction.y, u->sun_direction.z};
  }
  j["maps"] = nlohmann::json::array();
  if (const auto m = c.last_complete_maps()) {
    fs::create_directories(fs::path(out) / "maps");
    for (std::size_t k = 0; k < m->maps.size(); ++k) {
      std::ostringstream name;
      name << "s" << m->shininess[k] << ".exr";
      const fs::path p = fs::path(out) / "maps" / name.str();
      ImageMetadata meta;
      meta.projection = m->maps[k].layout.projection();
      meta.shininess = m->shininess[k];
      write_exr(p, m->maps[k].image.view(), meta);
      j["maps"].push_back({{"shininess", m->shininess[k]}, {"file", p.string()}});
    }
    j["map_set_seconds"] = m->server_seconds;
    j["map_set_frames"] = m->frames;
  }
  if (const auto chain = c.last_complete_ggx(); chain && u) {
    client::write_session_light_files(out, *chain, u->sh,
                                      "arlightd session " + w.session_id + ", " +
                                          std::to_string(chain->frames) + " frames");
    j["ggx"] = {{"file", (fs::path(out) / "specular.ktx2").string()},
                {"light_json", (fs::path(out) / "light.json").string()},
                {"levels", chain->maps.size()},
                {"face", chain->maps.front().layout.width()},
                {"roughness", chain->roughness},
                {"seconds", chain->server_seconds},
                {"frames", chain->frames}};
  }
  const std::string text = j.dump(2) + "\n";
  write_file_atomically(fs::path(out) / "replay.json", text);
  if (!json_path.empty()) write_file_atomically(json_path, text);
}

}  // namespace arlight::replay_tool
