# Configures the project with the widget, viewer, Designer plugin and tests off, traced, and
# fails if that read any file of a Qt package: the engine, its CMake package and the tools
# must build on a machine without Qt. Arguments: -DSOURCE_DIR= -DWORK=
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
execute_process(
  COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${WORK} -G Ninja
          -DIRIS_BUILD_WIDGET=OFF -DIRIS_BUILD_TESTS=OFF
          --trace-expand --trace-format=json-v1 --trace-redirect=${WORK}/trace.json
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "engine-only configure failed:\n${out}${err}")
endif()
file(STRINGS ${WORK}/trace.json qt_lines REGEX "\"file\":\"[^\"]*/(cmake/Qt6|qt6/)")
if(qt_lines)
  list(GET qt_lines 0 first)
  message(FATAL_ERROR "the engine-only configure read Qt's CMake files, e.g. ${first}")
endif()
file(READ ${WORK}/build.ninja ninja)
if(NOT ninja MATCHES "libiris_engine\\.so" OR ninja MATCHES "libiris_widget|iris-viewer")
  message(FATAL_ERROR "the engine-only build should make libiris_engine and no widget or viewer")
endif()
message("engine-only configure: no Qt file read; libiris_engine and the tools are built")
