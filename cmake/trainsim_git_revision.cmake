# Write the git revision of the source tree into a Fortran file, at build time.
#
#   cmake -DSOURCE_DIR=<src> -DOUTPUT=<file.f90> -P trainsim_git_revision.cmake
#
# Run by the `trainsim_revision` target before every build of the library, so
# the revision follows commits made after configuring. The file is rewritten
# only when its text changes (configure_file semantics), and the revision is
# the body of a function, not a parameter, so a new commit recompiles one file
# and relinks: no module that uses it changes.
# Without git, or when the sources are not the top of a git work tree (a release
# tarball, a copy inside another repository), the revision is "unknown".
set(rev "unknown")
find_package(Git QUIET)
if(GIT_FOUND)
  # Only trainsim's own work tree: a copy of the sources inside another project's
  # repository (vendored, unpacked from a tarball) must not take that project's revision.
  execute_process(COMMAND ${GIT_EXECUTABLE} -C ${SOURCE_DIR} rev-parse --show-toplevel
                  OUTPUT_VARIABLE top RESULT_VARIABLE rc ERROR_QUIET OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(rc EQUAL 0)
    file(REAL_PATH "${top}" top)
    file(REAL_PATH "${SOURCE_DIR}" src)
  endif()
  if(rc EQUAL 0 AND top STREQUAL src)
    execute_process(COMMAND ${GIT_EXECUTABLE} -C ${SOURCE_DIR} describe --always --dirty --abbrev=12
                    OUTPUT_VARIABLE out RESULT_VARIABLE rc ERROR_QUIET OUTPUT_STRIP_TRAILING_WHITESPACE)
    if(rc EQUAL 0 AND NOT out STREQUAL "")
      set(rev "${out}")
    endif()
  endif()
endif()
set(TRAINSIM_GIT_REVISION "${rev}")
configure_file(${SOURCE_DIR}/src/core/trainsim_revision.f90.in ${OUTPUT} @ONLY)
