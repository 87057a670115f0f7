# Default per-configuration Fortran flags of a top-level trainsim build.
#
# Loaded through CMAKE_USER_MAKE_RULES_OVERRIDE_Fortran (CMakeLists.txt), i.e. after
# CMake's own compiler defaults and before the CMAKE_Fortran_FLAGS_<CONFIG> cache
# entries are created: these are defaults only. A value given with -D, or already in
# the cache of an existing build folder, wins. As a subproject (add_subdirectory,
# FetchContent) trainsim leaves the parent's flags alone and this file is not used.
if(CMAKE_Fortran_COMPILER_ID STREQUAL "GNU")
  set(CMAKE_Fortran_FLAGS_RELEASE_INIT "-O2 -march=x86-64-v2")
  set(CMAKE_Fortran_FLAGS_DEBUG_INIT "-O0 -g -fcheck=all -fbacktrace -ffpe-trap=invalid,zero,overflow")
endif()
