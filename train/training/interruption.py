"""Stopping a training run cleanly: SIGTERM (what ``kill`` and job schedulers send) or SIGINT
(Ctrl-C) asks the run to stop after the optimizer step it is taking.

The trainer then writes a checkpoint of the steps done and raises TrainingStopped, so the same
command continues the run from there, exactly as if it had not stopped, and no step is lost.
A second signal while the step finishes (Ctrl-C pressed again) is ignored, so the run stops
once, with its checkpoint; SIGKILL ends a run at once, losing the steps since its last
checkpoint. Under torchrun, which forwards the signal to its workers (and kills those still
running 30 s later), the processes agree on the step at which they stop (Distributed.any).
"""

import signal
import threading
from types import FrameType

SIGNALS = (signal.SIGTERM, signal.SIGINT)


class TrainingStopped(Exception):
    """A run stopped by a signal after writing the checkpoint of ``step`` (optimizer steps
    done)."""

    def __init__(self, signal_number: int | None, step: int):
        self.signal_number = signal_number  # None: another torchrun process took the signal
        self.step = step
        cause = signal.Signals(signal_number).name if signal_number else "another process"
        kept = "its checkpoint is written" if step else "no step was taken"
        super().__init__(f"stopped by {cause} at step {step}: {kept}, the same command "
                         f"continues the run")


class StopRequest:
    """Within ``with StopRequest() as stop:``, SIGTERM and SIGINT set ``stop.signal_number``
    instead of ending the process; the previous handlers come back on exit. Outside the main
    thread (where Python cannot take signals) it installs nothing and is never requested."""

    def __init__(self) -> None:
        self.signal_number: int | None = None
        self._previous: dict[int, object] = {}

    @property
    def requested(self) -> bool:
        return self.signal_number is not None

    def __enter__(self) -> "StopRequest":
        if threading.current_thread() is threading.main_thread():
            for number in SIGNALS:
                self._previous[number] = signal.signal(number, self._handle)
        return self

    def __exit__(self, *exception: object) -> None:
        for number, handler in self._previous.items():
            signal.signal(number, handler)
        self._previous = {}

    def _handle(self, number: int, frame: FrameType | None) -> None:
        if self.signal_number is None:
            self.signal_number = number
