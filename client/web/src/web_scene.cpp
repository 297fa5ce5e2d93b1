// The page's API (web_client.hpp): the camera's focal length, the object on the marker, its
// material and the renderer's modes, each checked as the native client's flags are.
#include <cmath>
#include <stdexcept>

#include "arlight/common/error.hpp"
#include "web_client.hpp"

namespace arlight::web {

namespace {

// The object stands this many marker sides tall, as in the native client (client_app.hpp).
constexpr double kObjectHeightPerMarker = 1.5;
constexpr double kDefaultMarkerSize = 0.2;  // metres: the native client's default marker

// "model": the model's own materials (WebClient::draw_materials); the Phong default on parts
// without one.
render::Material material_named(const std::string& name) {
  if (name == "model") return {};
  return render::preset_material(name, float(kShininess.back()));  // as sharp as the sharpest map
}

}  // namespace

WebClient::WebClient(const std::string& canvas, int width, int height)
    : WebClient(canvas, width, height, render::make_sphere(0.5f, 48, 96)) {}

WebClient::WebClient(const std::string& canvas, int width, int height, const render::Mesh& sphere)
    : context_(render::GlContext::canvas(canvas)),
      renderer_(width, height, "/shaders"),
      mesh_bounds_(sphere.bounds),
      mesh_(sphere),
      model_vertices_(sphere.vertex_count()),
      material_(material_named("plastic")),
      width_(width),
      height_(height) {
  camera_.width = width, camera_.height = height;
  pacer_.limit_in_flight(kMaxInFlight);
  set_fov(63.0);
  set_marker_size(kDefaultMarkerSize);
}

void WebClient::set_fov(double fov_y_deg) {
  if (!(fov_y_deg > 10.0 && fov_y_deg < 150.0))
    throw std::invalid_argument("field of view " + std::to_string(fov_y_deg) +
                                " is not in (10, 150) degrees");
  set_focal(0.5 * height_ / std::tan(0.5 * fov_y_deg * M_PI / 180.0));
}

void WebClient::set_focal(double f) {
  if (!(f > 0.05 * height_ && f < 20.0 * height_))
    throw std::invalid_argument("focal length " + std::to_string(f) + " px is out of range");
  camera_.fx = camera_.fy = f;
  camera_.cx = 0.5 * width_ - 0.5, camera_.cy = 0.5 * height_ - 0.5;
}

val WebClient::camera() const {
  val k = val::object();
  k.set("fx", camera_.fx), k.set("fy", camera_.fy), k.set("cx", camera_.cx);
  k.set("cy", camera_.cy), k.set("width", width_), k.set("height", height_);
  return k;
}

void WebClient::set_marker_size(double size_m) {
  if (!(size_m > 0.005 && size_m < 10.0))
    throw std::invalid_argument("marker size " + std::to_string(size_m) + " m is out of range");
  object_height_ = kObjectHeightPerMarker * size_m;
  model_ = render::standing_on_marker(mesh_bounds_, float(object_height_));
}

void WebClient::set_shadow_lights(int max_lights, double target_fps) {
  if (max_lights < 1 || max_lights > render::kMaxShadowLights)
    throw std::invalid_argument("shadow lights " + std::to_string(max_lights) + ": 1 to " +
                                std::to_string(render::kMaxShadowLights));
  if (!(target_fps >= 0) || !std::isfinite(target_fps))
    throw std::invalid_argument("target frame rate: a number of frames a second, 0 for none");
  shadow_ = client_app::ShadowBudget(max_lights, target_fps);
}

void WebClient::set_material(const std::string& name) {
  material_ = material_named(name);
  material_name_ = name;
}

void WebClient::set_refraction(const std::string& name) {
  const auto refraction = render::refraction_named(name);
  if (!refraction) throw std::invalid_argument("refraction '" + name + "': live or maps");
  renderer_.set_refraction(*refraction);
}

void WebClient::set_shading(const std::string& name) {
  const auto shading = render::shading_named(name);
  if (!shading)
    throw std::invalid_argument("shading '" + name + "': maps, hemisphere or hemisphere-occlusion");
  renderer_.set_shading(*shading);
}

void WebClient::set_colour(const std::string& name) {
  const auto colour = render::colour_correction_named(name);
  if (!colour)
    throw std::invalid_argument("colour '" + name + "': none, brightness, contrast or match");
  colour_ = *colour;
}

std::span<const render::Material> WebClient::draw_materials() const {
  if (material_name_ != "model") return {};
  return model_materials_;
}

std::string WebClient::set_model(const std::string& name, const val& glb) {
  render::GltfModel model;
  try {
    if (name == "sphere")
      model.mesh = render::make_sphere(0.5f, 48, 96);
    else
      model = render::load_gltf_model(emscripten::convertJSArrayToNumberVector<std::uint8_t>(glb),
                                      name + ".glb");
  } catch (const InputError& e) {
    return e.what();
  }
  const render::Mesh& mesh = model.mesh;
  mesh_ = render::GpuMesh(mesh);
  model_materials_ = std::move(model.materials);
  model_warnings_ = std::move(model.warnings);
  mesh_bounds_ = mesh.bounds;
  model_name_ = name;
  model_vertices_ = mesh.vertex_count();
  model_ = render::standing_on_marker(mesh_bounds_, float(object_height_));
  return {};
}

}  // namespace arlight::web
