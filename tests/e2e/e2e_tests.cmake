# Programs end to end: each test runs the real binaries (build/bin) as a user would.
# Included from tests/CMakeLists.txt; paths relative to this file.
include(GoogleTest)
add_executable(e2e_tests
  ${CMAKE_CURRENT_LIST_DIR}/test_arlight_maps.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_arlight_sim.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_arlight_capture.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_arlightd.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_arlightd_web.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_arlight_client.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_arlight_model.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_failover.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_watchers.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_contributors.cpp)
target_include_directories(e2e_tests PRIVATE ${CMAKE_CURRENT_LIST_DIR}/..
  ${CMAKE_SOURCE_DIR}/server/daemon/src)
target_link_libraries(e2e_tests PRIVATE arlight_daemon arlight_lighting arlight_client_net arlight_message_stream arlight_wire arlight_capture
  arlight_sim arlight_truth arlight_recording arlight_common arlight_warnings GTest::gtest_main nlohmann_json::nlohmann_json
  Boost::system OpenSSL::SSL OpenSSL::Crypto opencv_core opencv_imgcodecs opencv_imgproc opencv_aruco
  Threads::Threads)
target_compile_definitions(e2e_tests PRIVATE
  ARLIGHT_SOURCE_DIR="${CMAKE_SOURCE_DIR}"
  ARLIGHT_MAPS_EXE="$<TARGET_FILE:arlight-maps>"
  ARLIGHT_SIM_EXE="$<TARGET_FILE:arlight-sim>"
  ARLIGHT_CAPTURE_EXE="$<TARGET_FILE:arlight-capture>"
  ARLIGHTD_EXE="$<TARGET_FILE:arlightd>"
  ARLIGHT_REPLAY_EXE="$<TARGET_FILE:arlight-replay>"
  ARLIGHT_CLIENT_EXE="$<TARGET_FILE:arlight-client>"
  ARLIGHT_EVAL_EXE="$<TARGET_FILE:arlight-eval>"
  ARLIGHT_MODEL_EXE="$<TARGET_FILE:arlight-model>")
add_dependencies(e2e_tests arlight-maps arlight-sim arlight-capture arlightd arlight-replay
  arlight-client arlight-eval arlight-model)
set_target_properties(e2e_tests PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
arlight_discover_sanitized_tests(e2e_tests DISCOVERY_TIMEOUT 60 PROPERTIES TIMEOUT 300)

# A test program of its own that drives arlightd with arlight-load from the outside (the shared
# support headers only), and its tests with `properties`.
set(ARLIGHT_E2E_DIR ${CMAKE_CURRENT_LIST_DIR})
function(arlight_load_test_program name source)
  add_executable(${name} ${ARLIGHT_E2E_DIR}/${source})
  target_include_directories(${name} PRIVATE ${ARLIGHT_E2E_DIR}/.. ${CMAKE_SOURCE_DIR}/common/include)
  target_link_libraries(${name} PRIVATE arlight_warnings GTest::gtest_main
    nlohmann_json::nlohmann_json Boost::system Threads::Threads)
  target_compile_definitions(${name} PRIVATE
    ARLIGHT_SOURCE_DIR="${CMAKE_SOURCE_DIR}"
    ARLIGHT_SIM_EXE="$<TARGET_FILE:arlight-sim>"
    ARLIGHTD_EXE="$<TARGET_FILE:arlightd>"
    ARLIGHT_LOAD_EXE="$<TARGET_FILE:arlight-load>")
  add_dependencies(${name} arlight-sim arlightd arlight-load)
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
  arlight_discover_sanitized_tests(${name} DISCOVERY_TIMEOUT 60 PROPERTIES ${ARGN})
endfunction()

# arlightd on a machine kept busy by other programs (issue 37 §2): alone, since it fills every
# core on purpose and the other tests' load would change what it measures.
arlight_load_test_program(e2e_busy_machine_tests test_map_sets_under_load.cpp
  TIMEOUT 120 RUN_SERIAL TRUE)

# A phone on a shaped link (issue 36 §3): network namespaces, tbf and nftables; needs root.
arlight_load_test_program(e2e_shaped_link_tests test_shaped_link.cpp TIMEOUT 120)
