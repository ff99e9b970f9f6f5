# The installed package as its users consume it. cmake -P this file with MODE:
#   install_build  install the build tree BUILD_DIR into PREFIX (the example programs included)
#   install_fresh  configure SOURCE_DIR as a top-level project into WORK_DIR with CONFIGURE_ARGS
#                  (comma-separated), check that the tests were not enabled, install into PREFIX
#   consume        configure, build and run tests/consumer/project against PREFIX in WORK_DIR, with
#                  DIACHRON_COMPONENTS / FORBIDDEN_PACKAGES / WITH_IO (see project/CMakeLists.txt);
#                  with EXPECT_FAILURE (a regex) the configure must fail with a message matching it
cmake_minimum_required(VERSION 3.16)

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  set(rc ${rc} PARENT_SCOPE)
  set(out "${out}${err}" PARENT_SCOPE)
endfunction()

function(run_or_fail what)
  run(${ARGN})
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc}):\n${out}")
  endif()
  set(out "${out}" PARENT_SCOPE)
endfunction()

if(MODE STREQUAL "install_build")
  file(REMOVE_RECURSE ${PREFIX})
  run_or_fail("installing ${BUILD_DIR}" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${PREFIX})
  string(REPLACE "," ";" programs "${EXPECT_PROGRAMS}")
  foreach(program IN LISTS programs)
    if(NOT EXISTS ${PREFIX}/bin/${program})
      message(FATAL_ERROR "the example program ${program} was not installed in ${PREFIX}/bin")
    endif()
  endforeach()
  foreach(file estimators.cpp rough_coregistration.cpp test_estimators.hpp)
    if(NOT EXISTS ${PREFIX}/share/doc/diachron/examples/${file})
      message(FATAL_ERROR "the worked example ${file} was not installed in share/doc/diachron/examples")
    endif()
  endforeach()

elseif(MODE STREQUAL "install_fresh")
  file(REMOVE_RECURSE ${WORK_DIR} ${PREFIX})
  string(REPLACE "," ";" args "${CONFIGURE_ARGS}")
  run_or_fail("configuring diachron (${CONFIGURE_ARGS})"
              ${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${WORK_DIR} ${args})
  message(STATUS "${out}")
  file(STRINGS ${WORK_DIR}/CMakeCache.txt tests_option REGEX "^DIACHRON_BUILD_TESTS:")
  if(NOT tests_option MATCHES "=OFF$")
    message(FATAL_ERROR "tests were enabled without Catch2: ${tests_option}")
  endif()
  run_or_fail("installing ${WORK_DIR}" ${CMAKE_COMMAND} --install ${WORK_DIR} --prefix ${PREFIX})

elseif(MODE STREQUAL "consume")
  file(REMOVE_RECURSE ${WORK_DIR})
  # No build type (no optimisation): the test is about the package, and -O3 tripled its build.
  run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/consumer/project -B ${WORK_DIR}
      -DCMAKE_PREFIX_PATH=${PREFIX} -DCMAKE_BUILD_TYPE=
      -DDIACHRON_COMPONENTS=${DIACHRON_COMPONENTS} -DFORBIDDEN_PACKAGES=${FORBIDDEN_PACKAGES}
      -DWITH_IO=${WITH_IO})
  if(DEFINED EXPECT_FAILURE)
    if(rc EQUAL 0)
      message(FATAL_ERROR "find_package(diachron COMPONENTS ${DIACHRON_COMPONENTS}) should have failed:\n${out}")
    endif()
    string(REGEX REPLACE "[ \t\r\n]+" " " flat "${out}")
    if(NOT flat MATCHES "${EXPECT_FAILURE}")
      message(FATAL_ERROR "the failure does not say '${EXPECT_FAILURE}':\n${out}")
    endif()
    message(STATUS "failed as expected:\n${out}")
    return()
  endif()
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "configuring the consumer failed (${rc}):\n${out}")
  endif()
  message(STATUS "${out}")
  run_or_fail("building the consumer" ${CMAKE_COMMAND} --build ${WORK_DIR})
  run_or_fail("the consumer" ${WORK_DIR}/consumer)
  message(STATUS "consumer said: ${out}")
  if(WITH_IO)
    run_or_fail("consumer_io" ${WORK_DIR}/consumer_io ${WORK_DIR})
    message(STATUS "consumer_io said: ${out}")
  endif()

else()
  message(FATAL_ERROR "run_consumer.cmake: unknown MODE '${MODE}'")
endif()
