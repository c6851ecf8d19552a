"""
How a launch of this package stops: a node that ends stops it; Ctrl-C is one stop however pressed.

Every node of ``launch/`` is required (:func:`required`): when one ends on its own
(a bad parameter at start-up, a crash) launch says so ("process[X] was
required: shutting down launched system") and stops the others, so no half
pipeline keeps running.  When the launch is already stopping (Ctrl-C), the nodes
end because they were asked to: nothing to say for each.

A second Ctrl-C (a person pressing again while the stop seems slow; 0.3-0.4 s
later is typical) is ignored by launch while it runs ("... again, ignoring").
But once every node has ended, launch no longer catches it, and Python,
ending, puts SIGINT back to its system default (a Python handler is reset at
finalisation): a Ctrl-C in that moment ended the ``ros2`` process by the signal,
status 130, though everything had stopped cleanly.  :func:`one_stop_per_ctrl_c`
ignores SIGINT in the launch process from the moment the launch stops (an
ignored signal is left alone at finalisation; launch then says nothing of a
second Ctrl-C, and has nothing to do for it).

``launch`` is imported where the actions are built: it is not on PyPI.
"""

import signal


def required(executable: str, reason: str):
    """
    Return the ``on_exit`` of a node the launch cannot do without.

    :param executable: the node's executable (for the reason).
    :param reason: why the launch stops when it ends (launch logs it).
    """
    from launch.actions import OpaqueFunction, Shutdown

    def ended(context):
        if context.is_shutdown:
            return None     # stopping already (Ctrl-C): it ended because it was asked to
        return [Shutdown(reason=f'{executable} ended; {reason}')]
    return OpaqueFunction(function=ended)


def _ignore_further_interrupts(event, context) -> None:
    """From the launch's shutdown on, SIGINT is ignored in this process (module doc)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def one_stop_per_ctrl_c():
    """Return the action that keeps a second Ctrl-C from ending the launch with 130."""
    from launch.actions import RegisterEventHandler
    from launch.event_handlers import OnShutdown
    return RegisterEventHandler(OnShutdown(on_shutdown=_ignore_further_interrupts))
