#!/usr/bin/env bash
# Build the interface packages of this folder with colcon into the venv VENV (the Makefile's
# set-up; see README.md here).  usage: interfaces/build.sh VENV
#
# They are installed into the venv's own prefix, as the ROS wheels are (VENV/lib, VENV/share,
# VENV/lib/pythonX.Y/site-packages), so every process the venv's python starts finds them with
# nothing sourced: the ros_wheels_bootstrapper wheel puts VENV/lib on LD_LIBRARY_PATH, where
# rosidl's typesupport lookup and the loader find the libraries.
set -euo pipefail
venv=$(cd "$1" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
work=$venv/interfaces_build
# The venv alone: its cmake packages, its python first, nothing of a sourced ROS install.
export AMENT_PREFIX_PATH=$venv CMAKE_PREFIX_PATH=$venv PATH=$venv/bin:$PATH COLCON_HOME=$work
unset PYTHONPATH COLCON_PREFIX_PATH
# A folder with COLCON_IGNORE is skipped when colcon crawls (a user's workspace); a package path
# named with --paths is identified directly, so the marker of the parent folder does not apply.
packages=()
for package in "$here"/*/package.xml; do packages+=("$(dirname "$package")"); done
"$venv/bin/colcon" --log-base "$work/log" build --paths "${packages[@]}" \
  --build-base "$work/build" --install-base "$venv" --merge-install \
  --cmake-args -DBUILD_TESTING=OFF -DPython3_EXECUTABLE="$venv/bin/python" \
  -DCMAKE_PROJECT_INCLUDE="$here/cmake/drop_missing_include_dirs.cmake" \
  >"$work.log" 2>&1 || { tail -n 40 "$work.log"; echo "interfaces/build.sh: colcon build failed (log: $work.log)" >&2; exit 1; }
