"""The progress bar of long commands (``cellgl bake``, sweeps, Dask bakes, frames) on stderr:
:class:`Progress` (also reachable as ``cellgl.bake.core.Progress``)."""

from __future__ import annotations

import sys
import threading
import time

from cellgl import _interrupt

__all__ = ["Progress"]


class Progress:
    """A progress bar on stderr. On a terminal one line redrawn in place (``\\r``, at most four
    times a second); elsewhere (a log, a pipe) plain lines: one saying what started as soon as
    the work begins, one at every tenth of the work, and one at least every
    :data:`LOG_INTERVAL` seconds between them (from a timer thread, so a slow tile still shows
    the bake is alive); nothing when not ``enabled`` (``--quiet``) or for a single step. Used
    as ``with bar:`` the line is ended on leaving, with "interrupted" after Ctrl-C or a
    terminating signal."""

    #: most seconds between two lines in a log (stderr not a terminal)
    LOG_INTERVAL = 5.0

    def __init__(self, total: int, label: str, enabled: bool, stream=None, unit: str = "tiles"):
        self.total, self.label, self.done, self.unit = total, label, 0, unit
        self.enabled = enabled and total > 1
        self.stream = stream or sys.stderr
        try:
            self.tty = self.stream.isatty()
        except (AttributeError, ValueError, OSError):
            self.tty = False
        self.t0 = time.perf_counter()
        self.last = -1.0
        self.drawn = 0    # 0 nothing written, 1 a line in progress (terminal), 2 lines ended
        self._lock = threading.Lock()
        self._stop: threading.Event | None = None
        self._logged = self.t0      # when the last log line was written

    def _text(self) -> str:
        secs = time.perf_counter() - self.t0
        if not self.done:
            return f"0/{self.total} {self.unit}, {secs:.0f} s"
        eta = secs / self.done * (self.total - self.done)
        return f"{self.done}/{self.total} {self.unit}, {secs:.0f} s, eta {eta:.0f} s"

    def _log(self, text: str) -> None:
        """One plain line (stderr not a terminal); never raises (a closed log ends the lines)."""
        with self._lock:
            self.drawn = 2      # first: a signal that lands in the write still ends the lines
            self._logged = time.perf_counter()
            try:
                self.stream.write(f"{self.label}: {text}\n")
                self.stream.flush()
            except (OSError, ValueError):
                return

    def start(self) -> None:
        """Say what started (stderr not a terminal) and keep a line coming every
        :data:`LOG_INTERVAL` seconds until :meth:`close`."""
        if not self.enabled or self.tty or self._stop is not None:
            return
        self._log(f"started, {self.total} {self.unit}")
        self._stop = threading.Event()
        threading.Thread(target=self._heartbeat, args=(self._stop,), daemon=True,
                         name="cellgl-progress").start()

    def _heartbeat(self, stop: threading.Event) -> None:
        while not stop.wait(self.LOG_INTERVAL / 4):
            if time.perf_counter() - self._logged >= self.LOG_INTERVAL and not stop.is_set():
                self._log(self._text())

    def step(self) -> None:
        _interrupt.check()      # a Ctrl-C the first raise of which was swallowed
        self.done += 1
        if not self.enabled:
            return
        if self.tty:
            now = time.perf_counter()
            if self.done < self.total and now - self.last < 0.25:
                return  # redraw at most four times a second, and always at the end
            self.last = now
            width = 30
            fill = width * self.done // self.total
            self.stream.write(f"\r{self.label} [{'#' * fill}{'.' * (width - fill)}] {self._text()} ")
            self.drawn = 1
        else:
            if 10 * self.done // self.total == 10 * (self.done - 1) // self.total:
                return  # a line at every tenth, and at the end (the timer thread in between)
            self._log(self._text())
            return
        self.stream.flush()

    def close(self, exc: BaseException | None = None) -> None:
        """End the line; say "interrupted" if ``exc`` is a Ctrl-C or a terminating signal."""
        if self._stop is not None:
            self._stop.set()
            self._stop = None
        if not self.enabled or not self.drawn:
            return
        # (a signal during an import can reach here as another exception; it is still pending)
        stopped = isinstance(exc, KeyboardInterrupt) or type(exc).__name__ == "Terminated" \
            or bool(_interrupt.pending)
        try:
            if self.drawn == 1:
                self.stream.write(" interrupted\n" if stopped else "\n")
            elif stopped:
                self._log(f"interrupted at {self.done}/{self.total} {self.unit}")
            self.stream.flush()
        except (OSError, ValueError):
            pass
        self.drawn = 0

    def __enter__(self) -> Progress:
        try:
            self.start()
        except BaseException as exc:    # a Ctrl-C right after the first line: still said
            self.close(exc)
            raise
        return self

    def __exit__(self, kind, exc, tb) -> None:
        self.close(exc)
