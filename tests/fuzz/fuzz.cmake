# The fuzz targets: one per parser of untrusted bytes (tests/fuzz/fuzz_<name>.cpp). In the
# fuzzing build (ARLIGHT_FUZZ, clang; `make fuzz`) each links libFuzzer's main; in every other
# build it links replay_main.cpp, which runs given inputs once. Either way ctest runs each target
# on its committed corpus (tests/fuzz/corpus/<name>/: the seeds and every input that once
# crashed it, kept as regressions). Included from tests/CMakeLists.txt.
set(ARLIGHT_FUZZ_DIR ${CMAKE_CURRENT_SOURCE_DIR}/fuzz)
set(ARLIGHT_FUZZ_TARGETS wire recording checkpoint config hdr_image gltf jpeg_frame)

add_custom_target(fuzz_targets)  # `make fuzz` builds only these

# libFuzzer's coverage (edges and comparisons) in the code that parses the targets' bytes: the
# protocol and recording libraries, the daemon's (checkpoints, config, tokens) and the parsers of
# HDR images, glTF and JPEG frames. Not in the numeric code behind them (projection, SH,
# convolution, rendering), whose edges say nothing about the input's structure: instrumented
# everywhere, the sanitized test suite, built in the same folder, ran 2-2.5x slower.
if(ARLIGHT_FUZZ)
  set(ARLIGHT_FUZZ_COVERAGE -fsanitize=fuzzer-no-link)
  foreach(lib arlight_wire arlight_recording arlight_message_stream arlight_daemon)
    target_compile_options(${lib} PRIVATE ${ARLIGHT_FUZZ_COVERAGE})
  endforeach()
  set_source_files_properties(${CMAKE_SOURCE_DIR}/common/src/hdr_io.cpp
    TARGET_DIRECTORY arlight_common PROPERTIES COMPILE_OPTIONS ${ARLIGHT_FUZZ_COVERAGE})
  set_source_files_properties(${CMAKE_SOURCE_DIR}/client/render/src/gltf.cpp
    ${CMAKE_SOURCE_DIR}/client/render/src/mesh.cpp
    TARGET_DIRECTORY arlight_render PROPERTIES COMPILE_OPTIONS ${ARLIGHT_FUZZ_COVERAGE})
  set_source_files_properties(${CMAKE_SOURCE_DIR}/server/capture/src/jpeg_decode.cpp
    TARGET_DIRECTORY arlight_capture PROPERTIES COMPILE_OPTIONS ${ARLIGHT_FUZZ_COVERAGE})
endif()
function(arlight_fuzz_target name)
  add_executable(fuzz_${name} ${ARLIGHT_FUZZ_DIR}/fuzz_${name}.cpp)
  add_dependencies(fuzz_targets fuzz_${name})
  target_link_libraries(fuzz_${name} PRIVATE ${ARGN} arlight_common arlight_warnings)
  target_compile_definitions(fuzz_${name} PRIVATE ARLIGHT_SOURCE_DIR="${CMAKE_SOURCE_DIR}")
  target_include_directories(fuzz_${name} PRIVATE ${ARLIGHT_FUZZ_DIR})
  set_target_properties(fuzz_${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
  set(corpus ${ARLIGHT_FUZZ_DIR}/corpus/${name})
  if(ARLIGHT_FUZZ)
    target_link_options(fuzz_${name} PRIVATE -fsanitize=fuzzer)
    add_test(NAME fuzz.${name} COMMAND fuzz_${name} -runs=0 ${corpus})
  else()
    target_sources(fuzz_${name} PRIVATE ${ARLIGHT_FUZZ_DIR}/replay_main.cpp)
    add_test(NAME fuzz.${name} COMMAND fuzz_${name} ${corpus})
  endif()
  set_tests_properties(fuzz.${name} PROPERTIES LABELS sanitize)
endfunction()

arlight_fuzz_target(wire arlight_wire)
arlight_fuzz_target(recording arlight_recording opencv_core opencv_imgcodecs)
arlight_fuzz_target(checkpoint arlight_daemon arlight_capture)
target_include_directories(fuzz_checkpoint PRIVATE ${CMAKE_SOURCE_DIR}/server/daemon/src)
arlight_fuzz_target(config arlight_daemon)
target_include_directories(fuzz_config PRIVATE ${CMAKE_SOURCE_DIR}/server/daemon/src)
arlight_fuzz_target(hdr_image)
arlight_fuzz_target(gltf arlight_render)
arlight_fuzz_target(jpeg_frame arlight_capture opencv_core opencv_imgcodecs)
