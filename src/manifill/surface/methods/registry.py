"""The registry of reconstruction methods: every method by name, the presets, and :func:`configure`.

A method is one object in one module of this package (:mod:`.pipeline`, :mod:`.gvf`,
:mod:`.energy`, :mod:`.rbf`, :mod:`.matern`, :mod:`.auto`), listed once in
:data:`METHODS`; a preset (:mod:`.default`) is a named configuration of one. Generic code
looks a method up here (:func:`method_of`) and asks it what it can do; this module is the
one place where method names are compared.

To add a method: write its module (a :class:`~manifill.surface.methods.base.Method` with its
capabilities and ``fill``), add it to :data:`METHODS`, and test it; ``reconstruct``,
``Reconstructor``, ``cross_validate``, the command line and the batch then take it.
"""

from dataclasses import replace

from ...errors import OptionError
from ...validate import check_option
from ..gp import VARIANCE_OPTIONS
from ..options import Options
from .base import Method
from ...linalg.gp import GPOptions, as_gp_options
from .auto import AUTO
from .default import DEFAULT
from .energy import BIHARMONIC, HARMONIC, TRIHARMONIC
from .hessian import HESSIAN, HESSIAN_CURVED
from .gvf import GVF
from .matern import GP
from .pipeline import PIPELINE
from .rbf import RBF

__all__ = ["METHODS", "PRESETS", "method_of", "configure", "names", "for_surface"]

#: Every method by name, in the order the docs list them.
METHODS = {m.name: m for m in (PIPELINE, HARMONIC, BIHARMONIC, TRIHARMONIC, HESSIAN, HESSIAN_CURVED, GVF, RBF, GP,
                               AUTO)}
#: Named presets: ``method=None`` is ``'default'``.
PRESETS = {DEFAULT.name: DEFAULT}


def names(presets=True):
    """The names ``method=`` takes: the methods, then the presets.

    Examples
    --------
    >>> names()[:3], names()[-1]
    (('gvf-harmonic', 'harmonic', 'biharmonic'), 'default')
    """
    return tuple(METHODS) + (tuple(PRESETS) if presets else ())


def method_of(name: str | None) -> Method:
    """The :class:`~manifill.surface.methods.base.Method` of a name (a preset's name gives its method).

    Parameters
    ----------
    name : str or None
        A method's or a preset's name (:func:`names`); None is the default preset.

    Examples
    --------
    >>> method_of("biharmonic").can_bound, method_of(None).name
    (True, 'biharmonic')
    """
    if name is None or name in PRESETS:
        return METHODS[PRESETS[name or "default"].method]
    check_option("method", name, names())
    return METHODS[name]


def configure(options=None, **keywords):
    """:class:`~manifill.surface.options.Options` from keywords (or a copy changed by them), resolved and checked.

    Resolves ``method=None`` (and any preset's name) to the preset's method and the options it sets unless
    given; ``curve_values=None`` to the method's own (``Method.default_curve_values``, ``'hermite'``);
    ``uncertainty=None`` to whether a std is asked for (``method='gp'``, or ``trust``); then the method refuses
    what it cannot use.

    Raises
    ------
    OptionError
        An unknown option or method, a value outside its set, an option the method cannot use.

    Examples
    --------
    >>> o = configure()
    >>> o.method, o.preset, o.fit.bounds, o.fit.bounds_mode
    ('biharmonic', 'default', 'samples', 'project')
    >>> configure(method="gvf-harmonic").fill.curve_values
    'hermite'
    >>> configure(method="rbf", bounds="samples")
    Traceback (most recent call last):
    ...
    manifill.errors.OptionError: method='rbf' has no mesh energy to minimise within bounds; pass bounds=None, ...
    """
    o = Options() if options is None else options
    if o.checked and not keywords:
        return o
    if keywords:
        if "method" in keywords:
            keywords.setdefault("preset", None)
        o = o.replace(**keywords)
    if o.method is None or o.method in PRESETS:
        preset = PRESETS[o.method or "default"]
        fill_in = {k: v for k, v in preset.options.items() if k not in o.given}
        o = replace(o.replace(method=preset.method, preset=preset.name, **fill_in), given=o.given)
    check_option("method", o.method, names())
    method = METHODS[o.method]
    if o.fill.curve_values is None:  # the method's own
        o = replace(o, fill=replace(o.fill, curve_values=method.default_curve_values))
    uncertainty = _check_uncertainty(method, o)
    _check_gp(method, o, uncertainty)
    method.check(o)
    return replace(o, uq=replace(o.uq, uncertainty=uncertainty), checked=True)


def for_surface(options, surface):
    """The configured options for this surface: a preset whose method needs a mass matrix, on a surface without
    one (a digital surface), gives way to its fallback (the default: the paper's pipeline there).

    Examples
    --------
    >>> from manifill.surface.surface import Surface
    >>> from manifill.mesh.shapes import icosphere
    >>> s = Surface.from_mesh(*icosphere(1))
    >>> s.mass = None   # as a digital surface
    >>> o = for_surface(configure(), s)
    >>> o.method, o.preset, o.fill.curve_values, o.fit.bounds
    ('gvf-harmonic', 'default', 'monotone', 'samples')
    """
    preset = PRESETS.get(options.preset)
    if preset is None or preset.fallback is None or surface.mass is not None \
            or not METHODS[options.method].needs_triangles:
        return options
    fb = preset.fallback
    given = {k: options.get(k) for k in options.given if k not in ("method", "preset")}
    fill_in = {k: v for k, v in fb.options.items() if k not in given}
    o = Options.build(**given).replace(method=fb.method, preset=preset.name, **fill_in)
    return configure(replace(o, given=options.given))


def _check_uncertainty(method, o):
    """``uncertainty`` resolved (None: True for the Gaussian process, or with ``trust``), with its refusals."""
    uq = o.uq
    uncertainty = uq.uncertainty
    if uncertainty is None:
        uncertainty = method.gp_mean or uq.trust is not None
    if uncertainty and not method.gives_std:
        raise OptionError(f"uncertainty needs a probability model, and method={method.name!r} has none (the curve "
                          f"pipeline's curve values are estimates); pass method='gp', 'harmonic' or 'biharmonic'")
    if uncertainty and "bounds" in o.given and o.fit.exact:
        raise OptionError("uncertainty and bounds together are not supported: a bounded fill is not a Gaussian "
                          "posterior mean; leave bounds out, or uncertainty, or pass bounds_mode='project'")
    if uq.trust is not None and not uncertainty:
        raise OptionError("trust= needs the standard deviation; leave uncertainty=False out")
    return bool(uncertainty)


def _check_gp(method, o, uncertainty):
    """``gp=`` is the Gaussian process's; a method with a std takes only how its variance is computed."""
    gp = o.uq.gp
    if gp is None:
        return
    if method.gp_mean:
        as_gp_options(gp)  # every gp option against its table, before any work
        return
    if method.gives_std and uncertainty:
        given = [f for f in (gp if isinstance(gp, dict) else
                             {f: getattr(gp, f) for f in GPOptions.__dataclass_fields__
                              if getattr(gp, f) != getattr(GPOptions(), f)})]
        extra = [f for f in given if f not in VARIANCE_OPTIONS]
        if not extra:
            as_gp_options(gp)
            return
        raise OptionError(f"gp option {extra[0]!r} is method='gp''s; with uncertainty, method={method.name!r} takes "
                          f"only {', '.join(VARIANCE_OPTIONS)} in gp=; leave it out")
    raise OptionError(f"gp= holds method='gp''s options, not method={method.name!r}'s; pass method='gp' or leave "
                      f"gp out")
