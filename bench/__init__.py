"""Benchmarks of eye_bci_ros2 (run with make bench)."""
