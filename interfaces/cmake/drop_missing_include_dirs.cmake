# Given to each interface package as CMAKE_PROJECT_INCLUDE by interfaces/build.sh.
#
# The ROS wheels on PyPI were built in a manylinux container: their exported targets (e.g.
# geometry_msgs::geometry_msgs__rosidl_generator_py) name that machine's Python and numpy include
# directories (/opt/python/cp311-cp311/...), which do not exist here, and CMake refuses to
# generate with a missing INTERFACE_INCLUDE_DIRECTORIES entry. At the end of the configure step,
# drop every such missing directory from the imported targets; the package's own Python and numpy
# include directories come from its own find_package(Python3 ... Development NumPy).
function(_venv_wheels_drop_missing_include_dirs)
  get_property(targets DIRECTORY "${CMAKE_SOURCE_DIR}" PROPERTY IMPORTED_TARGETS)
  foreach(target IN LISTS targets)
    get_target_property(dirs ${target} INTERFACE_INCLUDE_DIRECTORIES)
    if(NOT dirs)
      continue()
    endif()
    set(kept "")
    foreach(dir IN LISTS dirs)
      if(dir MATCHES "^\\$<" OR EXISTS "${dir}")
        list(APPEND kept "${dir}")
      else()
        message(STATUS "${target}: dropping the missing include directory ${dir}")
      endif()
    endforeach()
    set_target_properties(${target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${kept}")
  endforeach()
endfunction()

cmake_language(DEFER DIRECTORY "${CMAKE_SOURCE_DIR}" CALL _venv_wheels_drop_missing_include_dirs)
