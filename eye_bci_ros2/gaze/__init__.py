"""
Gaze input: tracker layouts (:mod:`.profiles`), which LSL stream is a tracker's, validation.

Pure numpy.  Depends on :mod:`eye_bci_ros2.projection`, :mod:`eye_bci_ros2.streams`
and the gaze-error model of :mod:`eye_bci_ros2.decision.tolerance`.
"""
