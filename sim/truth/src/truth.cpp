#include "arlight/truth/truth.hpp"

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "arlight/common/atomic_file.hpp"
#include "arlight/common/error.hpp"

namespace arlight::recording {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Field access whose errors name the file and the field's path, e.g.
// "'REC/truth/truth.json': poses[3].orientation: missing".
class Reader {
 public:
  explicit Reader(const fs::path& file) : file_(file) {}

  [[noreturn]] void fail(const std::string& field, const std::string& what) const {
    throw InputError("'" + file_.string() + "': " + field + ": " + what);
  }
  const json& get(const json& obj, const std::string& where, const std::string& field) const {
    if (!obj.is_object()) fail(where.empty() ? "(top level)" : where, "expected an object");
    const auto it = obj.find(field);
    if (it == obj.end()) fail(where + field, "missing");
    return *it;
  }
  std::string string(const json& obj, const std::string& where, const std::string& field) const {
    const json& v = get(obj, where, field);
    if (!v.is_string()) fail(where + field, "expected a string");
    return v.get<std::string>();
  }
  double number(const json& obj, const std::string& where, const std::string& field) const {
    const json& v = get(obj, where, field);
    if (!v.is_number() || !std::isfinite(v.get<double>())) fail(where + field, "expected a number");
    return v.get<double>();
  }
  // n finite numbers in an array.
  std::vector<double> numbers(const json& obj, const std::string& where, const std::string& field,
                              std::size_t n, const char* shape) const {
    const json& v = get(obj, where, field);
    if (!v.is_array() || v.size() != n) fail(where + field, std::string("expected ") + shape);
    std::vector<double> out;
    for (const json& x : v) {
      if (!x.is_number() || !std::isfinite(x.get<double>()))
        fail(where + field, std::string("expected ") + shape + " (finite numbers)");
      out.push_back(x.get<double>());
    }
    return out;
  }
  Pose pose(const json& obj, const std::string& where) const {
    Pose p;
    const auto q = numbers(obj, where, "orientation", 4, "[w, x, y, z]");
    const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (std::abs(norm - 1.0) > 1e-6) fail(where + "orientation", "not a unit quaternion");
    p.orientation = glm::dquat(q[0], q[1], q[2], q[3]);
    // Exactly as written when it is unit to rounding, so poses round-trip bit for bit.
    if (std::abs(norm - 1.0) > 1e-12) p.orientation = glm::normalize(p.orientation);
    const auto t = numbers(obj, where, "position", 3, "[x, y, z]");
    p.position = {t[0], t[1], t[2]};
    return p;
  }

 private:
  const fs::path& file_;
};

json pose_json(const Pose& p) {
  const glm::dquat& q = p.orientation;
  return {{"orientation", {q.w, q.x, q.y, q.z}},
          {"position", {p.position.x, p.position.y, p.position.z}}};
}

}  // namespace

void write_truth(const fs::path& rec_folder, const Truth& truth) {
  if (truth.marker && truth.marker_visible.size() != truth.poses.size())
    throw std::invalid_argument("write_truth: marker_visible needs one entry per pose");
  if (!truth.marker && !truth.marker_visible.empty())
    throw std::invalid_argument("write_truth: marker_visible without a marker");
  json j;
  j["format"] = kTruthFormatName;
  j["version"] = kTruthFormatVersion;
  j["probe"] = truth.probe;
  j["radiance_scale"] = truth.radiance_scale;
  j["response"] = truth.response;
  j["gyro_drift_deg_per_s"] = truth.gyro_drift_deg_per_s;
  j["poses"] = json::array();
  for (const Pose& p : truth.poses) j["poses"].push_back(pose_json(p));
  if (truth.marker) {
    const MarkerTruth& m = *truth.marker;
    j["marker"] = {{"dictionary", m.dictionary},
                   {"id", m.id},
                   {"size_m", m.size_m},
                   {"pose", pose_json(m.pose)}};
    j["marker_visible"] = json::array();
    for (const bool v : truth.marker_visible) j["marker_visible"].push_back(v);
  }
  const fs::path dir = rec_folder / kTruthFolder;
  fs::create_directories(dir);
  write_file_atomically(dir / kTruthManifestName, j.dump(1) + "\n");
}

std::optional<Truth> read_truth(const fs::path& rec_folder) {
  const fs::path file = rec_folder / kTruthFolder / kTruthManifestName;
  std::error_code ec;
  if (!fs::exists(file, ec)) return std::nullopt;
  const Reader r(file);
  if (!fs::is_regular_file(file, ec)) r.fail("(file)", "not a regular file");
  if (fs::file_size(file, ec) > (256u << 20)) r.fail("(file)", "larger than 256 MiB");
  json j;
  try {
    std::ifstream in(file);
    j = json::parse(in);
  } catch (const json::exception& e) {
    throw InputError("'" + file.string() + "': not valid JSON (truncated?): " + e.what());
  }
  if (r.string(j, "", "format") != kTruthFormatName)
    r.fail("format", "expected \"" + std::string(kTruthFormatName) + "\"");
  const json& version = r.get(j, "", "version");
  if (!version.is_number_integer() || version.get<long long>() < 1)
    r.fail("version", "expected a whole number >= 1");
  if (version.get<long long>() > kTruthFormatVersion)
    r.fail("version", std::to_string(version.get<long long>()) + " is newer than this reader (" +
                          std::to_string(kTruthFormatVersion) + ")");

  Truth t;
  t.probe = r.string(j, "", "probe");
  t.radiance_scale = r.number(j, "", "radiance_scale");
  if (!(t.radiance_scale > 0)) r.fail("radiance_scale", "must be positive");
  t.response = r.string(j, "", "response");
  t.gyro_drift_deg_per_s = r.number(j, "", "gyro_drift_deg_per_s");
  const json& poses = r.get(j, "", "poses");
  if (!poses.is_array()) r.fail("poses", "expected an array");
  for (std::size_t i = 0; i < poses.size(); ++i)
    t.poses.push_back(r.pose(poses[i], "poses[" + std::to_string(i) + "]."));

  if (j.contains("marker") && !j["marker"].is_null()) {
    const json& mj = j["marker"];
    MarkerTruth m;
    m.dictionary = r.string(mj, "marker.", "dictionary");
    const json& id = r.get(mj, "marker.", "id");
    if (!id.is_number_integer() || id.get<long long>() < 0 || id.get<long long>() > 1000000)
      r.fail("marker.id", "expected a whole number >= 0");
    m.id = int(id.get<long long>());
    m.size_m = r.number(mj, "marker.", "size_m");
    if (!(m.size_m > 0)) r.fail("marker.size_m", "must be positive");
    m.pose = r.pose(r.get(mj, "marker.", "pose"), "marker.pose.");
    t.marker = m;
    const json& vis = r.get(j, "", "marker_visible");
    if (!vis.is_array() || vis.size() != t.poses.size())
      r.fail("marker_visible",
             "expected one true/false per pose (" + std::to_string(t.poses.size()) + ")");
    for (const json& v : vis) {
      if (!v.is_boolean()) r.fail("marker_visible", "expected true or false values");
      t.marker_visible.push_back(v.get<bool>());
    }
  } else if (j.contains("marker_visible") &&
             !(j["marker_visible"].is_array() && j["marker_visible"].empty())) {
    r.fail("marker_visible", "given without a marker");
  }
  return t;
}

std::optional<Pose> camera_in_marker(const Truth& truth, std::size_t i) {
  if (!truth.marker || i >= truth.poses.size() || i >= truth.marker_visible.size() ||
      !truth.marker_visible[i])
    return std::nullopt;
  return compose(inverse(truth.marker->pose), truth.poses[i]);
}

}  // namespace arlight::recording
