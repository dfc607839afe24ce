"""The options of ``method='gp'`` (:class:`GPOptions`, given as ``gp=``), their constraints table, and their check
(:func:`as_gp_options`); the Gaussian process itself is :mod:`manifill.linalg.gp`."""

from dataclasses import dataclass, fields, replace

from ..errors import OptionError
from ..validate.constraints import Flag, Number, OneOf, check_table
from .gaussian import VARIANCES
from .spde import ALPHAS

#: The barrier models of ``gp=``: the mesh cut along the barriers, or Bakka et al.'s thin-range faces.
BARRIER_MODELS = ("cut", "bakka")

__all__ = ["GPOptions", "BARRIER_MODELS", "as_gp_options"]


@dataclass(frozen=True, kw_only=True)
class GPOptions:
    """Options of ``method='gp'`` (pass a ``GPOptions`` or a dict of these names as ``gp=``).

    Attributes
    ----------
    alpha : {1, 2}
        SPDE order: 2 (default) is Matérn ``nu = 1`` on surfaces (``nu = 1/2``, the
        exponential covariance, in solids); 1 is the Gaussian free field with a range.
    range : 'auto' or float > 0
        Distance at which the correlation falls to about 0.13 (``sqrt(8 nu) / kappa``), in the
        units of the mesh; ``'auto'``: fitted.
    sigma : 'auto' or float > 0
        Prior marginal standard deviation (``alpha = 2`` only); ``'auto'``: fitted.
    noise : 0, float >= 0 or 'auto'
        Standard deviation of the measurement noise, in the units of the values: 0 (default)
        interpolates the samples; ``'auto'``: fitted.
    mean : 'constant' or float
        A constant mean per field, estimated (default) or known.
    share : bool
        True (default): the fields share the range and the noise-to-signal ratio (one
        precision, one variance computation, scaled per field); False: each field its own.
    variance : {'auto', 'exact', 'sampled'}
        ``exact``: selected inversion of the sparse Cholesky factor (:mod:`manifill.linalg.selinv`);
        ``sampled``: a Monte Carlo estimate with its standard error in the report; ``auto``: exact with
        CHOLMOD (the ``[cholmod]`` extra) or up to 20,000 unknowns, sampled above.
    samples : int
        Conditional samples of ``variance='sampled'`` (error about ``1 / sqrt(samples)``).
    seed : int
        Seed of the sampled variance and of the fit's subset.
    fit_samples : int
        The likelihood is evaluated on at most this many samples (a random subset).
    barrier : {'cut', 'bakka'}
        With ``barriers=``: the mesh cut along them (default; nothing correlates across), or Bakka et al.'s
        barrier model (2019): the faces along the barriers keep the mesh whole but their range is
        ``barrier_range`` times the field's, so correlation leaks across them only weakly.
    barrier_range : float in (0, 1]
        The barrier faces' range as a fraction of the range (``barrier='bakka'``).
    """

    alpha: int = 2
    range: object = "auto"
    sigma: object = "auto"
    noise: object = 0.0
    mean: object = "constant"
    share: bool = True
    variance: str = "auto"
    samples: int = 100
    seed: int = 0
    fit_samples: int = 200
    barrier: str = "cut"
    barrier_range: float = 0.1

    #: What each option takes (:mod:`manifill.validate.constraints`), checked by :func:`as_gp_options`.
    CONSTRAINTS = {
        "alpha": [OneOf(*ALPHAS)], "range": [OneOf("auto"), Number(lo=0, lo_open=True)],
        "sigma": [OneOf("auto"), Number(lo=0, lo_open=True)], "noise": [OneOf("auto"), Number(lo=0)],
        "mean": [OneOf("constant"), Number()], "share": [Flag()], "variance": [OneOf(*VARIANCES)],
        "samples": [Number(lo=2, integer=True)], "seed": [Number(lo=0, integer=True)],
        "fit_samples": [Number(lo=3, integer=True)], "barrier": [OneOf(*BARRIER_MODELS)],
        # the barrier faces' range as a fraction of the field's
        "barrier_range": [Number(lo=0, hi=1, lo_open=True)],
    }


def as_gp_options(gp):
    """``gp`` (None, a dict or :class:`GPOptions`) checked, as a :class:`GPOptions`.

    Examples
    --------
    >>> as_gp_options({"range": 0.5}).range
    0.5
    >>> as_gp_options({"ragne": 0.5})
    Traceback (most recent call last):
    ...
    manifill.errors.OptionError: gp option 'ragne' is not one of alpha, range, sigma, noise, mean, share, \
variance, samples, seed, fit_samples, barrier, barrier_range; pass those names
    """
    if gp is None:
        o = GPOptions()
    elif isinstance(gp, GPOptions):
        o = gp
    elif isinstance(gp, dict):
        names = [f.name for f in fields(GPOptions)]
        for key in gp:
            if key not in names:
                raise OptionError(f"gp option {key!r} is not one of {', '.join(names)}; pass those names")
        o = GPOptions(**gp)
    else:
        raise OptionError(f"gp= must be a dict or a manifill.GPOptions, not {type(gp).__name__}; pass one of those")
    check_table(o, GPOptions.CONSTRAINTS, owner="gp ")
    return replace(o, range=_number(o.range), sigma=_number(o.sigma), noise=_number(o.noise))


def _number(v):
    """``'auto'`` as it is, a number as a float."""
    return v if isinstance(v, str) else float(v)
