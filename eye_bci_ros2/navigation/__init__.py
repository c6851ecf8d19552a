"""
The robot's side of a choice, pure Python + numpy/scipy (no rclpy).

The scene's floor plan as an occupancy grid (:mod:`.occupancy`), a planner on it
(:mod:`.planner`), the approach pose of each table (:mod:`.approach`), a
differential-drive model that follows a plan (:mod:`.drive`), the robot's
settings (:mod:`.robot_settings`), REP-105 frames and planar poses (:mod:`.frames`),
drifting wheel odometry (:mod:`.odometry`), planning in a thread (:mod:`.plan_worker`)
and nav2's result codes (:mod:`.nav2_codes`).  Frame: the scene's ``frame_id`` (the map
frame); x, y in metres, yaw in radians about z (counter-clockwise from x).
"""
