# The GLES 3 renderer, headless (EGL surfaceless on Mesa llvmpipe).
add_executable(render_tests
  render/test_context.cpp
  render/test_shading.cpp
  render/test_mirror.cpp
  render/test_tonemap.cpp
  render/test_surface_maps.cpp
  render/test_gltf.cpp
  render/test_timing.cpp
  render/test_shadow.cpp
  render/test_hemisphere.cpp
  render/test_glass.cpp
  render/test_colour.cpp
  render/test_occlusion.cpp
  render/test_light_count_control.cpp
  render/test_transfer.cpp
  render/test_pbr.cpp
)
target_include_directories(render_tests PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/render)
target_link_libraries(render_tests PRIVATE arlight_render arlight_lighting arlight_common arlight_warnings
  GTest::gtest_main opencv_core opencv_imgproc nlohmann_json::nlohmann_json)
target_compile_definitions(render_tests PRIVATE
  ARLIGHT_ASSETS_DIR="${CMAKE_SOURCE_DIR}/data")
set_target_properties(render_tests PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
gtest_discover_tests(render_tests DISCOVERY_TIMEOUT 60 TEST_PREFIX "render." PROPERTIES LABELS render)
