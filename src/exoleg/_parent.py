"""A child process that must not outlive its parent (a SIGKILL leaves no one to stop
it): :func:`when_parent_ends`."""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable


def when_parent_ends(action: Callable[[], None], every: float = 0.2) -> None:
    """Run ``action`` in a daemon thread of this process once its parent is gone (it is
    re-parented: ``os.getppid()`` changes), looking every ``every`` s."""
    parent = os.getppid()

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(every)
        action()

    threading.Thread(target=watch, name="exoleg-parent-watch", daemon=True).start()
