"""
The package's nodes: one module per executable node (its ``Node`` class and ``main``).

A node with parts of its own keeps them in its subpackage (``choice_arbiter/``:
feedback and fusion; ``ssvep_stimulus/``: the window); what every node uses is
in :mod:`eye_bci_ros2.ros`.  Simulated stand-ins live in :mod:`eye_bci_ros2.sim`.
"""
