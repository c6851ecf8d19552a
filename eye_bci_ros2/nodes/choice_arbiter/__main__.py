"""``python -m`` of the node's subpackage: the same as ``ros2 run eye_bci_ros2 choice_arbiter``."""

from eye_bci_ros2.nodes.choice_arbiter import main

main()
