// The native side of the page-against-native pixel test (page_pixels.test.mjs): the lighting the
// page is given, and the native renderer's composite of what the page drew.
//
//   web_pixel_reference lighting PROBE.exr OUT.bin
//       a LightingUpdate (protocol envelope) whose SH is the probe's, bands 0-2
//   web_pixel_reference render LIGHTING.bin VIEW.json FRAME.ppm MODEL.glb OUT.ppm
//       the composite of MODEL over FRAME (any image OpenCV reads, the page's size) as the
//       page's WebClient.view() and camera() describe it (VIEW.json: {view, camera}), lit by
//       LIGHTING.bin's SH, written to OUT, and its mask (255 where the object is) beside it as
//       OUT_mask.pgm
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <glm/gtc/quaternion.hpp>
#include <iterator>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "arlight/common/hdr_io.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/common/sh.hpp"
#include "arlight/protocol/wire.hpp"
#include "arlight/render/opencv.hpp"
#include "arlight/render/render.hpp"

using namespace arlight;

namespace {

std::vector<std::uint8_t> read_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path.string());
  return {std::istreambuf_iterator<char>(in), {}};
}

glm::dmat4 matrix(const nlohmann::json& a) {
  glm::dmat4 m;
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) m[c][r] = a.at(std::size_t(4 * c + r)).get<double>();
  return m;
}

int lighting(const std::string& probe, const std::string& out) {
  const EnvMap env = resample(load_envmap(probe).env, EnvLayout::for_size(Projection::LatLong, 64));
  wire::LightingUpdate u;
  u.frame_sequence = 1, u.frame_used = true, u.coverage = 1.0f, u.frames_processed = 1;
  u.sh = sh_project(env, 2);
  const DominantLight light = sh_dominant_light(u.sh);
  u.dominant_direction = glm::vec3(light.direction), u.dominant_colour = glm::vec3(light.colour);
  const std::vector<std::uint8_t> bytes = wire::encode(wire::Message(u));
  std::ofstream(out, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  return 0;
}

int render_view(const std::string& lighting_bin, const std::string& view_json,
                const std::string& frame_png, const std::string& model, const std::string& out) {
  const wire::Message m = wire::decode(read_bytes(lighting_bin));
  const auto& update = std::get<wire::LightingUpdate>(m);
  std::ifstream in(view_json);
  const nlohmann::json j = nlohmann::json::parse(in);
  const nlohmann::json& view = j.at("view");
  const nlohmann::json& cam = j.at("camera");
  cv::Mat frame = cv::imread(frame_png, cv::IMREAD_COLOR);  // BGR, as the native client's
  if (frame.empty()) throw std::runtime_error("cannot read " + frame_png);
  CameraIntrinsics k;
  k.width = cam.at("width"), k.height = cam.at("height");
  k.fx = cam.at("fx"), k.fy = cam.at("fy"), k.cx = cam.at("cx"), k.cy = cam.at("cy");

  render::GlContext gl = render::GlContext::headless();
  render::Renderer r(frame.cols, frame.rows);
  const render::GltfModel gltf = render::load_gltf_model(model);
  const render::GpuMesh mesh(gltf.mesh);
  r.set_sh(update.sh);
  r.set_camera(k, matrix(view.at("camera_from_scene")));
  const auto& q = view.at("world_from_scene");
  r.set_world_from_scene(glm::dquat(q[0], q[1], q[2], q[3]));
  r.set_shading(*render::shading_named(view.at("shading").get<std::string>()));
  r.set_refraction(*render::refraction_named(view.at("refraction").get<std::string>()));
  r.begin_frame();
  // "model": the glTF's own materials, as the page draws them.
  const std::string material = view.at("material").get<std::string>();
  if (material == "model")
    r.draw(mesh, gltf.materials, render::Material{}, glm::mat4(matrix(view.at("model"))));
  else
    r.draw(mesh, render::preset_material(material), glm::mat4(matrix(view.at("model"))));
  render::ToneMapping tone{render::ToneMode::CameraMatched, view.at("exposure").get<double>(), 1.0};
  tone.colour = *render::colour_correction_named(view.at("colour").get<std::string>());
  cv::Mat composited;
  render::composite(r, frame, tone, composited);
  const render::HdrReadback hdr = r.read_hdr();
  cv::Mat mask(frame.rows, frame.cols, CV_8UC1);
  for (int y = 0; y < frame.rows; ++y)
    for (int x = 0; x < frame.cols; ++x)
      mask.at<std::uint8_t>(y, x) = hdr.mask[std::size_t(y) * frame.cols + x] ? 255 : 0;
  const std::filesystem::path path(out);
  if (!cv::imwrite(out, composited) ||
      !cv::imwrite((path.parent_path() / (path.stem().string() + "_mask.pgm")).string(), mask))
    throw std::runtime_error("cannot write " + out);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::vector<std::string> a(argv + 1, argv + argc);
    if (a.size() == 3 && a[0] == "lighting") return lighting(a[1], a[2]);
    if (a.size() == 6 && a[0] == "render") return render_view(a[1], a[2], a[3], a[4], a[5]);
    std::fprintf(stderr,
                 "usage: web_pixel_reference lighting PROBE.exr OUT.bin\n"
                 "       web_pixel_reference render LIGHTING.bin VIEW.json FRAME.ppm MODEL.glb "
                 "OUT.ppm\n");
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "web_pixel_reference: %s\n", e.what());
    return 1;
  }
}
