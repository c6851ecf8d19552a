"""
The world as the screen shows it and the eye sees it: pure numpy.

The RViz camera (:mod:`.camera_model`, :mod:`.geometry`), its calibration from
world/pixel pairs, the ``.rviz`` file, the render panel on a screenshot, the
animated views, and the visual angle of screen pixels (:mod:`.visual_angle`).
Depends on nothing else of the package.
"""
