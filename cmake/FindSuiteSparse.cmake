# Finds SuiteSparse (SPQR, CHOLMOD and their support libraries) as installed by Debian's
# libsuitesparse-dev 5.x, which ships neither a CMake config nor a pkg-config file.
# Defines the imported target SuiteSparse::SuiteSparse.
find_path(SuiteSparse_INCLUDE_DIR NAMES SuiteSparseQR.hpp cholmod.h PATH_SUFFIXES suitesparse)
foreach(lib spqr cholmod amd colamd camd ccolamd suitesparseconfig)
  find_library(SuiteSparse_${lib}_LIBRARY NAMES ${lib})
  list(APPEND SuiteSparse_LIBRARIES ${SuiteSparse_${lib}_LIBRARY})
  list(APPEND _ss_required SuiteSparse_${lib}_LIBRARY)
endforeach()
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(SuiteSparse REQUIRED_VARS SuiteSparse_INCLUDE_DIR ${_ss_required})
if(SuiteSparse_FOUND AND NOT TARGET SuiteSparse::SuiteSparse)
  add_library(SuiteSparse::SuiteSparse INTERFACE IMPORTED)
  set_target_properties(SuiteSparse::SuiteSparse PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${SuiteSparse_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${SuiteSparse_LIBRARIES}")
endif()
