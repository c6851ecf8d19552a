"""
The assistive task: the scene of rooms and tables, and the menu's protocol.

Pure.  Depends on :mod:`eye_bci_ros2.projection` and :mod:`eye_bci_ros2.decision`.
"""
