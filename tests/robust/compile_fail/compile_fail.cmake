# Compile-fail tests: every *.cpp here must fail to compile, and the compiler's output must match
# the regular expression on its `// expect: ` line, so a concept violation is reported by the
# static_assert that names the member at fault rather than by an error deep inside Ransac.
# Each test runs the compiler once with -fsyntax-only (about a second); included from
# tests/CMakeLists.txt.
file(GLOB _compile_fail_sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_LIST_DIR}/*.cpp)
foreach(source IN LISTS _compile_fail_sources)
  get_filename_component(name ${source} NAME_WE)
  file(STRINGS ${source} _expect REGEX "^// expect: " LIMIT_COUNT 1)
  string(REGEX REPLACE "^// expect: " "" _expect "${_expect}")
  add_test(NAME robust/compile_fail_${name}
           COMMAND ${CMAKE_CXX_COMPILER} -std=c++17 -fsyntax-only
                   -I${PROJECT_SOURCE_DIR}/include
                   "-I$<JOIN:$<TARGET_PROPERTY:Eigen3::Eigen,INTERFACE_INCLUDE_DIRECTORIES>,;-I>"
                   ${source}
           COMMAND_EXPAND_LISTS)
  set_tests_properties(robust/compile_fail_${name} PROPERTIES
                       LABELS robust PASS_REGULAR_EXPRESSION "${_expect}" TIMEOUT 120)
endforeach()
