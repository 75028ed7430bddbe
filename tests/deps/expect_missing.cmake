# Runs scripts/check-deps.py as if PACKAGE were missing from scripts/install-deps.sh and
# requires it to fail naming that package (and only it), a file of it matching FILE_REGEX, and
# the line to add. Arguments: -DSOURCE_DIR= -DPRESET= -DPACKAGE= -DFILE_REGEX=
execute_process(
  COMMAND ${SOURCE_DIR}/scripts/check-deps.py --preset ${PRESET} --reuse --without ${PACKAGE}
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message("${out}${err}")
if(NOT rc EQUAL 1)
  message(FATAL_ERROR "check-deps without ${PACKAGE} exited ${rc}, expected 1 (a missing package)")
endif()
string(REGEX MATCHALL "check-deps: package [^ ]+ is used but" reported "${out}")
list(LENGTH reported count)
if(NOT count EQUAL 1 OR NOT out MATCHES "check-deps: package ${PACKAGE} is used but")
  message(FATAL_ERROR "expected exactly one missing package, ${PACKAGE}; got: ${reported}")
endif()
if(NOT out MATCHES "\n  ${FILE_REGEX}  \\(")
  message(FATAL_ERROR "the report names no file matching ${FILE_REGEX}")
endif()
if(NOT out MATCHES "add this line to PACKAGES in scripts/install-deps.sh:\n    ${PACKAGE}\n")
  message(FATAL_ERROR "the report does not give the line to add")
endif()
