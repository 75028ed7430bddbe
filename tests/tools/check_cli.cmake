# Runs one program and checks how it answered: its exit status and what it printed.
#
#   cmake -DEXIT=N [-DSTDOUT_IS=LINE] [-DSTDOUT_HAS=a|b] [-DSTDERR_HAS=a|b] [-DSTDERR_EMPTY=ON]
#         [-DNO_DISPLAY=ON] -P check_cli.cmake -- PROGRAM [ARGS...]
#
# STDOUT_IS: stdout is exactly LINE and a newline. STDOUT_HAS, STDERR_HAS: '|'-separated
# strings (plain text, not regular expressions) that must each appear. NO_DISPLAY: fail unless
# DISPLAY, WAYLAND_DISPLAY and QT_QPA_PLATFORM are all unset (run it under
# `cmake -E env --unset=...`), so a pass proves the program needed no display.
set(cmd)
set(after_dashes OFF)
math(EXPR last "${CMAKE_ARGC} - 1")
foreach(i RANGE ${last})
  if(after_dashes)
    list(APPEND cmd "${CMAKE_ARGV${i}}")
  elseif(CMAKE_ARGV${i} STREQUAL "--")
    set(after_dashes ON)
  endif()
endforeach()
if(NOT cmd)
  message(FATAL_ERROR "no program given (-- PROGRAM ARGS...)")
endif()

if(NO_DISPLAY)
  foreach(var DISPLAY WAYLAND_DISPLAY QT_QPA_PLATFORM)
    if(DEFINED ENV{${var}})
      message(FATAL_ERROR "${var} is set ('$ENV{${var}}'): this check must run without a display")
    endif()
  endforeach()
endif()

execute_process(COMMAND ${cmd} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 60)
string(REPLACE ";" " " shown "${cmd}")
set(report "command: ${shown}\nexit status: ${rc}\n--- stdout ---\n${out}\n--- stderr ---\n${err}")

set(failures)
if(NOT rc STREQUAL "${EXIT}")
  list(APPEND failures "exit status ${rc}, expected ${EXIT}")
endif()
if(DEFINED STDOUT_IS AND NOT out STREQUAL "${STDOUT_IS}\n")
  list(APPEND failures "stdout is not exactly '${STDOUT_IS}'")
endif()
foreach(stream STDOUT STDERR)
  if(stream STREQUAL "STDOUT")
    set(text "${out}")
  else()
    set(text "${err}")
  endif()
  if(DEFINED ${stream}_HAS)
    string(REPLACE "|" ";" wanted "${${stream}_HAS}")
    foreach(w IN LISTS wanted)
      string(FIND "${text}" "${w}" at)
      if(at EQUAL -1)
        list(APPEND failures "${stream} lacks '${w}'")
      endif()
    endforeach()
  endif()
endforeach()
if(STDERR_EMPTY AND NOT err STREQUAL "")
  list(APPEND failures "stderr is not empty")
endif()

if(failures)
  string(REPLACE ";" "\n  " failures "${failures}")
  message(FATAL_ERROR "\n  ${failures}\n${report}")
endif()
message(STATUS "${report}")
