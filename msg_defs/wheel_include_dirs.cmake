# Included by every interface package under msg_defs/ after its find_package() calls.
#
# The ROS 2 Jazzy PyPI wheels export their `<pkg>__rosidl_generator_py` targets with the wheel
# builder's include paths (/opt/python/cp311-cp311/...), which do not exist here and make CMake
# stop at generate time. Point every such imported target at this interpreter's Python and NumPy
# headers instead. On a regular ROS 2 install no path matches and nothing changes.
find_package(Python3 REQUIRED COMPONENTS Interpreter Development NumPy)
get_property(_imported_targets DIRECTORY PROPERTY IMPORTED_TARGETS)
foreach(_target IN LISTS _imported_targets)
  if(NOT _target MATCHES "__rosidl_generator_py$")
    continue()
  endif()
  get_target_property(_dirs ${_target} INTERFACE_INCLUDE_DIRECTORIES)
  if(NOT _dirs)
    continue()
  endif()
  set(_fixed "")
  set(_changed FALSE)
  foreach(_dir IN LISTS _dirs)
    if(_dir MATCHES "^/opt/python/" AND NOT EXISTS "${_dir}")
      set(_changed TRUE)
    else()
      list(APPEND _fixed "${_dir}")
    endif()
  endforeach()
  if(_changed)
    list(APPEND _fixed ${Python3_INCLUDE_DIRS} ${Python3_NumPy_INCLUDE_DIRS})
    list(REMOVE_DUPLICATES _fixed)
    set_target_properties(${_target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_fixed}")
  endif()
endforeach()
