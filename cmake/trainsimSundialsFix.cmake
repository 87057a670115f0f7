# Debian's SUNDIALS 6.4 Fortran targets name /usr/fortran (absent) as their include
# directory, and CMake stops at generate time. Point every imported SUNDIALS:: target of
# the current directory at the folder that really holds the .mod files
# (/usr/include/sundials/fortran). Idempotent; a no-op where SUNDIALS is packaged right.
# Used by trainsim's own CMakeLists.txt and by the installed trainsimConfig.cmake.
function(trainsim_fix_sundials_targets)
  find_path(TRAINSIM_SUNDIALS_MODDIR fcvode_mod.mod
            HINTS ${SUNDIALS_DIR}/../../../include
            PATHS /usr/include /usr/local/include
            PATH_SUFFIXES sundials/fortran fortran)
  if(NOT TRAINSIM_SUNDIALS_MODDIR)
    message(FATAL_ERROR "trainsim: cannot find the SUNDIALS Fortran module fcvode_mod.mod "
                        "(set TRAINSIM_SUNDIALS_MODDIR to the folder that holds it)")
  endif()
  get_property(_imported DIRECTORY PROPERTY IMPORTED_TARGETS)
  foreach(_t IN LISTS _imported)
    if(_t MATCHES "^SUNDIALS::")
      get_target_property(_inc ${_t} INTERFACE_INCLUDE_DIRECTORIES)
      if(_inc)
        list(FILTER _inc EXCLUDE REGEX "^/usr/fortran$")
        list(APPEND _inc ${TRAINSIM_SUNDIALS_MODDIR})
        list(REMOVE_DUPLICATES _inc)
        set_target_properties(${_t} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_inc}")
      endif()
    endif()
  endforeach()
endfunction()
