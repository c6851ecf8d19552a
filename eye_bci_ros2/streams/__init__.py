"""
LSL stream connections shared by the gaze and the EEG input: pure and clock-injected.

pylsl itself is behind :mod:`eye_bci_ros2.ros.lsl_adapter`; nothing here loads it.
"""
