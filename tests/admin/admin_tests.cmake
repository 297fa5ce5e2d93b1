# Unit tests of arlight_admin: the Prometheus registry and the admin HTTP server.
# Included from tests/CMakeLists.txt; paths are relative to this file so it works from anywhere.
include(GoogleTest)
add_executable(admin_tests ${CMAKE_CURRENT_LIST_DIR}/test_admin.cpp)
target_link_libraries(admin_tests PRIVATE arlight_admin arlight_warnings GTest::gtest_main)
set_target_properties(admin_tests PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
arlight_discover_sanitized_tests(admin_tests DISCOVERY_TIMEOUT 60 PROPERTIES TIMEOUT 60)
