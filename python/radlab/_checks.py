"""Argument checks in Python's terms: a wrong type is a TypeError, a wrong value a ValueError,
each naming the argument, what it must be and what it got (docs/python.md lists the cases)."""

import math
import numbers


def integer(name, value, minimum=None):
    # bool is an int in Python, never a count here.
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an int, got {type(value).__name__} {value!r}")
    if minimum is not None and value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    return int(value)


def number(name, value, minimum=None, positive=False):
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a number, got {type(value).__name__} {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value}")
    if positive and not value > 0:
        raise ValueError(f"{name} must be > 0, got {value}")
    if minimum is not None and value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    return value


def choice(name, value, choices):
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a str, got {type(value).__name__} {value!r}")
    if value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(choices)}; got {value!r}")
    return value


def text(name, value):
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a str, got {type(value).__name__} {value!r}")
    return value


def assignments(name, params):
    """A parameter dict as the command line's key=value items (--set, --ff-set).

    Floats are written with repr, which round-trips, so {"omega": 1.2} is `omega=1.2`: the same
    text, the same run id, the same value as on the command line."""
    if params is None:
        return []
    if not isinstance(params, dict):
        raise TypeError(f"{name} must be a dict of parameter: value, got {type(params).__name__}")
    items = []
    for key, value in params.items():
        if not isinstance(key, str):
            raise TypeError(f"{name}: keys must be str, got {type(key).__name__} {key!r}")
        if isinstance(value, bool):
            value = "true" if value else "false"
        elif isinstance(value, numbers.Integral):
            value = str(int(value))
        elif isinstance(value, numbers.Real):
            if not math.isfinite(float(value)):
                raise ValueError(f"{name}[{key!r}] must be finite, got {value}")
            value = repr(float(value))
        elif not isinstance(value, str):
            raise TypeError(f"{name}[{key!r}] must be a number, bool or str, "
                            f"got {type(value).__name__}")
        items.append(f"{key}={value}")
    return items


def path(name, value):
    """A file path from a str, a path-like object or an open file (its name); a closed file or
    anything else is refused."""
    import os
    if isinstance(value, (str, os.PathLike)):
        return os.fspath(value)
    if hasattr(value, "closed") and hasattr(value, "name"):
        if value.closed:
            raise ValueError(f"{name}: the file {value.name!r} is closed (pass its path, or the "
                             "file while it is open)")
        if isinstance(value.name, str):
            return value.name
    raise TypeError(f"{name} must be a path (str or os.PathLike), a builtin spec such as "
                    f"'builtin:cornell', or an open file; got {type(value).__name__}")
