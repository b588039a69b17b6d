#!/bin/sh
# The ROS 2 package of Cairn's types (ros2/cairn_msgs_ros2) is what tools/gen_ros2_msgs.py makes of
# idl/cairn_msgs.idl now: regenerated into a scratch folder and compared. Usage: ros2_msgs_generated_test.sh SOURCE_DIR
set -eu
src="$1"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
python3 "$src/tools/gen_ros2_msgs.py" "$src/idl/cairn_msgs.idl" "$out" >/dev/null
diff -r "$out" "$src/ros2/cairn_msgs_ros2" ||
  { echo "ros2/cairn_msgs_ros2 is out of date: run tools/gen_ros2_msgs.py" >&2; exit 1; }
echo "ros2/cairn_msgs_ros2 up to date"
