"""Checks of arguments at the public entry points (design §11).

One grammar for every message: ``<argument>: expected <what>; got <what came>``.
A value of the wrong *type* raises :class:`TypeError`; a value of the right type but the
wrong shape, range or content raises :class:`ValueError`. Each checker returns the
checked value converted (a float64 array, a Python ``int``), so a caller writes
``order = as_int(order, "order", minimum=1)`` and never checks twice.

This module is a leaf: it imports nothing from handvar, so every layer may use it.

Examples
--------
>>> as_int(3, "order", minimum=1)
3
>>> as_int(0, "order", minimum=1)
Traceback (most recent call last):
...
ValueError: order: expected an integer >= 1; got 0
>>> as_int(0.5, "block index")
Traceback (most recent call last):
...
TypeError: block index: expected an integer; got 0.5
"""

from __future__ import annotations

import numbers
from collections.abc import Iterable

import numpy as np

__all__ = [
    "as_array",
    "as_float",
    "as_instance",
    "as_int",
    "fmt_shape",
    "one_of",
    "readonly",
]


def _bounds(minimum, maximum) -> str:
    if minimum is not None and maximum is not None:
        return f" in [{minimum}, {maximum}]"
    if minimum is not None:
        return f" >= {minimum}"
    if maximum is not None:
        return f" <= {maximum}"
    return ""


def as_int(value, name: str, *, minimum: int | None = None, maximum: int | None = None) -> int:
    """Return `value` as a Python int within the bounds, or raise naming `name`.

    Booleans and floats (even integral ones such as ``2.0``) are not integers here: a
    block index of 0.5 must not be truncated to 0.

    Raises
    ------
    TypeError
        If `value` is not an integer (``int`` or a numpy integer).
    ValueError
        If it lies outside ``[minimum, maximum]``.
    """
    want = f"an integer{_bounds(minimum, maximum)}"
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name}: expected {want}; got {value!r}")
    value = int(value)
    if (minimum is not None and value < minimum) or (maximum is not None and value > maximum):
        raise ValueError(f"{name}: expected {want}; got {value!r}")
    return value


def as_float(
    value,
    name: str,
    *,
    minimum: float | None = None,
    maximum: float | None = None,
    exclusive_minimum: bool = False,
) -> float:
    """Return `value` as a finite Python float within the bounds, or raise naming `name`.

    Parameters
    ----------
    exclusive_minimum : bool
        Require ``value > minimum`` instead of ``value >= minimum``.

    Raises
    ------
    TypeError
        If `value` is not a real number (strings and booleans are not).
    ValueError
        If it is NaN, infinite or outside the bounds.
    """
    if exclusive_minimum and minimum is not None:
        want = f"a finite number > {minimum}" + (
            f" and <= {maximum}" if maximum is not None else ""
        )
    else:
        want = f"a finite number{_bounds(minimum, maximum)}"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name}: expected {want}; got {value!r}")
    value = float(value)
    low_bad = minimum is not None and (value <= minimum if exclusive_minimum else value < minimum)
    if not np.isfinite(value) or low_bad or (maximum is not None and value > maximum):
        raise ValueError(f"{name}: expected {want}; got {value!r}")
    return value


def fmt_shape(shape: tuple[int | None, ...]) -> str:
    """``(None, 3)`` -> ``'(N, 3)'``: how a shape reads in a message."""
    return (
        "("
        + ", ".join("N" if s is None else str(s) for s in shape)
        + ("," if len(shape) == 1 else "")
        + ")"
    )


def as_array(
    value,
    name: str,
    shape: tuple[int | None, ...] | None = None,
    *,
    finite: bool = True,
    what: str = "an array",
) -> np.ndarray:
    """Return `value` as a float64 array of `shape`, or raise naming `name`.

    Parameters
    ----------
    value : array_like
    name : str
        The argument's name, as the caller knows it.
    shape : tuple of int or None, optional
        Required shape; ``None`` in a place allows any length there. ``None`` as a
        whole allows any shape.
    finite : bool
        Reject NaN and infinity.
    what : str
        How the expected value reads in the message ("a pose", "a series").

    Raises
    ------
    TypeError
        If `value` is not numeric (strings, objects, ragged lists).
    ValueError
        If its shape differs or it holds NaN or infinity while `finite`.

    Examples
    --------
    >>> as_array([1, 2, 3], "x", (3,)).dtype
    dtype('float64')
    >>> as_array([[1, 2]], "points", (None, 3))
    Traceback (most recent call last):
    ...
    ValueError: points: expected an array of shape (N, 3); got shape (1, 2)
    """

    def want() -> str:  # built only for a message: this check runs in the fits' loops
        return what if shape is None else f"{what} of shape {fmt_shape(shape)}"

    if type(value) is np.ndarray and value.dtype == np.float64:
        arr = value  # what np.asarray would return
    else:
        if isinstance(value, str | bytes):
            raise TypeError(f"{name}: expected {want()}; got {value!r}")
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise TypeError(f"{name}: expected {want()}; got {_short(value)}") from None
    if shape is not None and (
        arr.ndim != len(shape)
        or any(s is not None and a != s for a, s in zip(arr.shape, shape, strict=True))
    ):
        raise ValueError(f"{name}: expected {want()}; got shape {arr.shape}")
    if finite and not np.isfinite(arr).all():
        raise ValueError(f"{name}: expected finite values; got NaN or infinity")
    return arr


def as_mask(mask, name: str = "mask") -> np.ndarray:
    """Return a 2-D (H, W) mask as C-contiguous uint8 0/1, or raise naming `name`.

    Anything non-zero is inside; booleans and any integer or finite float dtype are
    accepted.

    Examples
    --------
    >>> as_mask([[0, 2], [True, 0]]).tolist()
    [[0, 1], [1, 0]]
    >>> as_mask([1, 0, 1], "sil")
    Traceback (most recent call last):
    ...
    ValueError: sil: expected a 2-D (H, W) mask, got shape (3,)
    """
    arr = np.asarray(mask)
    if arr.ndim != 2:
        raise ValueError(f"{name}: expected a 2-D (H, W) mask, got shape {arr.shape}")
    if arr.dtype.kind not in "biuf":
        raise ValueError(f"{name}: expected a boolean or numeric mask, got dtype {arr.dtype}")
    if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected finite values, got NaN or inf")
    return np.ascontiguousarray(arr != 0, dtype=np.uint8)


def as_instance(value, types: type | tuple[type, ...], name: str, *, what: str | None = None):
    """Return `value` if it is an instance of `types`, else raise :class:`TypeError`.

    Examples
    --------
    >>> as_instance("a", (int, float), "q")
    Traceback (most recent call last):
    ...
    TypeError: q: expected int or float; got 'a'
    """
    if not isinstance(value, types):
        if what is None:
            names = types if isinstance(types, tuple) else (types,)
            what = " or ".join(t.__name__ for t in names)
        raise TypeError(f"{name}: expected {what}; got {_short(value)}")
    return value


def one_of(value, options: Iterable, name: str):
    """Return `value` if it is one of `options`, else raise :class:`ValueError`.

    Examples
    --------
    >>> one_of("relative", ("absolute", "relative"), "mode")
    'relative'
    >>> one_of("rel", ("absolute", "relative"), "mode")
    Traceback (most recent call last):
    ...
    ValueError: mode: expected one of absolute, relative; got 'rel'
    """
    options = tuple(options)
    try:
        ok = value in options
    except TypeError:  # an unhashable value asked of a set
        ok = False
    if not ok:
        raise ValueError(f"{name}: expected one of {', '.join(map(str, options))}; got {value!r}")
    return value


def readonly(value, dtype=float) -> np.ndarray:
    """A read-only copy of `value` as an array of `dtype` (frozen dataclasses' fields)."""
    arr = np.array(value, dtype=dtype)
    arr.flags.writeable = False
    return arr


def _short(value, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."
