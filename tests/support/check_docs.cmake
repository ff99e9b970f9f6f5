# The repository's documentation stands alone (cmake -DSOURCE_DIR=... -P this file): no header, test,
# example, benchmark or doc refers to the design notes kept outside the repository, and every
# docs/<name>.md that one of them names exists.
file(GLOB_RECURSE files RELATIVE ${SOURCE_DIR}
     ${SOURCE_DIR}/include/*.hpp ${SOURCE_DIR}/tests/*.cpp ${SOURCE_DIR}/tests/*.hpp
     ${SOURCE_DIR}/examples/*.cpp ${SOURCE_DIR}/bench/*.cpp ${SOURCE_DIR}/bench/*.hpp
     ${SOURCE_DIR}/docs/*.md ${SOURCE_DIR}/README.md)
set(outside "DESIGN" ".md")  # spelt in two parts, so this file does not name it
string(CONCAT outside ${outside})
set(problems "")
foreach(file IN LISTS files)
  file(STRINGS ${SOURCE_DIR}/${file} lines)
  set(number 0)
  foreach(line IN LISTS lines)
    math(EXPR number "${number} + 1")
    string(FIND "${line}" "${outside}" at)
    if(NOT at EQUAL -1)
      string(APPEND problems "\n  ${file}:${number}: refers to ${outside}, which is not in the repository")
    endif()
    string(REGEX MATCHALL "docs/[a-z0-9_-]+\\.md" named "${line}")
    foreach(doc IN LISTS named)
      if(NOT EXISTS ${SOURCE_DIR}/${doc})
        string(APPEND problems "\n  ${file}:${number}: names ${doc}, which does not exist")
      endif()
    endforeach()
  endforeach()
endforeach()
list(LENGTH files count)
if(problems)
  message(FATAL_ERROR "the documentation does not stand alone:${problems}")
endif()
message(STATUS "${count} files checked: no reference outside the repository")
