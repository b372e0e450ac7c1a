"""How numbers are written in the report: one function, used by tables and text alike."""

from __future__ import annotations

import math

__all__ = ["format_number"]


def format_number(value, digits: int = 3) -> str:
    """Render a number with ``digits`` significant digits, scientific when very small or large.

    Parameters
    ----------
    value : float or int or None
        None and NaN render as "n/a"; integers render exactly.
    digits : int
        Significant digits of a float.

    Returns
    -------
    str
    """
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    value = float(value)
    if math.isnan(value):
        return "n/a"
    if math.isinf(value):
        return "inf" if value > 0 else "-inf"
    if value == 0.0:
        return "0"
    magnitude = abs(value)
    if 1e-3 <= magnitude < 1e5:
        decimals = max(digits - 1 - math.floor(math.log10(magnitude)), 0)
        text = f"{value:.{decimals}f}"
        return text.rstrip("0").rstrip(".") if "." in text else text
    return f"{value:.{digits - 1}e}"
