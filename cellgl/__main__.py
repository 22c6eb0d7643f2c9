"""``python -m cellgl`` and the ``cellgl`` command (:func:`run`)."""

import os
import signal
import sys


def _early_exit(signum, frame):  # pragma: no cover - timing dependent
    """A signal before the command line has started: nothing is written yet, so leave at once
    with the status it would give (130 Ctrl-C, 143 SIGTERM, 129 SIGHUP), no traceback."""
    os._exit(128 + signum)


def run() -> int:
    """The program: signals end it cleanly from its first line (:func:`cellgl.cli.main` then
    takes over: they unwind the command, its temporary files deleted, and exit 128 + N)."""
    for name in ("SIGINT", "SIGTERM", "SIGHUP"):
        sig = getattr(signal, name, None)
        if sig is not None and signal.getsignal(sig) is not signal.SIG_IGN:
            signal.signal(sig, _early_exit)
    from cellgl.cli import main

    return main()


if __name__ == "__main__":
    sys.exit(run())
