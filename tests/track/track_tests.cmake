# The thin client's tracking (client/track), against arlight-sim's ground truth. Included from
# tests/CMakeLists.txt; paths relative to this file.
include(GoogleTest)
add_executable(track_tests
  ${CMAKE_CURRENT_LIST_DIR}/test_pose.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_tracker.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_orientation.cpp)
target_include_directories(track_tests PRIVATE ${CMAKE_CURRENT_LIST_DIR}/..)
target_link_libraries(track_tests PRIVATE arlight_sim arlight_source arlight_track arlight_truth arlight_recording
  arlight_common arlight_warnings GTest::gtest_main nlohmann_json::nlohmann_json opencv_core
  opencv_imgcodecs opencv_imgproc opencv_calib3d opencv_aruco TBB::tbb)
target_compile_definitions(track_tests PRIVATE
  ARLIGHT_SOURCE_DIR="${CMAKE_SOURCE_DIR}")
set_target_properties(track_tests PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
gtest_discover_tests(track_tests DISCOVERY_TIMEOUT 60 PROPERTIES TIMEOUT 120)
