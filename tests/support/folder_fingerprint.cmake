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
