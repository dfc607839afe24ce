"""Progress over the named steps of a long run (a tqdm bar on standard error).

The library's long functions take ``progress=``: a callable that is told the name
of each step as it starts. :class:`StepBar` is the command line's: a bar that
appears only once a run has lasted a second, so quick runs print nothing extra.
"""

import sys

__all__ = ["StepBar", "tick"]


def tick(progress, step):
    """Tell ``progress`` (a callable or None) that ``step`` starts."""
    if progress is not None:
        progress(step)


class StepBar:
    """A progress bar over ``total`` named steps.

    Parameters
    ----------
    total : int
        Steps expected (the bar fills as each one starts the next).
    enabled : bool, optional
        False draws nothing (``--quiet``). The bar is drawn only on a terminal
        (not into logs or pipes) and only once a run has lasted a second.
    desc : str, optional
        The bar's label.

    Examples
    --------
    >>> bar = StepBar(2, enabled=False)
    >>> bar("partition"); bar("harmonic"); bar.close()
    >>> bar.steps
    ['partition', 'harmonic']
    """

    def __init__(self, total, *, enabled=True, desc="manifill"):
        from tqdm import tqdm

        self.steps = []
        enabled = enabled and sys.stderr.isatty()
        self._bar = tqdm(total=total, desc=desc, disable=not enabled, delay=1.0, leave=False, file=sys.stderr,
                         unit="step", bar_format="{desc}: {bar} {n_fmt}/{total_fmt} steps {postfix} [{elapsed}]")

    def __call__(self, step):
        if self.steps:
            self._bar.update(1)
        self.steps.append(step)
        self._bar.set_postfix_str(step, refresh=False)  # drawn by tqdm once the run has lasted a second

    def close(self):
        """Finish the bar and remove it from the terminal."""
        self._bar.close()
