"""The plumbing every ROS 2 node of the product and of the simulator shares.

- ``spin``: ``spin(make_node, args, prog)``, a node's main: parameters files checked, the
  callbacks guarded, one-line reasons, exit codes that ``ros2 launch`` respawns on;
- ``params``: ``Param``, ``declare``, ``on_set``, ``usage``, ``from_command_line``: parameters
  declared from one table, checked and changed at run time;
- ``batch``: ``BatchTaker``, ``BatchTopic``: serialized messages of busy topics taken in batches
  on a thread of their own;
- ``processes``: ``popen``, ``run``, ``interrupt_on_signals``, ``Interrupted``: child processes
  that end with their parent, signals turned into a clean stop;
- ``guard``: ``CallbackGuard``, ``FailureLog``: a callback that raises is logged once and the
  node goes on; ``core_log``: ``CoreLog``, the numerical core's log lines forwarded to the node's.

The modules are the public face (``from orthoglide_ident.ros.spin import spin``): importing this
package imports no rclpy, so ``processes`` serves tests and benches without ROS.
"""
