"""
Which regions a decision may use: those projected for the camera view it decides on.

Two pipelines on one ROS graph (same domain, no namespace) share
``choices/regions``.  A second projector whose camera shows another view
publishes the same options projected from there: taken as the newest regions,
they would move every option under the person's gaze, at once, for as long as
they are the newest.  A warning about the second pipeline comes too late for
that.  So the regions message says which camera view it was projected with
(the projector's camera pose, :mod:`eye_bci_ros2.ros.conversions`), the arbiter
follows ``camera/pose`` as the projector does, and a regions message is used
only when its view is one that ``camera/pose`` showed (one of the last
``remembered``: a pose the projector refused, NaN or in another frame, must not
make its regions of the last good pose wrong, and a camera moving faster than
the projector projects leaves regions a few poses behind).

Regions can arrive before the pose they were made for (two topics, no order
between them): such a message is held, and used as soon as its view arrives.
One held longer than ``hold_s`` was made for a view this pipeline does not
show: another pipeline's, said once per view.  Regions that do not say their
view (drawn by hand, a test's driver) are used as before.
"""

from collections import deque
from typing import Deque, Generic, List, Optional, Tuple, TypeVar

import numpy as np

#: A camera view: shape (7,): position x, y, z (m) and orientation x, y, z, w.
View = np.ndarray
Item = TypeVar('Item')

#: A held regions message not matched by a camera view within this long is another view's, s.
HOLD_S = 1.0
#: At most this many regions messages are held (the newest kept).
CAPACITY = 8
#: The last this many views on camera/pose are the pipeline's (2 s of an animation at 30 Hz).
REMEMBERED = 64


def same_view(first: Optional[View], second: Optional[View]) -> bool:
    """Tell whether two camera views are the same pose (a pose copied through messages)."""
    return first is not None and second is not None and \
        bool(np.allclose(first, second, rtol=0.0, atol=1e-9))


class ViewGate(Generic[Item]):
    """Let through regions made for the current camera view; hold the others a while."""

    def __init__(self, hold_s: float = HOLD_S, capacity: int = CAPACITY,
                 remembered: int = REMEMBERED):
        """Start with no camera view and nothing held."""
        self.hold_s = float(hold_s)
        self.capacity = int(capacity)
        self._views: Deque[View] = deque(maxlen=int(remembered))
        self._held: List[Tuple[View, Item, float]] = []
        #: Regions messages never used: made for another camera view.
        self.ignored = 0

    def offer(self, view: Optional[View], item: Item, now: float) -> bool:
        """
        Take a regions message made for ``view`` (None: it does not say); tell whether to use it.

        A message for a view camera/pose has not shown is held (:meth:`camera`).
        """
        if view is None or any(same_view(view, shown) for shown in reversed(self._views)):
            return True
        self._held.append((np.asarray(view, dtype=float), item, now))
        del self._held[:-self.capacity]
        return False

    def camera(self, view: View) -> Optional[Item]:
        """Take the camera view now shown; return the newest held message made for it, if any."""
        view = np.asarray(view, dtype=float)
        self._views.append(view)
        matching = [index for index, (held, _, _) in enumerate(self._held)
                    if same_view(held, view)]
        if not matching:
            return None
        item = self._held[matching[-1]][1]
        self._held = [entry for index, entry in enumerate(self._held) if index not in matching]
        return item

    def expired(self, now: float) -> List[View]:
        """Drop messages held longer than ``hold_s``; return their views (another pipeline's)."""
        old = [entry for entry in self._held if now - entry[2] > self.hold_s]
        if not old:
            return []
        self._held = [entry for entry in self._held if now - entry[2] <= self.hold_s]
        self.ignored += len(old)
        return [view for view, _, _ in old]
