# The browser client, built with the native build: client/web is a project of its own compiled by
# emscripten (its CMakeLists.txt); this runs it as an external project and puts the page where
# arlightd serves it from by default, build/bin/web/ (index.html, its scripts, the WebAssembly
# module). `make build` (and so `make test` and `make demo`) builds it.
include(ExternalProject)
find_program(EMCMAKE_EXECUTABLE emcmake)
if(NOT EMCMAKE_EXECUTABLE)
  message(FATAL_ERROR "arlight needs emscripten for the browser client: install the Debian package 'emscripten' (or run `make deps`).")
endif()

set(ARLIGHT_WEB_DIR ${CMAKE_BINARY_DIR}/bin/web)
# emscripten's Node tools need Debian's Node modules where the machine's node is not Debian's.
set(ARLIGHT_EMSCRIPTEN_ENV ${CMAKE_COMMAND} -E env NODE_PATH=/usr/share/nodejs)
ExternalProject_Add(arlight_web_module
  SOURCE_DIR ${CMAKE_SOURCE_DIR}/client/web
  BINARY_DIR ${CMAKE_BINARY_DIR}/web-module
  CONFIGURE_COMMAND ${ARLIGHT_EMSCRIPTEN_ENV} ${EMCMAKE_EXECUTABLE} ${CMAKE_COMMAND}
                    -S <SOURCE_DIR> -B <BINARY_DIR> -G Ninja -DCMAKE_BUILD_TYPE=Release
  BUILD_COMMAND ${ARLIGHT_EMSCRIPTEN_ENV} ${CMAKE_COMMAND} --build <BINARY_DIR>
  INSTALL_COMMAND ${CMAKE_COMMAND} -E make_directory ${ARLIGHT_WEB_DIR}
  COMMAND ${CMAKE_COMMAND} -E copy_if_different <BINARY_DIR>/arlight_web.js
          <BINARY_DIR>/arlight_web.wasm ${ARLIGHT_WEB_DIR}
  COMMAND ${CMAKE_COMMAND} -E make_directory ${ARLIGHT_WEB_DIR}/three
  COMMAND ${CMAKE_COMMAND} -E copy_if_different <BINARY_DIR>/arlight_light.js
          <BINARY_DIR>/arlight_light.wasm ${ARLIGHT_WEB_DIR}/three
  BUILD_ALWAYS ON  # its own ninja decides what is out of date
  USES_TERMINAL_BUILD ON)

# The page's own files, copied when they change, and opencv.js for its tracking worker (npm
# `@techstark/opencv-js`, pinned in client/web/package-lock.json; `make deps` runs npm ci).
set(ARLIGHT_OPENCV_JS ${CMAKE_SOURCE_DIR}/client/web/node_modules/@techstark/opencv-js)
if(NOT EXISTS ${ARLIGHT_OPENCV_JS}/dist/opencv.js)
  message(FATAL_ERROR "the browser client needs opencv.js: run `make deps` (npm ci in client/web)")
endif()
configure_file(${ARLIGHT_OPENCV_JS}/LICENSE ${ARLIGHT_WEB_DIR}/opencv.js.LICENSE COPYONLY)
file(GLOB ARLIGHT_WEB_PAGE CONFIGURE_DEPENDS
  ${CMAKE_SOURCE_DIR}/client/web/index.html
  ${CMAKE_SOURCE_DIR}/client/web/three.html
  ${CMAKE_SOURCE_DIR}/client/web/style.css
  ${CMAKE_SOURCE_DIR}/client/web/src/*.js
  ${ARLIGHT_OPENCV_JS}/dist/opencv.js)
set(ARLIGHT_WEB_PAGE_STAMP ${CMAKE_BINARY_DIR}/web-page.stamp)
add_custom_command(OUTPUT ${ARLIGHT_WEB_PAGE_STAMP}
  COMMAND ${CMAKE_COMMAND} -E make_directory ${ARLIGHT_WEB_DIR}
  COMMAND ${CMAKE_COMMAND} -E copy_if_different ${ARLIGHT_WEB_PAGE} ${ARLIGHT_WEB_DIR}
  COMMAND ${CMAKE_COMMAND} -E touch ${ARLIGHT_WEB_PAGE_STAMP}
  DEPENDS ${ARLIGHT_WEB_PAGE}
  COMMENT "The browser client's page -> bin/web")
# The page's models (bin/web/models/): the bundled ones re-encoded without Draco, which the
# WebAssembly build cannot decode, with their occlusion of themselves baked in (the page cannot
# ray-cast: it downloads the bake from arlightd with the model).
set(ARLIGHT_WEB_MODELS)
foreach(pair "bunny.glb;bunny.glb" "suzi.glb;suzanne.glb" "tiles.glb;tiles.glb")
  list(GET pair 0 from)
  list(GET pair 1 to)
  set(out ${ARLIGHT_WEB_DIR}/models/${to})
  add_custom_command(OUTPUT ${out}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${ARLIGHT_WEB_DIR}/models
    COMMAND arlight-model convert --bake ${CMAKE_SOURCE_DIR}/data/models/${from} ${out} > /dev/null
    DEPENDS arlight-model ${CMAKE_SOURCE_DIR}/data/models/${from}
    COMMENT "The page's model ${to} (no Draco)")
  list(APPEND ARLIGHT_WEB_MODELS ${out})
endforeach()
# /three.html's: the three.js provider (client/web/three/src, served at three/) and the parts of
# three.js it and the page import (npm `three`, pinned in client/web/package-lock.json), under
# three/lib/ where the page's import map points.
set(ARLIGHT_THREE ${CMAKE_SOURCE_DIR}/client/web/node_modules/three)
if(NOT EXISTS ${ARLIGHT_THREE}/build/three.module.js)
  message(FATAL_ERROR "the three.js page needs three: run `make deps` (npm ci in client/web)")
endif()
set(ARLIGHT_THREE_FROM build/three.module.js build/three.core.js LICENSE
  examples/jsm/loaders/GLTFLoader.js examples/jsm/utils/BufferGeometryUtils.js
  examples/jsm/utils/SkeletonUtils.js)
set(ARLIGHT_THREE_TO three.module.js three.core.js LICENSE addons/loaders/GLTFLoader.js
  addons/utils/BufferGeometryUtils.js addons/utils/SkeletonUtils.js)
set(ARLIGHT_WEB_THREE)
foreach(from to IN ZIP_LISTS ARLIGHT_THREE_FROM ARLIGHT_THREE_TO)
  set(out ${ARLIGHT_WEB_DIR}/three/lib/${to})
  add_custom_command(OUTPUT ${out}
    COMMAND ${CMAKE_COMMAND} -E copy_if_different ${ARLIGHT_THREE}/${from} ${out}
    DEPENDS ${ARLIGHT_THREE}/${from})
  list(APPEND ARLIGHT_WEB_THREE ${out})
endforeach()
set(out ${ARLIGHT_WEB_DIR}/three/ArlightEstimatedLight.js)
add_custom_command(OUTPUT ${out}
  COMMAND ${CMAKE_COMMAND} -E copy_if_different
          ${CMAKE_SOURCE_DIR}/client/web/three/src/ArlightEstimatedLight.js ${out}
  DEPENDS ${CMAKE_SOURCE_DIR}/client/web/three/src/ArlightEstimatedLight.js)
list(APPEND ARLIGHT_WEB_THREE ${out})
add_custom_target(arlight_web ALL DEPENDS ${ARLIGHT_WEB_PAGE_STAMP} ${ARLIGHT_WEB_MODELS}
  ${ARLIGHT_WEB_THREE} arlight_web_module)
