"""Progress bars for the CLI (tqdm on stderr): the command line's ``softrnn.progress.Progress``; the
library only calls progress(done, total[, info]). Also the exit code of a command stopped by a signal
(``stop_code``), which every long command returns after saying what it kept."""

import signal
import sys
import time


class Bar:
    """A ``Progress`` backed by tqdm (``info`` is not shown); use as a context manager. A call with
    another total than the bar's (the next stage of a run that reports several) starts a new bar."""

    def __init__(self, desc: str, unit: str = "sample", enabled: bool = True):
        self.desc, self.unit, self.enabled = desc, unit, enabled
        self.bar = None

    def __call__(self, done: int, total: int, info: dict | None = None) -> None:
        if not self.enabled:
            return
        if self.bar is not None and self.bar.total != total:
            self.close()
        if self.bar is None:
            from tqdm import tqdm  # imported with the first bar: tqdm imports importlib.metadata, tens of ms

            self.bar = tqdm(total=total, desc=self.desc, unit=self.unit, file=sys.stderr, leave=False,
                            dynamic_ncols=True, unit_scale=True)
        self.bar.update(done - self.bar.n)
        if done >= total:
            self.close()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class StepBar(Bar):
    """The tqdm bar of a training, with the loss and the unroll (``info``) in its postfix."""

    def __call__(self, done, total, info=None):
        super().__call__(done, total)
        if self.bar is not None and info:
            self.bar.set_postfix_str(f"loss {info.get('loss', float('nan')):.3g} unroll {info.get('unroll')}",
                                     refresh=False)


class DelayedBar(Bar):
    """A ``Bar`` that appears only once its work has run ``after`` seconds, so that a small input is
    handled without one (and an error in it stays one line on the terminal)."""

    def __init__(self, desc: str, unit: str = "sample", enabled: bool = True, after: float = 1.0):
        super().__init__(desc, unit, enabled)
        self.after, self.start = after, None

    def __enter__(self):
        self.start = time.perf_counter()      # the work starts here, not at its first report
        return self

    def __call__(self, done: int, total: int, info: dict | None = None) -> None:
        now = time.perf_counter()
        self.start = now if self.start is None else self.start
        if now - self.start >= self.after:
            super().__call__(done, total, info)


class Terminated(KeyboardInterrupt):
    """SIGTERM (a scheduler or ``kill`` stopping the job), raised like Ctrl-C by ``main``'s signal
    handler so that every command's clean-up runs: temporary files removed, finished steps kept."""


def stop_code(err: KeyboardInterrupt) -> int:
    """The exit code of a command stopped by a signal, 128 + the signal's number: 143 for SIGTERM
    (a scheduler's time limit, ``kill``; raised as ``Terminated``) and 130 for SIGINT (Ctrl-C)."""
    return 128 + int(signal.SIGTERM if isinstance(err, Terminated) else signal.SIGINT)
