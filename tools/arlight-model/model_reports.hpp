// What arlight-model reports of a model (JSON), and the bakes it times: a shell's helpers over
// arlight_render's glTF reader, its transfer bake (Embree) and its colour priors.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "arlight/render/gltf.hpp"
#include "arlight/render/transfer.hpp"

namespace arlight::model_tool {

// Its vertex and triangle counts, what it carries (UVs, occlusion, transfer, ground), bounds.
nlohmann::json describe(const render::Mesh& m);
// Each glTF material: its factors, textures (field and size) and the triangles drawn with it.
nlohmann::json describe_materials(const render::GltfModel& model);
// Self-shadowing of the model's own vertices (tutorial §6.1): the bake's time and what it found.
nlohmann::json bake(const render::Mesh& m, const TransferOptions& options);
// Thesis Alg. 5.2's light map of the model's occlusion of itself over its UVs, written to
// `output` as an 8-bit grey PNG of size x size; its time and the share of texels covered.
// InputError for a model without UVs (`input` names it).
nlohmann::json light_map(const render::Mesh& mesh, const std::string& input, int size,
                         int directions, const std::string& output);
// The colour priors of the model's albedo texture over the texels its UVs cover (dissertation
// §5.1.1): mean and deviation in l alpha beta. InputError when no texel is covered.
nlohmann::json colour_priors(const render::Mesh& mesh, const std::string& input,
                             const std::string& albedo);

}  // namespace arlight::model_tool
