"""The numbers of a run's summary: the range of each field, for the lines the command line prints.

The command line holds no numerics: what it prints about values (each field's
range beside the samples', so that overshoot shows) is computed here, and so are the lines
about a standard deviation (:func:`uncertainty_lines`: the Gaussian process's hyperparameters,
how the variance was computed, the std's range, the vertices ``trust`` marks).
"""

import math
import warnings

import numpy as np

__all__ = ["Report", "RENAMED_KEYS", "value_ranges", "uncertainty_lines", "value_columns"]


#: Report keys renamed, read under their old name for one release with a warning: old -> new.
RENAMED_KEYS = {"harmonic": "fill"}


class Report(dict):
    """A reconstruction's report: a dict whose renamed keys (:data:`RENAMED_KEYS`) are still read, with a warning.

    Examples
    --------
    >>> import warnings
    >>> r = Report(fill={"solver": "direct"})
    >>> with warnings.catch_warnings(record=True) as w:
    ...     warnings.simplefilter("always")
    ...     r["harmonic"]["solver"], str(w[0].message)
    ('direct', "report['harmonic'] is now report['fill'] (the fill of every method); the old key goes in the next \
release")
    """

    def __missing__(self, key):
        new = RENAMED_KEYS.get(key)
        if new is None or new not in self:
            raise KeyError(key)
        warnings.warn(f"report[{key!r}] is now report[{new!r}] (the fill of every method); the old key goes in the "
                      f"next release", DeprecationWarning, stacklevel=2)
        return self[new]


def value_ranges(values, point_ndim=1):
    """The smallest and largest value of each field, NaN (outside a solid, empty components) left out.

    Parameters
    ----------
    values : array_like
        Values at points: shape ``points`` (one field) or ``points + (p,)``
        (``p`` fields), where ``points`` has ``point_ndim`` axes (1 for
        vertices or samples, 3 for voxels).
    point_ndim : int, optional
        How many leading axes index points.

    Returns
    -------
    lo, hi : (p,) float64 numpy arrays
        Per field; NaN for a field without a finite value.

    Examples
    --------
    >>> lo, hi = value_ranges([[0.0, 5.0], [np.nan, np.nan], [2.0, -1.0]])
    >>> lo.tolist(), hi.tolist()
    ([0.0, -1.0], [2.0, 5.0])
    >>> [v.tolist() for v in value_ranges(np.full((2, 2, 2), np.nan), point_ndim=3)]
    [[nan], [nan]]
    """
    X = np.asarray(values, dtype=np.float64)
    X = X.reshape(-1, 1) if X.ndim == point_ndim else X.reshape(-1, X.shape[-1])
    lo = np.full(X.shape[1], np.nan)
    hi = np.full(X.shape[1], np.nan)
    some = ~np.isnan(X).all(axis=0)
    lo[some] = np.nanmin(X[:, some], axis=0)
    hi[some] = np.nanmax(X[:, some], axis=0)
    return lo, hi


def _numbers(values, fmt=".4g"):
    values = [values] if not isinstance(values, (list, tuple)) else values
    shown = [("none" if v is None else format(float(v), fmt)) for v in values]
    return shown[0] if len(set(shown)) == 1 else ", ".join(shown)


def _variance_line(info):
    how = info.get("how", "?")
    if how == "sampled":
        return (f"variance sampled ({info.get('samples', '?')} Monte Carlo samples; its relative standard error: "
                f"median {info.get('rel_se_median', float('nan')):.1%}, "
                f"largest {info.get('rel_se_max', float('nan')):.1%}; the std's is about half)"
                + (f": {info['why']}" if info.get("why") else ""))
    if how == "exact" and info.get("factor"):
        return (f"variance exact (selected inversion of the {info['factor']} Cholesky factor, "
                f"{info.get('factor_entries', 0):,} entries)")
    return f"variance {how}"


def _loo_lines(loo):
    """The std's check on the samples (leave-one-out), one line, with what to do when it is off."""
    if not loo:
        return []
    rms = [x["rms_z"] for x in loo]
    within = [x["within_1.96"] for x in loo]
    line = (f"std checked by leaving out each of the {loo[0]['samples']:,} samples: errors {_numbers(rms, '.2f')} "
            f"of the std (RMS; 1 when calibrated), {_numbers(within, '.0%')} within 1.96 std (95% expected)")
    off = [x for x in loo if x["verdict"] != "calibrated"]
    if not off:
        return [line]
    worst = max(off, key=lambda x: abs(math.log(x["rms_z"])))
    field = "this field" if len(loo) == 1 else f"field {worst.get('field', 0) + 1} of {len(loo)}"
    if worst["verdict"] == "too wide":
        what = (f"  the std looks about {1 / worst['rms_z']:.1f}x too wide on {field} (smoother than the fitted "
                f"model): its intervals are conservative")
    else:
        what = (f"  the std looks about {worst['rms_z']:.1f}x too narrow on {field} (rougher than the fitted "
                f"model): treat it as a lower bound, or pass noise='auto'")
    return [line, what]


def uncertainty_lines(report, std, trusted=None, point_ndim=1):
    """The summary lines of a run's standard deviation, for the command line.

    Parameters
    ----------
    report : dict
        A reconstruction's report: ``gp`` (``method='gp'``), ``uncertainty`` (an energy method
        read as a Gaussian field) and ``trust``, where present.
    std : numpy array or None
        The standard deviation (its range is reported); None gives no lines.
    trusted : numpy array of bool, optional
        The ``trusted`` mask of ``trust=``.
    point_ndim : int, optional
        As for :func:`value_ranges`.

    Returns
    -------
    list of str

    Examples
    --------
    >>> rep = {"gp": {"alpha": 2, "nu": 1.0, "fitted": ["range"], "range": [0.5], "sigma": [1.0], "noise": [0.0],
    ...               "loglik": -3.2, "fit": {"samples": 9}, "variance": {"how": "exact"}},
    ...        "trust": {"threshold": [0.4], "untrusted": 3, "marked": "mask"}}
    >>> for line in uncertainty_lines(rep, np.array([0.0, 0.25, 0.5]), np.array([True, True, False])):
    ...     print(line)
    gp: Matern alpha=2 (nu=1), range 0.5 (fitted), sigma 1 (given), noise 0 (given);
    restricted log-likelihood -3.2 on 9 samples
    std: variance exact, std in [0, 0.5]
    trust: 1 of 3 vertices untrusted (std > threshold 0.4), marked in 'trusted'
    """
    lines = []
    if std is None:
        return lines
    gp = report.get("gp")
    if gp is not None:
        fitted = gp.get("fitted", [])
        parts = [f"{name} {_numbers(gp.get(name))} ({'fitted' if name in fitted else 'given'})"
                 for name in ("range", "sigma", "noise")]
        if any(x is None for x in gp.get("sigma") or [None]):  # alpha=1: no finite variance, a fitted scale
            parts[1] = f"scale {_numbers(gp.get('scale'))} (fitted; no marginal sigma at nu <= 0)"
        bounds = gp.get("fit", {}).get("range_bounds")
        advice = None
        if "range" in fitted and bounds and gp.get("range"):
            at = [b for b in bounds if any(abs(r - b) <= 1e-3 * b for r in gp["range"])]
            if at:  # the likelihood wanted a range beyond the search: say so, and what it means
                side = "upper" if at[0] == bounds[-1] else "lower"
                parts[0] = parts[0][:-1] + f", at the search's {side} bound)"
                advice = (f"  the likelihood wanted a range {'above' if side == 'upper' else 'below'} the search's "
                          + ("(the field is smoother than the samples can tell): its std is a rough guide; "
                             "method='biharmonic' (bounds='samples') fits such fields well" if side == "upper" else
                             "(the samples look uncorrelated at their spacing: noise, or a field rougher than they "
                             "resolve): add samples, or pass range= (e.g. the samples' spacing) and noise="))
        line = f"gp: Matern alpha={gp.get('alpha')} (nu={float(gp.get('nu', 0)):g}), " + ", ".join(parts)
        if "loglik" in gp:
            crit = gp.get("fit", {}).get("criterion", "restricted likelihood")
            what = "restricted log-likelihood" if crit.startswith("restricted") else "log-likelihood"
            line += f"; {what} {gp['loglik']:.5g} on {gp.get('fit', {}).get('samples', '?')} samples"
        lines.append(line)
        if advice:
            lines.append(advice)
        info = gp.get("variance", {})
    else:
        unc = report.get("uncertainty", {})
        names = {1: "harmonic", 2: "biharmonic", 3: "triharmonic"}
        lines.append(f"uncertainty: the {names.get(unc.get('energy'), 'energy')} energy read as an intrinsic "
                     f"Gaussian field (no range: the std grows away from the samples), scale "
                     f"{_numbers(unc.get('scale', []))}")
        info = unc.get("variance", {})
    lo, hi = value_ranges(std, point_ndim)
    rng = "; ".join(f"[{a:.4g}, {b:.4g}]" for a, b in zip(lo, hi))
    lines.append(f"std: {_variance_line(info)}, std in {rng}")
    lines.extend(_loo_lines(info.get("loo")))
    tr = report.get("trust")
    if tr is not None and trusted is not None:
        t = np.asarray(trusted, dtype=bool)
        t = t[np.isfinite(np.asarray(std, dtype=np.float64).reshape(t.shape + (-1,))[..., 0])] if t.ndim > 1 else t
        nan = ", values set NaN there" if "nan" in (tr.get("marked"), tr.get("untrusted")) else ""
        lines.append(f"trust: {int((~t).sum()):,} of {t.size:,} {'vertices' if point_ndim == 1 else 'voxels'} "
                     f"untrusted (std > threshold {_numbers(tr.get('threshold', []))}), marked in 'trusted'{nan}")
    return lines


def value_columns(point_data, names):
    """The columns ``names`` of ``point_data`` as one ``(n, p)`` float64 table (masks as 0 and 1), for a value file.

    Examples
    --------
    >>> value_columns({"t": [1.0, 2.0], "trusted": [True, False]}, ["t", "trusted"]).tolist()
    [[1.0, 1.0], [2.0, 0.0]]
    """
    return np.column_stack([np.asarray(point_data[name], dtype=np.float64) for name in names])
