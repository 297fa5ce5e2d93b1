#include "arlight/protocol/recording.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "arlight/common/atomic_file.hpp"
#include "arlight/common/error.hpp"

namespace arlight::recording {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string quoted(const fs::path& p) { return "'" + p.string() + "'"; }

// Field access with errors that name the manifest and the field's path.
class Fields {
 public:
  Fields(const fs::path& manifest, const json& j, std::string where)
      : manifest_(manifest), j_(j), where_(std::move(where)) {}

  [[noreturn]] void fail(const std::string& field, const std::string& what) const {
    throw InputError(quoted(manifest_) + ": " + where_ + field + ": " + what);
  }
  const json& get(const std::string& field) const {
    if (!j_.is_object()) fail("", "expected an object");
    const auto it = j_.find(field);
    if (it == j_.end()) fail(field, "missing");
    return *it;
  }
  bool has(const std::string& field) const { return j_.is_object() && j_.contains(field); }
  std::string string(const std::string& field) const {
    const json& v = get(field);
    if (!v.is_string()) fail(field, "expected a string");
    return v.get<std::string>();
  }
  int integer(const std::string& field, int lo, int hi) const {
    const json& v = get(field);
    if (!v.is_number_integer()) fail(field, "expected a whole number");
    const auto x = v.get<long long>();
    if (x < lo || x > hi)
      fail(field,
           std::to_string(x) + " is outside " + std::to_string(lo) + ".." + std::to_string(hi));
    return int(x);
  }
  double positive(const std::string& field) const {
    const json& v = get(field);
    if (!v.is_number()) fail(field, "expected a number");
    const double x = v.get<double>();
    if (!std::isfinite(x) || x <= 0) fail(field, "must be a positive number");
    return x;
  }
  // A number, or null (how JSON writers spell NaN): NaN then.
  double number_or_nan(const std::string& field) const {
    const json& v = get(field);
    if (v.is_null()) return std::nan("");
    if (!v.is_number()) fail(field, "expected a number");
    return v.get<double>();
  }

 private:
  const fs::path& manifest_;
  const json& j_;
  std::string where_;
};

// A relative path inside the recording, no "..", no absolute paths.
bool safe_relative(const std::string& s) {
  const fs::path p(s);
  if (s.empty() || p.is_absolute() || p.has_root_name()) return false;
  for (const auto& part : p)
    if (part == "..") return false;
  return true;
}

// Why a frame file cannot be used, or "" when it looks like a whole JPEG.
std::string check_jpeg_file(const fs::path& path, const std::string& name) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return name + " is missing";
  const auto size = fs::file_size(path, ec);
  if (ec) return name + " cannot be read";
  if (size < 4) return name + " is empty or truncated";
  if (size > kMaxFrameBytes)
    return name + " is larger than " + std::to_string(kMaxFrameBytes) + " bytes";
  std::ifstream f(path, std::ios::binary);
  unsigned char head[3] = {}, tail[2] = {};
  f.read(reinterpret_cast<char*>(head), 3);
  f.seekg(-2, std::ios::end);
  f.read(reinterpret_cast<char*>(tail), 2);
  if (!f) return name + " cannot be read";
  if (head[0] != 0xFF || head[1] != 0xD8 || head[2] != 0xFF) return name + " is not a JPEG";
  if (tail[0] != 0xFF || tail[1] != 0xD9) return name + " is truncated (no JPEG end marker)";
  return {};
}

std::vector<ImuSample> read_imu(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(quoted(path) + ": cannot read the IMU log");
  std::vector<ImuSample> out;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.empty() || line[0] == '#') continue;
    double v[7];
    const char* p = line.data();
    const char* end = line.data() + line.size();
    for (int k = 0; k < 7; ++k) {
      while (p < end && (*p == ' ' || *p == ',')) ++p;
      const auto [next, ec] = std::from_chars(p, end, v[k]);
      if (ec != std::errc() || !std::isfinite(v[k]))
        throw InputError(quoted(path) + ": line " + std::to_string(n) +
                         ": expected 7 numbers t,gx,gy,gz,ax,ay,az");
      p = next;
    }
    while (p < end && (*p == ' ' || *p == '\r')) ++p;
    if (p != end)
      throw InputError(quoted(path) + ": line " + std::to_string(n) + ": more than 7 values");
    if (!out.empty() && v[0] < out.back().timestamp)
      throw InputError(quoted(path) + ": line " + std::to_string(n) + ": timestamp goes back");
    out.push_back({v[0], {v[1], v[2], v[3]}, {v[4], v[5], v[6]}});
  }
  return out;
}

}  // namespace

Recording read_recording(const fs::path& folder) {
  const fs::path manifest = folder / kManifestName;
  std::error_code ec;
  if (!fs::is_regular_file(manifest, ec))
    throw InputError(quoted(manifest) + ": no such file (is " + quoted(folder) +
                     " a recording folder?)");
  if (fs::file_size(manifest, ec) > (64u << 20))
    throw InputError(quoted(manifest) + ": larger than 64 MiB");
  json j;
  try {
    std::ifstream in(manifest);
    j = json::parse(in);
  } catch (const json::exception& e) {
    throw InputError(quoted(manifest) + ": not valid JSON (truncated?): " + e.what());
  }
  const Fields top(manifest, j, "");
  if (top.string("format") != kFormatName)
    top.fail("format", "expected \"" + std::string(kFormatName) + "\"");
  Recording rec;
  rec.folder = folder;
  rec.version = top.integer("version", 1, 1 << 20);
  if (rec.version > kFormatVersion)
    top.fail("version", std::to_string(rec.version) + " is newer than this reader (" +
                            std::to_string(kFormatVersion) + ")");
  if (top.has("device_id")) rec.device_id = top.string("device_id");
  if (top.has("place")) {
    const Fields place(manifest, top.get("place"), "place.");
    RecordedPlace p;
    const auto number = [&](const char* field) {
      const double x = place.number_or_nan(field);
      if (!std::isfinite(x)) place.fail(field, "expected a finite number");
      return x;
    };
    p.where = {number("latitude"), number("longitude"),
               place.has("altitude") ? number("altitude") : 0.0};
    if (const std::string e = geo_location_error(p.where); !e.empty()) top.fail("place", e);
    p.utc_seconds = number("utc_seconds");
    if (place.has("north_offset")) {
      p.north_offset_deg = number("north_offset");
      if (std::abs(*p.north_offset_deg) > 180.0)
        place.fail("north_offset", "must be in [-180, 180] degrees");
    }
    rec.place = p;
  }

  const Fields cam(manifest, top.get("camera"), "camera.");
  CameraIntrinsics& c = rec.camera;
  c.width = cam.integer("width", 1, 16384);
  c.height = cam.integer("height", 1, 16384);
  c.fx = cam.positive("fx");
  c.fy = cam.positive("fy");
  c.cx = cam.positive("cx");
  c.cy = cam.positive("cy");
  if (c.cx >= c.width) cam.fail("cx", "outside the image");
  if (c.cy >= c.height) cam.fail("cy", "outside the image");
  if (cam.has("distortion")) {
    const json& d = cam.get("distortion");
    if (!d.is_array() || d.size() < 4 || d.size() > 5)
      cam.fail("distortion", "expected 4 or 5 numbers k1, k2, p1, p2[, k3]");
    for (std::size_t k = 0; k < d.size(); ++k) {
      if (!d[k].is_number() || !std::isfinite(d[k].get<double>()))
        cam.fail("distortion", "expected numbers");
      c.distortion[k] = d[k].get<double>();
    }
  }

  const json& frames = top.get("frames");
  if (!frames.is_array()) top.fail("frames", "expected an array");
  double last_time = -INFINITY;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const Fields f(manifest, frames[i], "frames[" + std::to_string(i) + "].");
    Frame fr;
    fr.file = f.string("file");
    if (!safe_relative(fr.file)) f.fail("file", "must be a path inside the recording folder");
    fr.timestamp = f.number_or_nan("timestamp");
    fr.exposure = f.number_or_nan("exposure");
    fr.gain = f.number_or_nan("gain");
    const json& q = f.get("orientation");
    if (!q.is_array() || q.size() != 4) f.fail("orientation", "expected [w, x, y, z]");
    double qv[4];
    for (int k = 0; k < 4; ++k) {
      if (!q[std::size_t(k)].is_null() && !q[std::size_t(k)].is_number())
        f.fail("orientation", "expected numbers");
      qv[k] = q[std::size_t(k)].is_null() ? std::nan("") : q[std::size_t(k)].get<double>();
    }
    fr.orientation = glm::dquat(qv[0], qv[1], qv[2], qv[3]);
    // What makes this one frame unusable, first reason only.
    const double norm = std::sqrt(qv[0] * qv[0] + qv[1] * qv[1] + qv[2] * qv[2] + qv[3] * qv[3]);
    if (!std::isfinite(fr.timestamp))
      fr.problem = "timestamp is not a number";
    else if (fr.timestamp < last_time)
      fr.problem = "timestamp goes back in time";
    else if (!std::isfinite(fr.exposure) || fr.exposure <= 0)
      fr.problem = "exposure is not a positive number";
    else if (!std::isfinite(fr.gain) || fr.gain <= 0)
      fr.problem = "gain is not a positive number";
    else if (!std::isfinite(norm) || std::abs(norm - 1.0) > 1e-3)
      fr.problem = "orientation is not a unit quaternion";
    else
      fr.problem = check_jpeg_file(folder / fr.file, fr.file);
    if (fr.problem.empty()) {
      fr.orientation = glm::normalize(fr.orientation);
      last_time = fr.timestamp;
    }
    rec.frames.push_back(std::move(fr));
  }

  if (top.has("imu")) {
    const std::string imu = top.string("imu");
    if (!safe_relative(imu)) top.fail("imu", "must be a path inside the recording folder");
    rec.imu = read_imu(folder / imu);
  }
  return rec;
}

std::vector<std::uint8_t> read_frame_bytes(const Recording& rec, std::size_t i) {
  if (i >= rec.frames.size())
    throw std::out_of_range("frame " + std::to_string(i) + " of " +
                            std::to_string(rec.frames.size()));
  const fs::path path = rec.folder / rec.frames[i].file;
  if (const std::string why = check_jpeg_file(path, rec.frames[i].file); !why.empty())
    throw InputError(quoted(path) + ": " + why);
  std::ifstream f(path, std::ios::binary);
  std::vector<std::uint8_t> bytes(fs::file_size(path));
  f.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size()));
  if (!f) throw InputError(quoted(path) + ": cannot be read");
  return bytes;
}

RecordingWriter::RecordingWriter(fs::path folder, const CameraIntrinsics& camera,
                                 std::string device_id)
    : folder_(std::move(folder)) {
  rec_.folder = folder_;
  rec_.camera = camera;
  rec_.device_id = std::move(device_id);
  fs::create_directories(folder_ / "frames");
}

std::size_t RecordingWriter::add_frame(const std::vector<std::uint8_t>& jpeg, double timestamp,
                                       double exposure, double gain,
                                       const glm::dquat& orientation) {
  if (finished_) throw std::logic_error("RecordingWriter: add_frame after finish");
  char name[32];
  std::snprintf(name, sizeof name, "frames/%06zu.jpg", rec_.frames.size());
  std::ofstream f(folder_ / name, std::ios::binary | std::ios::trunc);
  f.write(reinterpret_cast<const char*>(jpeg.data()), std::streamsize(jpeg.size()));
  if (!f.flush()) throw std::runtime_error("cannot write " + (folder_ / name).string());
  Frame frame;
  frame.timestamp = timestamp, frame.exposure = exposure, frame.gain = gain;
  frame.orientation = orientation, frame.file = name;
  rec_.frames.push_back(std::move(frame));
  return rec_.frames.size() - 1;
}

void RecordingWriter::add_imu(const ImuSample& sample) {
  if (finished_) throw std::logic_error("RecordingWriter: add_imu after finish");
  rec_.imu.push_back(sample);
}

void RecordingWriter::set_place(const RecordedPlace& place) {
  if (const std::string e = geo_location_error(place.where); !e.empty())
    throw std::invalid_argument("RecordingWriter: place: " + e);
  rec_.place = place;
}

void RecordingWriter::finish() {
  if (finished_) return;
  json j;
  j["format"] = kFormatName;
  j["version"] = kFormatVersion;
  if (!rec_.device_id.empty()) j["device_id"] = rec_.device_id;
  if (const auto& p = rec_.place) {
    j["place"] = {{"latitude", p->where.latitude_deg},
                  {"longitude", p->where.longitude_deg},
                  {"altitude", p->where.altitude_m},
                  {"utc_seconds", p->utc_seconds}};
    if (p->north_offset_deg) j["place"]["north_offset"] = *p->north_offset_deg;
  }
  const CameraIntrinsics& c = rec_.camera;
  j["camera"] = {
      {"width", c.width}, {"height", c.height},        {"fx", c.fx}, {"fy", c.fy}, {"cx", c.cx},
      {"cy", c.cy},       {"distortion", c.distortion}};
  j["frames"] = json::array();
  for (const Frame& f : rec_.frames)
    j["frames"].push_back(
        {{"file", f.file},
         {"timestamp", f.timestamp},
         {"exposure", f.exposure},
         {"gain", f.gain},
         {"orientation", {f.orientation.w, f.orientation.x, f.orientation.y, f.orientation.z}}});
  if (!rec_.imu.empty()) {
    std::ostringstream csv;
    csv.precision(17);
    csv << "# t,gx,gy,gz,ax,ay,az (s, rad/s, m/s^2)\n";
    for (const ImuSample& s : rec_.imu)
      csv << s.timestamp << ',' << s.gyro.x << ',' << s.gyro.y << ',' << s.gyro.z << ','
          << s.accel.x << ',' << s.accel.y << ',' << s.accel.z << '\n';
    write_file_atomically(folder_ / "imu.csv", csv.str());
    j["imu"] = "imu.csv";
  }
  write_file_atomically(folder_ / kManifestName, j.dump(1) + "\n");
  finished_ = true;
}

FrameReader::FrameReader(const Recording& rec, bool realtime, OnSkip on_skip)
    : rec_(rec), realtime_(realtime), on_skip_(std::move(on_skip)) {}

void FrameReader::skip(std::size_t index, const std::string& reason) {
  ++skipped_;
  if (on_skip_) on_skip_(index, reason);
}

std::optional<FrameReader::Item> FrameReader::next() {
  while (next_ < rec_.frames.size()) {
    Item item;
    item.index = next_++;
    item.frame = &rec_.frames[item.index];
    if (!item.frame->problem.empty()) {
      skip(item.index, item.frame->problem);
      continue;
    }
    try {
      item.jpeg = read_frame_bytes(rec_, item.index);
    } catch (const InputError& e) {  // changed on disk since the manifest was read
      skip(item.index, e.what());
      continue;
    }
    if (realtime_) {
      const auto now = std::chrono::steady_clock::now();
      if (!start_) {
        start_ = now;
        first_timestamp_ = item.frame->timestamp;
      } else {
        const auto due =
            *start_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                          std::chrono::duration<double>(item.frame->timestamp - first_timestamp_));
        if (due > now) std::this_thread::sleep_until(due);
      }
    }
    return item;
  }
  return std::nullopt;
}

}  // namespace arlight::recording
