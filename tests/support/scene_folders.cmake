# Helpers of the tests that run the example programs on a make_scene scene.
#
# fresh_scene(WORK ARGS...): empties WORK and writes a scene to WORK/scene with make_scene
# (${MAKE_SCENE}) and ARGS (e.g. --image-size 800x600); a failure of make_scene fails the test.
function(fresh_scene work)
  file(REMOVE_RECURSE "${work}")
  file(MAKE_DIRECTORY "${work}")
  execute_process(COMMAND "${MAKE_SCENE}" "${work}/scene" ${ARGN}
                  RESULT_VARIABLE made OUTPUT_QUIET ERROR_VARIABLE made_err)
  if(NOT made EQUAL 0)
    message(FATAL_ERROR "make_scene failed (${made}): ${made_err}")
  endif()
endfunction()

# folder_fingerprint(FOLDER OUT): every file under FOLDER with its SHA-256, as one list in OUT, so
# that two calls compare equal only when names and contents are the same (the tests' "the inputs
# are left as they were").
function(folder_fingerprint folder out)
  file(GLOB_RECURSE files RELATIVE "${folder}" "${folder}/*")
  set(list "")
  foreach(f IN LISTS files)
    file(SHA256 "${folder}/${f}" hash)
    list(APPEND list "${f}=${hash}")
  endforeach()
  set(${out} "${list}" PARENT_SCOPE)
endfunction()

# check_points_three_times_better(REPORT WHAT): from report.json's text REPORT, the check points' 3D
# RMS after the rough co-registration and after the adjustment; fails the test unless both are
# there with no failed point, the same number used (at least 10), and the adjusted RMS is at least
# 3 times smaller. WHAT names the run in the messages. Prints both RMS.
function(check_points_three_times_better report what)
  if(NOT report MATCHES "\"check_points\": {[^{]*{\"rough\": {\"used\": ([0-9]+), \"failed\": 0, \"rms_3d\": ([0-9.e+-]+)")
    message(FATAL_ERROR "${what}: report.json has no check-point figures after the rough co-registration:\n${report}")
  endif()
  set(rough_used "${CMAKE_MATCH_1}")
  set(rough_rms "${CMAKE_MATCH_2}")
  if(NOT report MATCHES "\"adjusted\": {\"used\": ([0-9]+), \"failed\": 0, \"rms_3d\": ([0-9.e+-]+)")
    message(FATAL_ERROR "${what}: report.json has no check-point figures after the adjustment:\n${report}")
  endif()
  set(adjusted_rms "${CMAKE_MATCH_2}")
  if(rough_used LESS 10 OR NOT CMAKE_MATCH_1 EQUAL rough_used)
    message(FATAL_ERROR "${what}: check points ${rough_used} used after the rough co-registration, ${CMAKE_MATCH_1} after the adjustment")
  endif()
  # CMake's math is integer only: both RMS in thousandths of a unit.
  set(k "")
  foreach(value IN ITEMS "${rough_rms}" "${adjusted_rms}")
    if(NOT value MATCHES "^([0-9]+)(\\.([0-9]*))?$")
      message(FATAL_ERROR "${what}: not a plain decimal number: ${value}")
    endif()
    string(SUBSTRING "${CMAKE_MATCH_3}000" 0 3 fraction)
    math(EXPR thousandths "${CMAKE_MATCH_1} * 1000 + 1${fraction} - 1000")
    list(APPEND k ${thousandths})
  endforeach()
  list(GET k 0 rough_k)
  list(GET k 1 adjusted_k)
  math(EXPR adjusted_k3 "3 * ${adjusted_k}")
  if(NOT adjusted_k3 LESS rough_k)
    message(FATAL_ERROR "${what}: check points not 3 times better after the adjustment: ${rough_rms} -> ${adjusted_rms}")
  endif()
  message(STATUS "${what}: check points 3D RMS ${rough_rms} -> ${adjusted_rms} (epoch-2 units)")
endfunction()

# same_results(A B WHAT): fails the test unless the match_epochs output folders A and B hold the
# same files with the same bytes, but for what measures the run rather than its results: the pair
# jobs' own files (jobs/: they hold their seconds), report.json's "run" line and every "seconds"
# value in report.json and plan.json (whose rough co-registration keeps its time).
function(same_results a b what)
  foreach(side a b)
    cmake_policy(SET CMP0009 NEW)
    file(GLOB_RECURSE files_${side} LIST_DIRECTORIES false RELATIVE "${${side}}" "${${side}}/*")
    list(FILTER files_${side} EXCLUDE REGEX "^jobs/|^slurm/")
    list(SORT files_${side})
  endforeach()
  if(NOT files_a STREQUAL files_b)
    message(FATAL_ERROR "${what}: the two runs wrote different files:\n${files_a}\n--\n${files_b}")
  endif()
  foreach(f IN LISTS files_a)
    if(f STREQUAL "report.json" OR f STREQUAL "plan.json")
      foreach(side a b)
        file(READ "${${side}}/${f}" text_${side})
        string(REGEX REPLACE "\n  \"run\": [^\n]*\n" "\n" text_${side} "${text_${side}}")
        string(REGEX REPLACE "seconds([a-z_]*)(\\\\?)\": ({[^}]*}|[-0-9.e+]+)" "seconds\\1\\2\": -" text_${side}
               "${text_${side}}")
      endforeach()
      if(NOT text_a STREQUAL text_b)
        file(WRITE "${a}.${f}.txt" "${text_a}")
        file(WRITE "${b}.${f}.txt" "${text_b}")
        message(FATAL_ERROR "${what}: ${f} differs beyond the run and its seconds (diff ${a}.${f}.txt ${b}.${f}.txt)")
      endif()
      continue()
    endif()
    if(IS_SYMLINK "${a}/${f}" OR IS_SYMLINK "${b}/${f}")  # links (images, Homol): the same target
      file(READ_SYMLINK "${a}/${f}" target_a)
      file(READ_SYMLINK "${b}/${f}" target_b)
      string(REPLACE "${a}" "" target_a "${target_a}")
      string(REPLACE "${b}" "" target_b "${target_b}")
      set(differ 0)
      if(NOT target_a STREQUAL target_b)
        set(differ 1)
      endif()
    else()
      execute_process(COMMAND "${CMAKE_COMMAND}" -E compare_files "${a}/${f}" "${b}/${f}" RESULT_VARIABLE differ)
    endif()
    if(NOT differ EQUAL 0)
      message(FATAL_ERROR "${what}: ${f} differs between ${a} and ${b}")
    endif()
  endforeach()
endfunction()
