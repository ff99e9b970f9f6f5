# Flags for our own programs (tests, examples, benchmarks). The library headers must stay warning-free
# under -Wall -Wextra -Wpedantic; third-party headers are SYSTEM includes, so their warnings stay out.
function(diachron_program target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic)
  if(DIACHRON_SANITIZE)
    # GCC's -Wmaybe-uninitialized gives false positives inside Eigen and libstdc++ under sanitizer
    # instrumentation (seen in Eigen's check_for_aliasing and std::regex); the Release build keeps it.
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined -fno-omit-frame-pointer
                                             -fno-sanitize-recover=undefined -Wno-maybe-uninitialized)
    if(DIACHRON_SANITIZE_UNDEFINED_EXCLUDE)
      target_compile_options(${target} PRIVATE -fno-sanitize=${DIACHRON_SANITIZE_UNDEFINED_EXCLUDE})
    endif()
    target_link_options(${target} PRIVATE -fsanitize=address,undefined)
    # Under ASan, Eigen stops trusting malloc's 16-byte alignment and allocates with an offset of its
    # own, while Ceres, built without ASan, frees with plain free the matrices its inline code shares
    # with ours: ASan stopped on that bad free in ceres::Covariance over a SubsetManifold block. ASan's
    # malloc is 16-byte aligned on x86-64 (checked over sizes 1-5000), so both sides can agree.
    target_compile_definitions(${target} PRIVATE EIGEN_MALLOC_ALREADY_ALIGNED=1)
  endif()
endfunction()
