"""
The robot's side of a choice, pure Python + numpy/scipy (no rclpy).

The scene's floor plan as an occupancy grid (:mod:`.occupancy`), a planner on it
(:mod:`.planner`), the approach pose of each table (:mod:`.approach`), a
differential-drive model that follows a plan (:mod:`.drive`) and the robot's
settings (:mod:`.robot_settings`).  Frame: the scene's ``frame_id`` (the map
frame); x, y in metres, yaw in radians about z (counter-clockwise from x).
"""
