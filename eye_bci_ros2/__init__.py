"""
Choose among RViz markers by looking at them: gaze over LSL, projection, arbitration.

Importing the package, or any module of it, leaves the process as it was: the
executables prepare their own process at start-up (:mod:`eye_bci_ros2.ros.startup`).
"""
