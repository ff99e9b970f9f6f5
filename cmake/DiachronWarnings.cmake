# Flags for our own programs (tests, examples, benchmarks). The library headers must stay warning-free
# under -Wall -Wextra -Wpedantic; third-party headers are SYSTEM includes, so their warnings stay out.
function(diachron_program target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic)
  if(DIACHRON_SANITIZE)
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined -fno-omit-frame-pointer
                                             -fno-sanitize-recover=undefined)
    target_link_options(${target} PRIVATE -fsanitize=address,undefined)
  endif()
endfunction()
