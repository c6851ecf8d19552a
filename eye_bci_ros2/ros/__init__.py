"""
The ROS 2 plumbing the nodes share: registry, runner, parameters, topics, conversions.

Each module is one piece of the adapters' common ground, not a node:

* ``registry``: the one list of executables and the nodes they run;
* ``startup``: an executable's process prepared before its imports (console scripts);
* ``runner``: the thin Jazzy ``main``, the executors, spin helpers;
* ``parameters``: parameters declared from a table, validated, applied live;
* ``screen_parameters``: the person's screen as one parameter table;
* ``rviz_file``: the ``rviz_config`` parameter (a ``.rviz`` file read);
* ``topics``: every topic name and QoS profile;
* ``session_topics``: the topics a study records (``session_record``, ``ros2 bag record``);
* ``message_types``: a message class by its type name, and its .msg definition;
* ``conversions``: message <-> numpy at the node edges;
* ``robot_messages``: planar poses <-> Pose, PoseStamped, TF transforms, Path;
* ``ssvep_messages``: SSVEP messages <-> the pure stimulus and score objects;
* ``feedback_markers``: the ``choices/feedback`` halos as a MarkerArray;
* ``marker_store``: RViz2's MarkerArray semantics, markers by (ns, id);
* ``lsl_adapter``: liblsl (pylsl) behind the stream connection;
* ``marker_outlet``: the session's LSL marker stream (pylsl);
* ``node_clock``: a node's clock read as numbers;
* ``log_throttle``: warnings a node may repeat, at most once per period;
* ``graph_watch``: a second pipeline on the same graph, noticed;
* ``package_files``: the installed files (ament index, else the source tree);
* ``launch_arguments``: the launch files' boolean arguments, checked.
* ``launch_stop``: how a launch stops: a node that ends stops it, Ctrl-C is one quiet stop.
"""
