# The version of the installed manylights package, read from the installed header's
# ML_VERSION_* macros. Before 1.0 a minor version may break the ABI: a request is met by the
# same major and minor version, at least the requested patch (and by any version for a
# request of none).

get_filename_component(_manylights_prefix "${CMAKE_CURRENT_LIST_DIR}/../../.." ABSOLUTE)
set(_manylights_header "${_manylights_prefix}/include/manylights.h")
set(PACKAGE_VERSION "0.0.0")
if(EXISTS "${_manylights_header}")
  file(STRINGS "${_manylights_header}" _manylights_defines
    REGEX "^#define ML_VERSION_(MAJOR|MINOR|PATCH) [0-9]+$")
  foreach(_manylights_part MAJOR MINOR PATCH)
    set(_manylights_${_manylights_part} 0)
    foreach(_manylights_define IN LISTS _manylights_defines)
      if(_manylights_define MATCHES "^#define ML_VERSION_${_manylights_part} ([0-9]+)$")
        set(_manylights_${_manylights_part} "${CMAKE_MATCH_1}")
      endif()
    endforeach()
  endforeach()
  set(PACKAGE_VERSION "${_manylights_MAJOR}.${_manylights_MINOR}.${_manylights_PATCH}")
endif()

set(PACKAGE_VERSION_COMPATIBLE FALSE)
set(PACKAGE_VERSION_EXACT FALSE)
if(NOT PACKAGE_FIND_VERSION)
  set(PACKAGE_VERSION_COMPATIBLE TRUE)
elseif(PACKAGE_VERSION VERSION_EQUAL PACKAGE_FIND_VERSION)
  set(PACKAGE_VERSION_COMPATIBLE TRUE)
  set(PACKAGE_VERSION_EXACT TRUE)
elseif("${_manylights_MAJOR}.${_manylights_MINOR}" VERSION_EQUAL
       "${PACKAGE_FIND_VERSION_MAJOR}.${PACKAGE_FIND_VERSION_MINOR}"
       AND PACKAGE_VERSION VERSION_GREATER PACKAGE_FIND_VERSION)
  set(PACKAGE_VERSION_COMPATIBLE TRUE)
endif()
if(PACKAGE_VERSION STREQUAL "0.0.0")
  set(PACKAGE_VERSION_UNSUITABLE TRUE)
endif()

unset(_manylights_prefix)
unset(_manylights_header)
unset(_manylights_defines)
unset(_manylights_define)
unset(_manylights_part)
unset(_manylights_MAJOR)
unset(_manylights_MINOR)
unset(_manylights_PATCH)
