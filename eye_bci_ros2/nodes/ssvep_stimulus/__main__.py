"""``python -m`` of the node's subpackage: the same as ``ros2 run eye_bci_ros2 ssvep_stimulus``."""

from eye_bci_ros2.nodes.ssvep_stimulus import main

main()
