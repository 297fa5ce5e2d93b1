// Internal: tinygltf as arlight compiles it (its documented header-only use: the implementation
// is tiny_gltf.cpp) under a namespace of arlight's own. Debian's libdraco carries another
// version of tinygltf and exports its tinygltf:: symbols, so a program linking both Debian
// libraries mixes the two versions' code (it crashed); renamed, ours cannot meet draco's. Images
// are decoded by gltf.cpp (stb_image), so tinygltf needs no stb of its own.
#pragma once

#define tinygltf arlight_tinygltf
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#include <tiny_gltf.h>
