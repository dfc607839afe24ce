"""The result of cross-validation (:func:`manifill.surface.crossval.cross_validate`): errors, table, advice."""

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["CrossValidation", "EXACT"]

#: An error at or below this (relative to the range) is rounding: the method reproduces the held-out samples.
EXACT = 1e-9


@dataclass
class CrossValidation:
    """The result of :func:`cross_validate`: every candidate's error at held-out samples.

    Attributes
    ----------
    methods : list of str
        The candidates' labels (``"biharmonic bounds=samples"``), in the order given.
    candidates : dict of str to (str, dict)
        Label -> ``(method, options)``.
    errors : dict of str to float
        Label -> RMSE at the held-out samples over the sample range (fields combined
        by root mean square); NaN if no fold ran.
    field_errors : dict of str to (p,) numpy array
        The same per field.
    fold_errors : dict of str to (folds,) numpy array
        The error of each fold's held-out samples (NaN where the fold failed).
    seconds : dict of str to float
        Time of all fits of each candidate.
    failures : dict of str to dict of int to str
        Label -> ``{fold: one-line reason}`` for the folds that raised.
    excluded : dict of str to int
        Label -> held-out samples with no prediction (NaN: a mesh component without
        training samples), left out of the error.
    folds : int
        Number of folds (the number of samples for leave-one-out).
    loo : bool
        Leave-one-out.
    seed : int
        Seed of the split.
    samples : int
        Number of samples.
    labels : (k,) int64 numpy array
        The fold of every sample (in the order of the sorted sample vertices).
    hints : dict of str to str
        Label -> what the method's win suggests (its ``cv_hint``: for rbf, a field that lives in space).
    overshoot : dict of str to float
        Label -> the farthest any fold's fit left its training samples' range, as a fraction of that range.
    field_fold_errors : dict of str to (folds, p) numpy array
        Label -> each fold's error per field.
    """

    methods: list
    candidates: dict
    errors: dict
    field_errors: dict
    fold_errors: dict
    seconds: dict
    failures: dict
    excluded: dict
    folds: int
    loo: bool
    seed: int
    samples: int
    labels: np.ndarray | None = field(default=None, repr=False)
    #: Label -> what the method's win suggests (its ``cv_hint``: for rbf, a field that lives in space).
    hints: dict = field(default_factory=dict, repr=False)
    #: Label -> the farthest any fold's fit left its training samples' range, as a fraction of that range.
    overshoot: dict = field(default_factory=dict)
    #: Label -> ``(folds, p)``: each fold's error per field.
    field_fold_errors: dict = field(default_factory=dict, repr=False)

    def one_se(self, default: str, *, combined: bool = False) -> list[str]:
        """Per field, the label to use: ``default`` unless another candidate's error is lower by more than one
        standard error of that candidate's fold errors (the one-standard-error rule), then that candidate.

        Parameters
        ----------
        default : str
            The label kept unless the evidence says otherwise.
        combined : bool, optional
            Apply the rule once, to the fields' combined error, and give that label to every field.

        Returns
        -------
        list of str
            One label per field.
        """
        ok = [m for m in self.methods if not self.failures[m] and np.isfinite(self.errors[m])]
        p = len(self.field_errors[self.methods[0]])
        errors = {m: [self.errors[m]] if combined else self.field_errors[m] for m in ok}
        folds: dict[str, Any] = {m: self.fold_errors[m][:, None] if combined else self.field_fold_errors.get(m)
                                 for m in ok}
        out = []
        for j in range(1 if combined else p):
            best = min(ok, key=lambda m: (errors[m][j], self.methods.index(m)))
            e = np.zeros(0) if folds[best] is None else folds[best][:, j][np.isfinite(folds[best][:, j])]
            se = float(np.std(e, ddof=1) / np.sqrt(e.size)) if e.size > 1 else 0.0
            keep = default in ok and errors[default][j] - errors[best][j] <= se
            out.append(default if keep else best)
        return out * p if combined else out

    def ranking(self) -> list[str]:
        """The labels, best first: methods that ran on every fold by error, then the others."""
        def key(m):
            e = self.errors[m]
            return (bool(self.failures[m]) or not np.isfinite(e), e if np.isfinite(e) else np.inf,
                    self.methods.index(m))
        return sorted(self.methods, key=key)

    @property
    def best(self) -> str | None:
        """The label of the lowest error among the methods that ran on every fold (None if none did)."""
        top = self.ranking()[0]
        return None if self.failures[top] or not np.isfinite(self.errors[top]) else top

    @property
    def best_options(self) -> dict[str, Any] | None:
        """``dict(method=..., **options)`` of :attr:`best`, to pass to :func:`manifill.reconstruct`."""
        if self.best is None:
            return None
        name, opts = self.candidates[self.best]
        return {"method": name, **opts}

    @property
    def what(self) -> str:
        """``"leave-one-out"`` or ``"5-fold"``."""
        return "leave-one-out" if self.loo else f"{self.folds}-fold"

    def table(self) -> str:
        """One line per candidate, best first: error, worst fold, excluded samples, seconds, failures.

        Returns
        -------
        str
        """
        width = max(len(m) for m in self.methods) + 2
        p = len(next(iter(self.field_errors.values())))
        lines = [f"{self.what} cross-validation of {self.samples:,} samples (seed {self.seed}); error: RMSE at "
                 f"the held-out samples / the samples' range" + ("" if p == 1 else f", {p} fields combined"),
                 f"{'rank':>4}  {'method':<{width}}{'error':>9}  {'worst fold':>10}  {'overshoot':>9}  {'seconds':>8}  "
                 f"note"]
        for r, m in enumerate(self.ranking(), 1):
            e, fe = self.errors[m], self.fold_errors[m]
            ok = not self.failures[m] and np.isfinite(e)
            notes = []
            if p > 1 and np.isfinite(e):
                notes.append("per field " + ", ".join(_pct(x) for x in self.field_errors[m]))
            if self.excluded[m]:
                notes.append(f"{self.excluded[m]} held-out samples unreached (components without training samples)")
            if self.failures[m]:
                fold, reason = next(iter(self.failures[m].items()))
                notes.append(f"failed on {len(self.failures[m])}/{self.folds} folds (fold {fold}: {reason})")
            worst = _pct(np.nanmax(fe)) if np.isfinite(fe).any() else "-"
            over = self.overshoot.get(m)
            over = "-" if over is None else ("0" if over <= EXACT else _pct(over))
            lines.append(f"{r if ok else '-':>4}  {m:<{width}}{_pct(e) if np.isfinite(e) else '-':>9}  {worst:>10}  "
                         f"{over:>9}  {self.seconds[m]:>8.2f}  {'; '.join(notes)}".rstrip())
        return "\n".join(lines)

    @property
    def recommendation(self) -> str:
        """One sentence: which method to use, by how much it wins, and what that suggests."""
        best = self.best
        if best is None:
            return "No candidate ran on every fold; see the failures in the table."
        name, opts = self.candidates[best]
        call = ", ".join([f"method={name!r}"] + [f"{k}={v!r}" for k, v in opts.items()])
        e = self.errors[best]
        text = f"Use {call}: its {self.what} error is {_pct(e)} of the samples' range"
        rest = [m for m in self.ranking() if m != best and np.isfinite(self.errors[m]) and not self.failures[m]]
        if rest:
            nxt = rest[0]
            en = self.errors[nxt]
            if en <= EXACT:
                text += f", as is {nxt}'s: both reproduce the held-out samples to rounding"
            elif e <= EXACT:
                text += f": it reproduces the held-out samples to rounding, where the next, {nxt}, errs by {_pct(en)}"
            elif en < 1.05 * e:
                text += f", within 5% of {nxt} ({_pct(en)}), as good"
            else:
                text += f", {en / e:.3g}x lower than the next, {nxt} ({_pct(en)})"
        if self.hints.get(best):
            text += f"; {self.hints[best]}"
        return text + "." + self._bounded_advice(best, rest) + self._field_advice(best)

    def per_field(self, label: str | None = None) -> list[tuple[str, float]]:
        """Per field: ``(its own best candidate, the error of ``label`` (default: :attr:`best`) over that one's)``.

        One method serves every field of a call; this says what each field loses by it (a ratio of 1: none).
        """
        label = self.best if label is None else label
        ok = [m for m in self.methods if not self.failures[m] and np.isfinite(self.errors[m])]
        out = []
        for j in range(len(self.field_errors[label])):
            own = min(ok, key=lambda m: (self.field_errors[m][j], self.methods.index(m)))
            e, e0 = self.field_errors[label][j], self.field_errors[own][j]
            out.append((own, float(e / e0) if e0 > 0 else (1.0 if e == 0 else np.inf)))
        return out

    def _field_advice(self, best):
        """With several fields: the fields another candidate would serve better, and by how much."""
        if len(self.field_errors[best]) < 2:
            return ""
        worse = [(j, own, r) for j, (own, r) in enumerate(self.per_field(best)) if own != best and r > 1.05]
        if not worse:
            return " It is the best for every field."
        parts = [f"field {j + 1} would be {r:.3g}x better with {own}" for j, own, r in worse]
        return (" One method serves all the fields of a call: " + "; ".join(parts) +
                " (reconstruct those fields on their own to use it).")

    def _bounded_advice(self, best, rest):
        """When the recommended method leaves the samples' range: by how much, and the best one that does not."""
        over = self.overshoot.get(best, 0.0)
        if over <= EXACT:
            return ""
        text = f" It overshoots the samples' range by up to {_pct(over)} of it"
        inside = [m for m in rest if self.overshoot.get(m, np.inf) <= EXACT]
        if inside:
            m = inside[0]
            name, opts = self.candidates[m]
            call = ", ".join([f"method={name!r}"] + [f"{k}={v!r}" for k, v in opts.items()])
            ratio = self.errors[m] / self.errors[best] if self.errors[best] > 0 else np.inf
            return text + f"; the best that stays within it is {call} ({_pct(self.errors[m])}, {ratio:.3g}x)."
        return text + "; none of the candidates stayed within it: add bounds='samples' to a candidate to keep it."

    def summary(self) -> dict[str, Any]:
        """A plain dict (for reports and JSON): ``methods``, ``errors``, ``chosen``, ``folds``, ``table``."""
        return {"methods": self.ranking(), "errors": [float(self.errors[m]) for m in self.ranking()],
                "chosen": self.best, "chosen_options": self.best_options, "folds": "loo" if self.loo else self.folds,
                "what": self.what,
                "seed": self.seed, "failures": {m: dict(f) for m, f in self.failures.items() if f},
                "overshoot": {m: float(v) for m, v in self.overshoot.items()},
                "per_field": [] if self.best is None else [{"best": own, "loss": r} for own, r in self.per_field()],
                "table": self.table(), "recommendation": self.recommendation}


def _pct(x):
    return f"{100.0 * float(x):.3g}%"
