"""Progress bars for the CLI (tqdm on stderr): the command line's ``softrnn.progress.Progress``; the
library only calls progress(done, total[, info]). Also the exit code of a command stopped by a signal
(``stop_code``), which every long command returns after saying what it kept."""

import signal
import sys

from tqdm import tqdm


class Bar:
    """A ``Progress`` backed by tqdm (``info`` is not shown); use as a context manager."""

    def __init__(self, desc: str, unit: str = "sample", enabled: bool = True):
        self.desc, self.unit, self.enabled = desc, unit, enabled
        self.bar = None

    def __call__(self, done: int, total: int, info: dict | None = None) -> None:
        if not self.enabled:
            return
        if self.bar is None:
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


class Terminated(KeyboardInterrupt):
    """SIGTERM (a scheduler or ``kill`` stopping the job), raised like Ctrl-C by ``main``'s signal
    handler so that every command's clean-up runs: temporary files removed, finished steps kept."""


def stop_code(err: KeyboardInterrupt) -> int:
    """The exit code of a command stopped by a signal, 128 + the signal's number: 143 for SIGTERM
    (a scheduler's time limit, ``kill``; raised as ``Terminated``) and 130 for SIGINT (Ctrl-C)."""
    return 128 + int(signal.SIGTERM if isinstance(err, Terminated) else signal.SIGINT)
