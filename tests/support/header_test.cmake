# Every public header compiles and links alone (included from tests/CMakeLists.txt).
#
# One small source per header under include/diachron: the header, included twice (include guard),
# and an empty main, compiled with -fsyntax-only (parsed and instantiated, no code: the check is about
# declarations). A declaration that is not included fails the compile.
#
# The building blocks (core/, geometry/, robust/, camera/, terrain/, eval/: small headers, where the
# Eigen modules are chosen; a header there that includes a composed header, as eval/match_truth.hpp
# includes synth/, counts as composed, since linking it would emit the composed code again) are also
# link-checked, as programs built at -O0: GCC's -fkeep-inline-functions makes it emit every inline function of the header, used
# or not, so a call whose definition lives in a header that is not included (Eigen's inverse() or
# determinant() with only <Eigen/Core>: declared there, defined in <Eigen/LU>) is an undefined
# reference at link time. (Function templates are checked only where the header itself instantiates
# them; other compilers get the compile check only.) Emitting every inline function of Eigen, OpenCV
# and Ceres doubles a program's build, and the composed headers (matching/ to pipeline/, synth/,
# vision/, io/, adjustment/) parse for 10 to 20 s each, so they get the compile check only: with 90
# headers on 2 cores, the link check of every one of them took 6 of CI's 30 minutes.
# DIACHRON_TEST_HEADERS_LINK_ALL=ON link-checks them too; DIACHRON_TEST_HEADERS_LINK=OFF checks
# the building blocks' compile only (CI does, see scripts/test.sh). Each program links alone: linked
# together, one header's inline functions would supply the definitions another header forgot to
# include.
#
# The umbrella header <diachron/diachron.hpp> has no program: it only includes headers that are each
# checked here, and the consumer test (tests/consumer) compiles it in an outside project.
#
# Each program sees only the dependencies of its component: vision/ gets OpenCV, io/ and the
# synthetic scene writer GDAL, adjustment/ Ceres, everything else diachron::core alone (Eigen,
# nanoflann), so a core header that includes OpenCV, Ceres or GDAL fails too. Programs whose
# component was not configured are left out.
#
# The programs are not part of the default build: the test headers/alone builds them (all of them,
# reporting every failure), so one header that does not stand alone fails that test, not the build.

option(DIACHRON_TEST_HEADERS_LINK "headers/alone: link-check the building blocks" ON)
option(DIACHRON_TEST_HEADERS_LINK_ALL "headers/alone: link-check every header, not only the building blocks" OFF)
set(DIACHRON_HEADER_TEST_JOBS 2 CACHE STRING "Parallel jobs of the headers/alone test's build")
set(_header_root ${PROJECT_SOURCE_DIR}/include)
file(GLOB_RECURSE _headers CONFIGURE_DEPENDS RELATIVE ${_header_root} ${_header_root}/diachron/*.hpp)
set(_header_dir ${CMAKE_CURRENT_BINARY_DIR}/header_test)
add_custom_target(diachron_header_checks)

# Composed: in a composed folder, or including a composed header (directly or through another). The
# includes are read when CMake configures: a header edited to include a composed one changes class at
# the next configure (CI always configures a fresh tree).
set(_composed "")
foreach(header IN LISTS _headers)
  if(NOT header MATCHES "^diachron/(core|geometry|robust|camera|terrain|eval)/")
    list(APPEND _composed ${header})
  endif()
  file(STRINGS ${_header_root}/${header} _lines REGEX "^#include <diachron/")
  string(REGEX REPLACE "#include <(diachron/[^>]+)>[^;]*" "\\1" _includes_of_${header} "${_lines}")
endforeach()
set(_changed TRUE)
while(_changed)
  set(_changed FALSE)
  foreach(header IN LISTS _headers)
    if(header IN_LIST _composed)
      continue()
    endif()
    foreach(included IN LISTS _includes_of_${header})
      if(included IN_LIST _composed)
        list(APPEND _composed ${header})
        set(_changed TRUE)
        break()
      endif()
    endforeach()
  endforeach()
endwhile()

set(_header_count 0)
set(_linked_count 0)
foreach(header IN LISTS _headers)
  if(header STREQUAL "diachron/diachron.hpp")
    continue()
  endif()
  if(header MATCHES "^diachron/vision/")
    set(_component vision)
  elseif(header MATCHES "^diachron/io/" OR header STREQUAL "diachron/synth/scene_io.hpp")
    set(_component io)
  elseif(header MATCHES "^diachron/adjustment/" OR header STREQUAL "diachron/pipeline/combined_adjustment.hpp" OR
         header STREQUAL "diachron/pipeline/combined_epochs.hpp")
    set(_component adjustment)
  else()
    set(_component core)
  endif()
  if(NOT TARGET diachron_${_component})
    continue()
  endif()
  string(REGEX REPLACE "^diachron/(.*)\\.hpp$" "\\1" _name ${header})
  string(REPLACE "/" "_" _name ${_name})
  set(_source ${_header_dir}/${_name}.cpp)
  # Written only when its content changes, so a re-configure does not rebuild every program.
  file(CONFIGURE OUTPUT ${_source} CONTENT
       "#include <${header}>\n#include <${header}>  // twice: the include guard\n\nint main() { return 0; }\n")
  set(_target header_${_name})
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND
     (DIACHRON_TEST_HEADERS_LINK_ALL OR (DIACHRON_TEST_HEADERS_LINK AND NOT header IN_LIST _composed)))
    add_executable(${_target} EXCLUDE_FROM_ALL ${_source})
    target_compile_options(${_target} PRIVATE -O0 -fkeep-inline-functions)
    math(EXPR _linked_count "${_linked_count} + 1")
  else()
    # Compile check only: parsed and instantiated, no code generated, nothing linked (a quarter of
    # the time of an -O0 object and its link). -fsyntax-only writes no object, which nothing needs:
    # the test rebuilds it every time it runs.
    add_library(${_target} OBJECT EXCLUDE_FROM_ALL ${_source})
    target_compile_options(${_target} PRIVATE -fsyntax-only)
  endif()
  target_link_libraries(${_target} PRIVATE diachron::${_component})
  diachron_program(${_target})
  add_dependencies(diachron_header_checks ${_target})
  math(EXPR _header_count "${_header_count} + 1")
endforeach()

set(_keep_going "")
if(CMAKE_GENERATOR MATCHES "Make")
  set(_keep_going -- -k)
elseif(CMAKE_GENERATOR MATCHES "Ninja")
  set(_keep_going -- -k 0)
endif()
add_test(NAME headers/alone
         COMMAND ${CMAKE_COMMAND} --build ${PROJECT_BINARY_DIR} --target diachron_header_checks
                 --parallel ${DIACHRON_HEADER_TEST_JOBS} ${_keep_going})
# The longest test by far: a high COST makes ctest start it first, so that the short tests fill the
# second core around it instead of leaving it to run alone at the end (a fresh build has no timing
# history to schedule by).
set_tests_properties(headers/alone PROPERTIES LABELS headers TIMEOUT 1800 COST 10000)
message(STATUS "diachron: headers/alone checks ${_header_count} public headers, ${_linked_count} of them linked")
