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
