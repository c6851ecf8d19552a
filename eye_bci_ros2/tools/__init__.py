"""Command-line tools of eye_bci_ros2 (measure, calibrate, watch)."""
