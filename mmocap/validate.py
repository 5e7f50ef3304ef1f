"""Checks of configuration values: each returns the value, converted, or raises a
:class:`~mmocap.errors.ConfigError` whose message names the key, the allowed range and
the value given (``optimizer.popsize must be an integer in [2, inf), got 'lots'``).

Every component checks its constructor arguments with these, so that a bad value fails
when the component is built, before any data is read.
"""

from __future__ import annotations

import math
import numbers
from typing import Any, Literal, overload

import numpy as np

from mmocap.errors import ConfigError


def is_real(value) -> bool:
    """True for an int or float (numpy's too), False for bool and anything else."""
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def is_integer(value) -> bool:
    """True for an int (numpy's too), False for bool, floats and anything else."""
    return isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))


@overload
def check_number(
    key: str,
    value: Any,
    low: float = ...,
    high: float = ...,
    *,
    low_open: bool = ...,
    high_open: bool = ...,
    integer: Literal[False] = ...,
) -> float: ...
@overload
def check_number(
    key: str,
    value: Any,
    low: float = ...,
    high: float = ...,
    *,
    low_open: bool = ...,
    high_open: bool = ...,
    integer: Literal[True],
) -> int: ...
def check_number(
    key: str,
    value: Any,
    low: float = -math.inf,
    high: float = math.inf,
    *,
    low_open: bool = False,
    high_open: bool = False,
    integer: bool = False,
) -> float:
    """``value`` as float (int with ``integer``) if it is a finite number in the interval
    from ``low`` to ``high`` (ends excluded with ``low_open`` / ``high_open``), else a
    ConfigError naming ``key``."""
    ok = is_integer(value) if integer else is_real(value)
    if ok:
        ok = (
            math.isfinite(value)
            and (value > low if low_open else value >= low)
            and (value < high if high_open else value <= high)
        )
    if not ok:
        kind = "an integer" if integer else "a number"
        left = "(" if low_open or low == -math.inf else "["
        right = ")" if high_open or high == math.inf else "]"
        raise ConfigError(f"{key} must be {kind} in {left}{low}, {high}{right}, got {value!r}")
    return int(value) if integer else float(value)


def check_flag(key: str, value: Any) -> bool:
    """``value`` as a bool if it is one, else a ConfigError naming ``key``."""
    if not isinstance(value, (bool, np.bool_)):
        raise ConfigError(f"{key} must be true or false, got {value!r}")
    return bool(value)


def check_choice(key: str, value, choices) -> str:
    """``value`` if it is one of ``choices`` (strings), else a ConfigError naming ``key`` and
    listing them."""
    if not isinstance(value, str) or value not in choices:
        raise ConfigError(f"{key} must be one of {', '.join(choices)}, got {value!r}")
    return value
