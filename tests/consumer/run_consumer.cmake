# trainsim as a package others build on: one step of the consumer tests
# (tests/CMakeLists.txt), run as  cmake -DSTEP=... -DTRAINSIM_SOURCE_DIR=... -DWORK_DIR=...
#   -DBUILD_DIR=... -DCMAKE_BUILD_TYPE=... -DFortran_COMPILER=... -DC_COMPILER=... -P run_consumer.cmake
#
# STEP=install           install the tested build tree BUILD_DIR into WORK_DIR/prefix
#                        (cmake --install --prefix); check the installed layout
# STEP=find_package      build docs/examples against WORK_DIR/prefix (find_package), run
#                        change_backlash on the installed GHM deck
# STEP=add_subdirectory  build docs/examples with trainsim's source tree as a
#                        subdirectory; check that trainsim's compile options, tests and
#                        module folder stay out of the consumer; run change_backlash
cmake_minimum_required(VERSION 3.21)
foreach(v STEP TRAINSIM_SOURCE_DIR BUILD_DIR WORK_DIR CMAKE_BUILD_TYPE Fortran_COMPILER C_COMPILER)
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "run_consumer.cmake: -D${v}=... is required")
  endif()
endforeach()
set(prefix ${WORK_DIR}/prefix)
set(example_src ${TRAINSIM_SOURCE_DIR}/docs/examples)
set(compilers -DCMAKE_Fortran_COMPILER=${Fortran_COMPILER} -DCMAKE_C_COMPILER=${C_COMPILER})

# run(<what> <command...>): run a command, stop with its output if it fails.
function(run what)
  message(STATUS "${what}: ${ARGN}")
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc}):\n${out}")
  endif()
  set(run_output "${out}" PARENT_SCOPE)
endfunction()

function(run_example exe deck)
  run("run the example" ${exe} ${deck})
  message(STATUS "${run_output}")
  if(NOT run_output MATCHES "the mesh metrics moved with the backlash")
    message(FATAL_ERROR "change_backlash did not report moved metrics:\n${run_output}")
  endif()
endfunction()

# install_dirs(): CMAKE_INSTALL_<DIR> as the trainsim build chose them (lib or lib64, ...).
macro(install_dirs)
  file(STRINGS ${BUILD_DIR}/CMakeCache.txt _dirs REGEX "^CMAKE_INSTALL_[A-Z]+DIR:")
  foreach(_d IN LISTS _dirs)
    string(REGEX REPLACE "^(CMAKE_INSTALL_[A-Z]+DIR):[A-Z]+=(.*)$" "\\1;\\2" _kv "${_d}")
    list(GET _kv 0 _k)
    list(GET _kv 1 _v)
    set(${_k} ${_v})
  endforeach()
  # the ones GNUInstallDirs derives from DATAROOTDIR are empty in the cache
  if(NOT CMAKE_INSTALL_DATAROOTDIR)
    set(CMAKE_INSTALL_DATAROOTDIR share)
  endif()
  foreach(_k DATADIR MANDIR DOCDIR)
    if(NOT CMAKE_INSTALL_${_k})
      set(_default_DATADIR ${CMAKE_INSTALL_DATAROOTDIR})
      set(_default_MANDIR ${CMAKE_INSTALL_DATAROOTDIR}/man)
      set(_default_DOCDIR ${CMAKE_INSTALL_DATAROOTDIR}/doc/trainsim)
      set(CMAKE_INSTALL_${_k} ${_default_${_k}})
    endif()
  endforeach()
endmacro()

if(STEP STREQUAL "install")
  # The tested build tree itself is installed (cmake --install --prefix), not a second
  # build of trainsim: that build took 80-150 s on a quiet machine and over the 900 s
  # time-out under load. A build with trainsim's tests off is the add_subdirectory step's.
  file(REMOVE_RECURSE ${prefix})
  run("install trainsim" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
  install_dirs()
  foreach(f ${CMAKE_INSTALL_BINDIR}/trainsim
            ${CMAKE_INSTALL_LIBDIR}/libtrainsim.a
            ${CMAKE_INSTALL_LIBDIR}/libtrainsim_c.so
            ${CMAKE_INSTALL_INCLUDEDIR}/trainsim.h
            ${CMAKE_INSTALL_LIBDIR}/python3/dist-packages/trainsim/__init__.py
            ${CMAKE_INSTALL_LIBDIR}/python3/dist-packages/trainsim/_install.py
            ${CMAKE_INSTALL_INCLUDEDIR}/trainsim/trainsim.mod
            ${CMAKE_INSTALL_INCLUDEDIR}/trainsim/trainsim_model.mod
            ${CMAKE_INSTALL_LIBDIR}/cmake/trainsim/trainsimConfig.cmake
            ${CMAKE_INSTALL_LIBDIR}/cmake/trainsim/trainsimConfigVersion.cmake
            ${CMAKE_INSTALL_LIBDIR}/cmake/trainsim/trainsimTargets.cmake
            ${CMAKE_INSTALL_MANDIR}/man1/trainsim.1
            ${CMAKE_INSTALL_DATADIR}/trainsim/inputs/gregory_harris_munro.nml
            ${CMAKE_INSTALL_DATADIR}/trainsim/scripts/plot_history.py
            ${CMAKE_INSTALL_DATADIR}/trainsim/scripts/export_events.py
            ${CMAKE_INSTALL_DATADIR}/trainsim/scripts/trainsim_export.py
            ${CMAKE_INSTALL_DATADIR}/trainsim/scripts/trainsim_plot.py
            ${CMAKE_INSTALL_DATADIR}/trainsim/scripts/plot_sweep.py
            ${CMAKE_INSTALL_DOCDIR}/LICENSE
            ${CMAKE_INSTALL_DOCDIR}/deck.md)
    if(NOT EXISTS ${prefix}/${f})
      message(FATAL_ERROR "not installed: ${prefix}/${f}")
    endif()
  endforeach()
  run("installed trainsim --version" ${prefix}/${CMAKE_INSTALL_BINDIR}/trainsim --version)
  if(NOT run_output MATCHES "^trainsim [0-9]+\\.[0-9]+\\.[0-9]+")
    message(FATAL_ERROR "installed trainsim --version printed: ${run_output}")
  endif()
  # The installed program runs an installed deck (relative table files resolve).
  run("installed trainsim runs an installed deck" ${prefix}/${CMAKE_INSTALL_BINDIR}/trainsim run
      ${prefix}/${CMAKE_INSTALL_DATADIR}/trainsim/inputs/loads_table_ramp.nml -o ${WORK_DIR}/installed_run.h5)
  # ... and its export command finds the installed script (not the source tree's).
  run("installed trainsim export" ${CMAKE_COMMAND} -E env --unset=TRAINSIM_SCRIPTS
      ${prefix}/${CMAKE_INSTALL_BINDIR}/trainsim export ${WORK_DIR}/installed_run.h5 --summary json)
  if(NOT run_output MATCHES "\"metrics\"")
    message(FATAL_ERROR "installed trainsim export --summary json printed: ${run_output}")
  endif()

  # ... and the installed Python package loads the installed C library (not the build's).
  run("installed Python package" ${CMAKE_COMMAND} -E env --unset=TRAINSIM_LIBRARY
      PYTHONPATH=${prefix}/${CMAKE_INSTALL_LIBDIR}/python3/dist-packages
      /usr/bin/python3 -c "import trainsim\nprint(trainsim.library_path)\nprint(trainsim.sweep('${prefix}/${CMAKE_INSTALL_DATADIR}/trainsim/inputs/sweep_ghm_mesh_frequency.nml')['mesh.p2p_mean'][0])")
  if(NOT run_output MATCHES "^${prefix}/${CMAKE_INSTALL_LIBDIR}/libtrainsim_c")
    message(FATAL_ERROR "the installed Python package loaded another library: ${run_output}")
  endif()

elseif(STEP STREQUAL "find_package")
  install_dirs()
  set(b ${WORK_DIR}/example-find-package)
  file(REMOVE_RECURSE ${b})
  run("configure the example against the install" ${CMAKE_COMMAND} -S ${example_src} -B ${b}
      -DCMAKE_BUILD_TYPE=${CMAKE_BUILD_TYPE} ${compilers} -DCMAKE_PREFIX_PATH=${prefix})
  run("build the example" ${CMAKE_COMMAND} --build ${b} --parallel 2)
  run_example(${b}/change_backlash ${prefix}/${CMAKE_INSTALL_DATADIR}/trainsim/inputs/gregory_harris_munro.nml)
  run("the C interface example" ${b}/c_api ${prefix}/${CMAKE_INSTALL_DATADIR}/trainsim/inputs/gregory_harris_munro.nml)
  message(STATUS "${run_output}")

elseif(STEP STREQUAL "add_subdirectory")
  set(b ${WORK_DIR}/example-add-subdirectory)
  file(REMOVE_RECURSE ${b})
  run("configure the example with trainsim as a subdirectory" ${CMAKE_COMMAND} -S ${example_src} -B ${b}
      -DCMAKE_BUILD_TYPE=${CMAKE_BUILD_TYPE} ${compilers} -DTRAINSIM_SOURCE_DIR=${TRAINSIM_SOURCE_DIR}
      -DCMAKE_EXPORT_COMPILE_COMMANDS=ON -DCMAKE_Fortran_FLAGS_RELEASE=-O1 -DCMAKE_Fortran_FLAGS_DEBUG=-g)
  run("build the example" ${CMAKE_COMMAND} --build ${b} --parallel 2)
  # Nothing leaks from trainsim into its parent:
  file(READ ${b}/CMakeCache.txt cache)
  if(NOT cache MATCHES "CMAKE_Fortran_FLAGS_RELEASE:STRING=-O1\n" OR NOT cache MATCHES "CMAKE_Fortran_FLAGS_DEBUG:STRING=-g\n")
    message(FATAL_ERROR "trainsim changed the parent's CMAKE_Fortran_FLAGS_<CONFIG> cache entries")
  endif()
  file(READ ${b}/compile_commands.json cc)
  string(REGEX MATCH "\"command\": \"[^\"]*change_backlash\\.f90[^\"]*\"" example_cmd "${cc}")
  string(REGEX MATCH "\"command\": \"[^\"]*trainsim_api\\.f90[^\"]*\"" api_cmd "${cc}")
  if(NOT api_cmd MATCHES "-Wall" OR NOT api_cmd MATCHES "-std=f2018")
    message(FATAL_ERROR "trainsim's own sources lost their options: ${api_cmd}")
  endif()
  if(NOT example_cmd OR example_cmd MATCHES "-Wall" OR example_cmd MATCHES "-std=f2018" OR example_cmd MATCHES "-J")
    message(FATAL_ERROR "trainsim's options or module folder leaked into the parent's target: ${example_cmd}")
  endif()
  if(EXISTS ${b}/CTestTestfile.cmake OR EXISTS ${b}/trainsim/tests)
    message(FATAL_ERROR "trainsim registered its tests in the parent project")
  endif()
  run_example(${b}/change_backlash ${TRAINSIM_SOURCE_DIR}/inputs/gregory_harris_munro.nml)

else()
  message(FATAL_ERROR "run_consumer.cmake: unknown STEP '${STEP}'")
endif()
