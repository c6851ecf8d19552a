"""The rclpy nodes of eye_bci_ros2: each converts messages at its edges only."""
