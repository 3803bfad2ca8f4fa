# How this build becomes an installable package (docs/packaging.md):
#   peis_install_program(<target>...)   a program into bin/ (one line per program)
#   peis_install_library(<target> <public include dir>)
#                                       a library of the package, exported as
#                                       peis::<EXPORT_NAME>, and its headers
#   peis_provide_package()              find_package(peis) inside this tree finds
#                                       the targets being built (for
#                                       components/examples/, which is also a
#                                       standalone project)
#   peis_install_package()              the CMake package (config, version,
#                                       targets) and the pkg-config files
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(PEIS_PACKAGE_TEMPLATES ${CMAKE_CURRENT_LIST_DIR})

# A shared build's installed programs find the libraries from where they are
# (the prefix may be moved); a static build's need nothing.
if(BUILD_SHARED_LIBS AND NOT DEFINED CMAKE_INSTALL_RPATH)
  file(RELATIVE_PATH bin_to_lib /${CMAKE_INSTALL_BINDIR} /${CMAKE_INSTALL_LIBDIR})
  set(CMAKE_INSTALL_RPATH "$ORIGIN/${bin_to_lib}")
endif()
# Before 1.0 a minor version may change the API: a consumer asking for 0.1
# accepts 0.1.x only.
set(PEIS_PACKAGE_COMPATIBILITY SameMinorVersion)

function(peis_install_program)
  install(TARGETS ${ARGN} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
endfunction()

function(peis_install_library target include_dir)
  install(TARGETS ${target} EXPORT peisTargets
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
          LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
          RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  # Every header of the public include dir, nothing else: the packaging test
  # compiles each installed header alone against the installed tree.
  install(DIRECTORY ${include_dir}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
          FILES_MATCHING PATTERN "*.h")
endfunction()

function(peis_provide_package)
  # CMake looks in this directory before anywhere else (the mechanism
  # FetchContent uses), so find_package(peis) in a subdirectory resolves to
  # the peis::kernel and peis::component ALIAS targets of this build.
  file(WRITE ${CMAKE_FIND_PACKAGE_REDIRECTS_DIR}/peis-config.cmake
       "# find_package(peis) inside the peis build: its targets already exist.\n")
  write_basic_package_version_file(${CMAKE_FIND_PACKAGE_REDIRECTS_DIR}/peis-config-version.cmake
                                   VERSION ${PROJECT_VERSION}
                                   COMPATIBILITY ${PEIS_PACKAGE_COMPATIBILITY})
endfunction()

# The dependencies a consumer must find: Threads always; yaml-cpp only when
# the libraries are static (the component library's; a shared one carries
# its own links). The kernel links none: libsodium, libgcrypt and
# yaml-cpp are the security module's (<libdir>/peis/libpeis-security.so),
# which the kernel loads at run time in a secured ecology. Boost is
# header-only and private to the kernel's sources: nothing of it is needed
# to build or link against the package.
function(peis_install_package)
  set(config_dir ${CMAKE_INSTALL_LIBDIR}/cmake/peis)
  get_target_property(component_type peis_component TYPE)
  # pkg-config: what a static library needs goes into Libs/Requires (a
  # plain `pkg-config --libs` must link); a shared one's into *.private.
  set(kernel_libs "-L\${libdir} -lpeis-kernel")
  set(component_requires "peis-kernel = ${PROJECT_VERSION}")
  if(component_type STREQUAL "STATIC_LIBRARY")
    set(PEIS_CONFIG_DEPENDENCIES "find_dependency(yaml-cpp)")
    set(PEIS_PC_KERNEL_LIBS "${kernel_libs} -pthread")
    set(PEIS_PC_KERNEL_LIBS_PRIVATE "")
    set(PEIS_PC_KERNEL_REQUIRES "")
    set(PEIS_PC_KERNEL_REQUIRES_PRIVATE "")
    set(PEIS_PC_COMPONENT_REQUIRES "${component_requires}, yaml-cpp")
    set(PEIS_PC_COMPONENT_REQUIRES_PRIVATE "")
  else()
    set(PEIS_CONFIG_DEPENDENCIES "")
    set(PEIS_PC_KERNEL_LIBS "${kernel_libs}")
    set(PEIS_PC_KERNEL_LIBS_PRIVATE "-pthread")
    set(PEIS_PC_KERNEL_REQUIRES "")
    set(PEIS_PC_KERNEL_REQUIRES_PRIVATE "")
    set(PEIS_PC_COMPONENT_REQUIRES "${component_requires}")
    set(PEIS_PC_COMPONENT_REQUIRES_PRIVATE "yaml-cpp")
  endif()

  install(EXPORT peisTargets NAMESPACE peis:: DESTINATION ${config_dir})
  configure_package_config_file(${PEIS_PACKAGE_TEMPLATES}/peisConfig.cmake.in
                                ${PROJECT_BINARY_DIR}/package/peisConfig.cmake
                                INSTALL_DESTINATION ${config_dir})
  write_basic_package_version_file(${PROJECT_BINARY_DIR}/package/peisConfigVersion.cmake
                                   VERSION ${PROJECT_VERSION}
                                   COMPATIBILITY ${PEIS_PACKAGE_COMPATIBILITY})
  install(FILES ${PROJECT_BINARY_DIR}/package/peisConfig.cmake
                ${PROJECT_BINARY_DIR}/package/peisConfigVersion.cmake
          DESTINATION ${config_dir})

  # pkg-config: relocatable (the prefix is found from the .pc file's place)
  # unless the install dirs were given as absolute paths.
  if(IS_ABSOLUTE "${CMAKE_INSTALL_LIBDIR}" OR IS_ABSOLUTE "${CMAKE_INSTALL_INCLUDEDIR}")
    set(PEIS_PC_PREFIX ${CMAKE_INSTALL_PREFIX})
    set(PEIS_PC_LIBDIR ${CMAKE_INSTALL_FULL_LIBDIR})
    set(PEIS_PC_INCLUDEDIR ${CMAKE_INSTALL_FULL_INCLUDEDIR})
  else()
    file(RELATIVE_PATH up /${CMAKE_INSTALL_LIBDIR}/pkgconfig /)
    string(REGEX REPLACE "/$" "" up "${up}")
    set(PEIS_PC_PREFIX "\${pcfiledir}/${up}")
    set(PEIS_PC_LIBDIR "\${prefix}/${CMAKE_INSTALL_LIBDIR}")
    set(PEIS_PC_INCLUDEDIR "\${prefix}/${CMAKE_INSTALL_INCLUDEDIR}")
  endif()
  foreach(pc peis-kernel peis-component)
    configure_file(${PEIS_PACKAGE_TEMPLATES}/${pc}.pc.in ${PROJECT_BINARY_DIR}/package/${pc}.pc
                   @ONLY)
    install(FILES ${PROJECT_BINARY_DIR}/package/${pc}.pc
            DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
  endforeach()
endfunction()
