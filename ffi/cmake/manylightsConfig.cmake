# The CMake package of manylights, installed by `cargo cinstall` (cargo-c) into
# <prefix>/share/manylights/cmake beside the pkg-config file <libdir>/pkgconfig/manylights.pc,
# which it reads: the library directory (the .pc file's parent's parent), the include
# directory and the system libraries the static library needs (`Libs.private`).
#
#   find_package(manylights CONFIG REQUIRED)
#   target_link_libraries(app PRIVATE manylights::manylights)         # shared
#   target_link_libraries(app PRIVATE manylights::manylights_static)  # static
#
# Both targets carry the include directory (manylights.h, manylights.hpp). The prefix is found
# from this file's place (relocatable with the default datadir, `share`).

if(TARGET manylights::manylights OR TARGET manylights::manylights_static)
  set(manylights_FOUND TRUE)
  return()
endif()

get_filename_component(_manylights_prefix "${CMAKE_CURRENT_LIST_DIR}/../../.." ABSOLUTE)
file(GLOB _manylights_pc
  "${_manylights_prefix}/lib*/pkgconfig/manylights.pc"
  "${_manylights_prefix}/lib*/*/pkgconfig/manylights.pc")
if(NOT _manylights_pc)
  set(manylights_FOUND FALSE)
  set(manylights_NOT_FOUND_MESSAGE
    "manylights.pc not found under ${_manylights_prefix}/lib*/ (install with cargo cinstall)")
  return()
endif()
list(GET _manylights_pc 0 _manylights_pc)
get_filename_component(_manylights_libdir "${_manylights_pc}" DIRECTORY)
get_filename_component(_manylights_libdir "${_manylights_libdir}" DIRECTORY)

# includedir and Libs.private from the .pc file, ${prefix} and ${exec_prefix} being this
# prefix.
set(_manylights_includedir "${_manylights_prefix}/include")
set(_manylights_private "")
file(STRINGS "${_manylights_pc}" _manylights_lines)
foreach(_manylights_line IN LISTS _manylights_lines)
  if(_manylights_line MATCHES "^includedir=(.*)$")
    set(_manylights_includedir "${CMAKE_MATCH_1}")
    string(REPLACE "\${prefix}" "${_manylights_prefix}" _manylights_includedir
      "${_manylights_includedir}")
    string(REPLACE "\${exec_prefix}" "${_manylights_prefix}" _manylights_includedir
      "${_manylights_includedir}")
  elseif(_manylights_line MATCHES "^Libs.private:(.*)$")
    string(REGEX MATCHALL "-l[^ \t]+" _manylights_flags "${CMAKE_MATCH_1}")
    foreach(_manylights_flag IN LISTS _manylights_flags)
      string(SUBSTRING "${_manylights_flag}" 2 -1 _manylights_name)
      list(APPEND _manylights_private "${_manylights_name}")
    endforeach()
  endif()
endforeach()

set(_manylights_shared
  "${_manylights_libdir}/${CMAKE_SHARED_LIBRARY_PREFIX}manylights${CMAKE_SHARED_LIBRARY_SUFFIX}")
set(_manylights_static
  "${_manylights_libdir}/${CMAKE_STATIC_LIBRARY_PREFIX}manylights${CMAKE_STATIC_LIBRARY_SUFFIX}")

if(EXISTS "${_manylights_shared}")
  add_library(manylights::manylights SHARED IMPORTED)
  set_target_properties(manylights::manylights PROPERTIES
    IMPORTED_LOCATION "${_manylights_shared}"
    INTERFACE_INCLUDE_DIRECTORIES "${_manylights_includedir}")
endif()
if(EXISTS "${_manylights_static}")
  add_library(manylights::manylights_static STATIC IMPORTED)
  set_target_properties(manylights::manylights_static PROPERTIES
    IMPORTED_LOCATION "${_manylights_static}"
    INTERFACE_INCLUDE_DIRECTORIES "${_manylights_includedir}"
    INTERFACE_LINK_LIBRARIES "${_manylights_private}")
endif()

if(TARGET manylights::manylights OR TARGET manylights::manylights_static)
  set(manylights_FOUND TRUE)
else()
  set(manylights_FOUND FALSE)
  set(manylights_NOT_FOUND_MESSAGE "neither ${_manylights_shared} nor ${_manylights_static} exists")
endif()

unset(_manylights_prefix)
unset(_manylights_pc)
unset(_manylights_libdir)
unset(_manylights_includedir)
unset(_manylights_private)
unset(_manylights_lines)
unset(_manylights_line)
unset(_manylights_flags)
unset(_manylights_flag)
unset(_manylights_name)
unset(_manylights_shared)
unset(_manylights_static)
