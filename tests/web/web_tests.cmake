# The browser client's tests, run by Node's test runner: the orientation conversion (unit), the
# marker tracking step (opencv.js) against arlight-sim's truth, the browser harness against real
# headless Chromium, a whole phone-shaped session against a real arlightd, and the page's marker
# tracking and focal-length refinement in Chromium. Included from tests/CMakeLists.txt; `make
# deps` installs node_modules (npm ci).
find_program(NODE_EXECUTABLE NAMES node nodejs)
if(NOT NODE_EXECUTABLE)
  message(FATAL_ERROR "arlight's browser tests need Node.js: install the Debian package 'nodejs' (or run `make deps`).")
endif()
set(ARLIGHT_WEB_TEST_DIR ${CMAKE_SOURCE_DIR}/tests/web)
add_test(NAME web.orientation
  COMMAND ${NODE_EXECUTABLE} --test ${ARLIGHT_WEB_TEST_DIR}/orientation.test.mjs)
add_test(NAME web.guide
  COMMAND ${NODE_EXECUTABLE} --test ${ARLIGHT_WEB_TEST_DIR}/guide.test.mjs)
add_test(NAME web.harness
  COMMAND ${NODE_EXECUTABLE} --test ${ARLIGHT_WEB_TEST_DIR}/harness.test.mjs)
add_test(NAME web.marker
  COMMAND ${NODE_EXECUTABLE} --test ${ARLIGHT_WEB_TEST_DIR}/marker.test.mjs)
set_tests_properties(web.marker PROPERTIES TIMEOUT 300
  ENVIRONMENT "ARLIGHT_BIN=${CMAKE_BINARY_DIR}/bin")
add_test(NAME web.browser_session
  COMMAND ${NODE_EXECUTABLE} --test ${ARLIGHT_WEB_TEST_DIR}/browser_session.test.mjs)
add_test(NAME web.marker_session
  COMMAND ${NODE_EXECUTABLE} --test ${ARLIGHT_WEB_TEST_DIR}/marker_session.test.mjs)
add_test(NAME web.marker_motion
  COMMAND ${NODE_EXECUTABLE} --test ${ARLIGHT_WEB_TEST_DIR}/marker_motion.test.mjs)
add_test(NAME web.shadow_control
  COMMAND ${NODE_EXECUTABLE} --test ${ARLIGHT_WEB_TEST_DIR}/shadow_control.test.mjs)
add_test(NAME web.failover
  COMMAND ${NODE_EXECUTABLE} --test ${ARLIGHT_WEB_TEST_DIR}/failover.test.mjs)
# Two phones, one room (issue 49 §1): a second page joins the first one's session by its link.
add_test(NAME web.two_phones
  COMMAND ${NODE_EXECUTABLE} --test ${ARLIGHT_WEB_TEST_DIR}/two_phones.test.mjs)
set_tests_properties(web.harness web.browser_session web.marker_session web.marker_motion
  web.shadow_control web.failover web.two_phones PROPERTIES
  TIMEOUT 400
  # Chromium and SwiftShader want both cores, and the session's sensor pacing wants the page
  # not starved: these run alone (1 of 3 full `ctest -j2` runs failed the session test when it
  # shared the cores with the other tests).
  RUN_SERIAL TRUE
  ENVIRONMENT "ARLIGHT_BIN=${CMAKE_BINARY_DIR}/bin;ARLIGHT_SOURCE_DIR=${CMAKE_SOURCE_DIR}")

# The page against the native renderer, pixel for pixel (page_pixels.test.mjs): its native side.
add_executable(web_pixel_reference ${ARLIGHT_WEB_TEST_DIR}/web_pixel_reference.cpp)
target_link_libraries(web_pixel_reference PRIVATE arlight_render arlight_wire arlight_common
  arlight_warnings nlohmann_json::nlohmann_json opencv_core opencv_imgcodecs)
set_target_properties(web_pixel_reference PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
add_test(NAME web.page_pixels
  COMMAND ${NODE_EXECUTABLE} --test ${ARLIGHT_WEB_TEST_DIR}/page_pixels.test.mjs)
set_tests_properties(web.page_pixels PROPERTIES TIMEOUT 300 RUN_SERIAL TRUE
  ENVIRONMENT "ARLIGHT_BIN=${CMAKE_BINARY_DIR}/bin;ARLIGHT_SOURCE_DIR=${CMAKE_SOURCE_DIR};ARLIGHT_WEB_PIXEL_REFERENCE=${CMAKE_BINARY_DIR}/tests/web_pixel_reference")

# The light files (arlight-maps export) read by ktx-parse and gltf-validator (npm, pinned).
add_test(NAME web.light_files
  COMMAND ${NODE_EXECUTABLE} --test ${ARLIGHT_WEB_TEST_DIR}/light_files.test.mjs)
set_tests_properties(web.light_files PROPERTIES TIMEOUT 120
  ENVIRONMENT "ARLIGHT_BIN=${CMAKE_BINARY_DIR}/bin;ARLIGHT_SOURCE_DIR=${CMAKE_SOURCE_DIR}")
# specular.ktx2 through three.js's KTX2Loader into WebGL2 in headless Chromium.
add_test(NAME web.three_ktx2
  COMMAND ${NODE_EXECUTABLE} --test ${ARLIGHT_WEB_TEST_DIR}/three_ktx2.test.mjs)
set_tests_properties(web.three_ktx2 PROPERTIES TIMEOUT 300 RUN_SERIAL TRUE
  ENVIRONMENT "ARLIGHT_BIN=${CMAKE_BINARY_DIR}/bin;ARLIGHT_SOURCE_DIR=${CMAKE_SOURCE_DIR}")
# /three.html (issue 35): three.js's scene lit by ArlightEstimatedLight watching a session
# arlight-replay captured into arlightd; SH, primary light and the environment against the session.
add_test(NAME web.three_page
  COMMAND ${NODE_EXECUTABLE} --test ${ARLIGHT_WEB_TEST_DIR}/three_page.test.mjs)
set_tests_properties(web.three_page PROPERTIES TIMEOUT 300 RUN_SERIAL TRUE
  ENVIRONMENT "ARLIGHT_BIN=${CMAKE_BINARY_DIR}/bin;ARLIGHT_SOURCE_DIR=${CMAKE_SOURCE_DIR}")
