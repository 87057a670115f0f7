# Write the git revision of the source tree into a Fortran file, at build time.
#
#   cmake -DSOURCE_DIR=<src> -DOUTPUT=<file.f90> -P trainsim_git_revision.cmake
#
# Run by the `trainsim_revision` target before every build of the library, so
# the revision follows commits made after configuring. The file is rewritten
# only when its text changes (configure_file semantics), and the revision is
# the body of a function, not a parameter, so a new commit recompiles one file
# and relinks: no module that uses it changes.
# Without git, or outside a work tree (a release tarball), the revision is
# "unknown".
set(rev "unknown")
find_package(Git QUIET)
if(GIT_FOUND)
  execute_process(COMMAND ${GIT_EXECUTABLE} -C ${SOURCE_DIR} describe --always --dirty --abbrev=12
                  OUTPUT_VARIABLE out RESULT_VARIABLE rc ERROR_QUIET OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(rc EQUAL 0 AND NOT out STREQUAL "")
    set(rev "${out}")
  endif()
endif()
set(TRAINSIM_GIT_REVISION "${rev}")
configure_file(${SOURCE_DIR}/src/core/trainsim_revision.f90.in ${OUTPUT} @ONLY)
