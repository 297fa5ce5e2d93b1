// stb_image's implementation for the WebAssembly build (natively, Debian's libstb has it): the
// PNG and JPEG textures of the page's glTF models (client/render/src/gltf.cpp).
#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
#define STBI_NO_STDIO
#include <stb_image.h>
