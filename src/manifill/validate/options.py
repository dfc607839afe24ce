"""Options and messages: the closed sets of option strings, and the helpers every validator's message uses."""

import numpy as np

from ..errors import OptionError

__all__ = ["check_option", "first_entries", "integral_floats"]


def first_entries(idx, k=5):
    """Format the first ``k`` entries of an index list for a message.

    Examples
    --------
    >>> first_entries([4, 8, 15, 16, 23, 42])
    '4, 8, 15, 16, 23, ...'
    """
    idx = np.asarray(idx).ravel()
    head = ", ".join(str(int(i)) for i in idx[:k])
    return head + (", ..." if idx.size > k else "")


def integral_floats(a):
    """True for a float array of whole numbers small enough to be indices.

    Examples
    --------
    >>> integral_floats(np.array([1.0, 2.0])), integral_floats(np.array([1.5])), integral_floats(np.array([1]))
    (True, False, False)
    """
    return (np.issubdtype(a.dtype, np.floating) and bool(np.all(np.isfinite(a)))
            and bool(np.all(a == np.round(a))) and bool(np.all(np.abs(a) < 2.0**62)))


def check_option(name, value, allowed):
    """Check that a keyword option is one of a closed set of strings.

    Parameters
    ----------
    name : str
        The option's name, for the message.
    value : object
        The value given.
    allowed : sequence of str
        The allowed values.

    Returns
    -------
    str
        ``value``, unchanged.

    Raises
    ------
    OptionError
        If ``value`` is not in ``allowed``.

    Examples
    --------
    >>> check_option("weights", "cotan", ("uniform", "cotan"))
    'cotan'
    """
    if not isinstance(value, str) or value not in allowed:
        raise OptionError(
            f"{name}={value!r} is not one of {', '.join(repr(a) for a in allowed)}; "
            f"pass one of those"
        )
    return value
