"""
Deciding a choice: regions on the screen, gaze evidence, the rules, rounds, fusion, feedback.

Pure numpy.  Depends on :mod:`eye_bci_ros2.projection` only; the rules are
registered in :data:`.rounds.RULE_EVIDENCE`.
"""
