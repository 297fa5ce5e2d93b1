// tinygltf's implementation (see tiny_gltf.hpp).
#define TINYGLTF_IMPLEMENTATION
#include "tiny_gltf.hpp"
