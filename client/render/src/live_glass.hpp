// Internal: live glass (Refraction::LiveFrame, dissertation §5.5.3). A transmissive material
// drawn under it is deferred to the composite, when the output holds the camera frame: the
// frame is copied (the output cannot be sampled and drawn at once, as Filament's screen-space
// refraction copies its colour buffer) and the glass drawn into the HDR target refracting it.
#pragma once

#include <vector>

#include "arlight/render/render.hpp"
#include "fullscreen_pass.hpp"
#include "ibl_pass.hpp"

namespace arlight::render {

class LiveGlass {
 public:
  void begin_frame() { deferred_.clear(); }
  // The mesh must live until draw().
  void defer(const GpuMesh& mesh, const Material& material, const glm::mat4& model,
             const DrawState& state, const MeshPart& part) {
    deferred_.push_back({&mesh, material, model, state, part});
  }
  // Copies the frame in targets.out_fbo and draws the deferred glass into the HDR target, with
  // the frame's exposure and the camera's inverse response; `rgb`: the output holds R, G, B.
  // Returns the milliseconds it took (0 with nothing deferred); waits for the GPU unless `rgb`
  // (the browser's path never waits).
  double draw(const RenderTargets& targets, const ToneMapping& tone, bool rgb, IblPass& ibl,
              const SceneLighting& lighting, GLuint response_inverse);

 private:
  struct Deferred {
    const GpuMesh* mesh;
    Material material;
    glm::mat4 model;
    DrawState state;
    MeshPart part;
  };
  std::vector<Deferred> deferred_;  // this frame's
  gl::Texture frame_copy_;          // what the glass samples, made when first used
};

}  // namespace arlight::render
