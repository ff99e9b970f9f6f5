# Provides the target nanoflann::nanoflann, from nanoflann's own package config (1.4 and 1.5+ ship
# one) or, failing that, from the bare header.
if(TARGET nanoflann::nanoflann)
  return()
endif()
find_package(nanoflann QUIET CONFIG)
if(NOT TARGET nanoflann::nanoflann)
  find_path(DIACHRON_NANOFLANN_INCLUDE_DIR nanoflann.hpp)
  if(NOT DIACHRON_NANOFLANN_INCLUDE_DIR)
    message(FATAL_ERROR "diachron: nanoflann.hpp not found (Debian: apt-get install libnanoflann-dev)")
  endif()
  add_library(nanoflann::nanoflann INTERFACE IMPORTED)
  set_target_properties(nanoflann::nanoflann PROPERTIES
                        INTERFACE_INCLUDE_DIRECTORIES "${DIACHRON_NANOFLANN_INCLUDE_DIR}")
endif()
