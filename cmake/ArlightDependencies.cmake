# Finds every third-party dependency of arlight. Each one comes from a Debian 12 package
# (deploy/debian-packages.txt, installed by `make deps`); a missing one stops configure with
# a message that names the package to install.

find_package(PkgConfig QUIET)
if(NOT PkgConfig_FOUND)
  message(FATAL_ERROR "pkg-config not found: install the Debian package 'pkg-config' (or run `make deps`).")
endif()

# arlight_find(<Name> DEB <debian-package> [find_package args...])
macro(arlight_find name)
  cmake_parse_arguments(_af "" "DEB" "" ${ARGN})
  find_package(${name} ${_af_UNPARSED_ARGUMENTS} QUIET)
  if(NOT ${name}_FOUND)
    message(FATAL_ERROR
      "arlight needs ${name}: install the Debian package '${_af_DEB}' (or run `make deps`).")
  endif()
endmacro()

# arlight_find_pkgconfig(<prefix> <module> DEB <debian-package>) -> PkgConfig::<prefix>
macro(arlight_find_pkgconfig prefix module)
  cmake_parse_arguments(_ap "" "DEB" "" ${ARGN})
  pkg_check_modules(${prefix} QUIET IMPORTED_TARGET ${module})
  if(NOT ${prefix}_FOUND)
    message(FATAL_ERROR
      "arlight needs ${module} (pkg-config): install the Debian package '${_ap_DEB}' (or run `make deps`).")
  endif()
endmacro()

find_package(Threads REQUIRED)

# common: images, HDR I/O, math
arlight_find(OpenImageIO DEB libopenimageio-dev CONFIG)
arlight_find(OpenEXR DEB libopenexr-dev CONFIG)
arlight_find(glm DEB libglm-dev CONFIG)
arlight_find(TBB DEB libtbb-dev CONFIG)
arlight_find(hwy DEB libhwy-dev CONFIG)

# command lines, logging, JSON
arlight_find(CLI11 DEB libcli11-dev CONFIG)
arlight_find(nlohmann_json DEB nlohmann-json3-dev CONFIG)
arlight_find(fmt DEB libfmt-dev CONFIG)
arlight_find(spdlog DEB libspdlog-dev CONFIG)

# networking, wire schema, compression, TLS (daemon and client)
arlight_find(Boost DEB libboost-system-dev 1.74 CONFIG COMPONENTS system)
arlight_find(FlatBuffers DEB libflatbuffers-dev CONFIG)
find_program(FLATC_EXECUTABLE flatc)
if(NOT FLATC_EXECUTABLE)
  message(FATAL_ERROR "arlight needs flatc: install the Debian package 'flatbuffers-compiler' (or run `make deps`).")
endif()
arlight_find(zstd DEB libzstd-dev CONFIG)
arlight_find_pkgconfig(XXHASH libxxhash DEB libxxhash-dev)
arlight_find(OpenSSL DEB libssl-dev)
# the phone page's URL as a QR code in the terminal
arlight_find_pkgconfig(QRENCODE libqrencode DEB libqrencode-dev)

# capture and tracking
arlight_find(OpenCV DEB "libopencv-dev libopencv-contrib-dev" CONFIG COMPONENTS
  core imgproc imgcodecs calib3d features2d photo video aruco quality)
# libjpeg-turbo directly: frames decode straight to BGR at a reduced scale
arlight_find(JPEG DEB libjpeg62-turbo-dev)
arlight_find_pkgconfig(LIBV4L2 libv4l2 DEB libv4l-dev)

# rendering
arlight_find_pkgconfig(EGL egl DEB libegl-dev)
arlight_find_pkgconfig(GLESV2 glesv2 DEB libgles-dev)
arlight_find(embree DEB libembree-dev 3 CONFIG)
arlight_find(draco DEB libdraco-dev CONFIG)
# glTF's JSON, buffers and materials (tinygltf's header, compiled in: client/render's
# tiny_gltf.hpp says why), its PNG / JPEG textures (stb_image)
find_path(TINYGLTF_INCLUDE_DIR tiny_gltf.h)
if(NOT TINYGLTF_INCLUDE_DIR)
  message(FATAL_ERROR "arlight needs tiny_gltf.h: install the Debian package 'libtinygltf-dev' (or run `make deps`).")
endif()
arlight_find_pkgconfig(STB stb DEB libstb-dev)

# the sun's position (libnova ships neither a CMake config nor a pkg-config file)
find_path(NOVA_INCLUDE_DIR libnova/solar.h)
find_library(NOVA_LIBRARY nova)
if(NOT NOVA_INCLUDE_DIR OR NOT NOVA_LIBRARY)
  message(FATAL_ERROR "arlight needs libnova: install the Debian package 'libnova-dev' (or run `make deps`).")
endif()
add_library(arlight_nova INTERFACE)
target_include_directories(arlight_nova SYSTEM INTERFACE ${NOVA_INCLUDE_DIR})
target_link_libraries(arlight_nova INTERFACE ${NOVA_LIBRARY})

# tests and benchmarks (ZBar reads the phone link's QR code back)
arlight_find_pkgconfig(ZBAR zbar DEB libzbar-dev)
arlight_find(GTest DEB "libgtest-dev libgmock-dev")
arlight_find(benchmark DEB libbenchmark-dev CONFIG)
