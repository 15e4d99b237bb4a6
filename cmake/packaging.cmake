# Packaging (docs/install.md). The shipped wheel links exactly as the developer build does: Debian's
# SuiteSparse archives (libcholmod.a, libamd.a, ...) are position-dependent code (PIE: an
# R_X86_64_PC32 relocation against stdout in cholmod_l_error.o, text relocations in camd_l_2.o), so
# they cannot go into the _core shared module; auditwheel bundles the shared libraries instead.

# What the module was built for, read by the Blender add-on (python_addon/native.py) to say why it
# cannot load the module in another Blender: written into the wheel beside _core.
if(TARGET _core)
  execute_process(COMMAND ${Python_EXECUTABLE} -c "import platform; print(platform.libc_ver()[1])"
                  OUTPUT_VARIABLE DEFORMKIT_BUILD_GLIBC OUTPUT_STRIP_TRAILING_WHITESPACE)
  string(TOLOWER "${CMAKE_SYSTEM_NAME}" DEFORMKIT_BUILD_SYSTEM)
  configure_file(${CMAKE_CURRENT_LIST_DIR}/build_target.json.in ${CMAKE_CURRENT_BINARY_DIR}/build_target.json @ONLY)
  install(FILES ${CMAKE_CURRENT_BINARY_DIR}/build_target.json DESTINATION deformkit)
endif()
