"""The distributions a sampling study draws its model parameters from, as given in a study
file (``uniform``, ``normal``, ``lognormal``, ``choice``, ``loguniform``,
``bernoulli``): parsed and validated from their TOML tables, and mapped from points of the
unit interval to values (``ppf``).

A distribution is a table ``{ distribution = NAME, ... }`` with exactly the keys of its
kind:

=============  ===========================================  ============================
distribution   keys                                         draws
=============  ===========================================  ============================
``uniform``    ``low``, ``high``                            uniform on [low, high]
``normal``     ``mean``, ``std``; optional ``low``, ``high``  normal, truncated to
                                                            [low, high] when given
``lognormal``  ``median``, ``beta``; optional ``low``,      exp(normal(ln median, beta)),
               ``high``                                     truncated to [low, high]
``choice``     ``values`` (a list)                          each value with the same
                                                            probability
``loguniform`` ``low``, ``high`` (both above 0)             exp(uniform on [ln low,
                                                            ln high])
``bernoulli``  ``p`` (in [0, 1])                            1 with probability p, else 0
=============  ===========================================  ============================

Each sample is drawn as a point ``u`` of the unit interval (the sampler's Latin hypercube,
Sobol' sequence or random point) mapped through the distribution's inverse cumulative
distribution function (:meth:`Distribution.ppf`), so the stratification of the design
carries over to every marginal; a ``choice`` of ``k`` values takes value ``floor(u k)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import InputError

#: the keys of each distribution (required, optional)
KEYS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "uniform": (("low", "high"), ()),
    "normal": (("mean", "std"), ("low", "high")),
    "lognormal": (("median", "beta"), ("low", "high")),
    "choice": (("values",), ()),
    "loguniform": (("low", "high"), ()),
    "bernoulli": (("p",), ()),
}


class ParameterError(InputError):
    """A parameter's distribution table is not valid; ``key`` is the bad key of its table
    (``""`` for the table itself), so a study file can point at its line."""

    def __init__(self, key: str, message: str):
        super().__init__(message)
        self.key = key


@dataclass(frozen=True)
class Distribution:
    """One parameter's distribution.

    Parameters
    ----------
    kind : str
        ``uniform``, ``normal``, ``lognormal``, ``choice``, ``loguniform`` or
        ``bernoulli``.
    args : tuple
        The kind's numbers, in `KEYS` order: (low, high); (mean, std, low, high);
        (median, beta, low, high), with -inf/inf (0/inf for a lognormal) where no
        truncation is given; or, for ``choice``, the values; (low, high) of a
        ``loguniform``, (p,) of a ``bernoulli``.
    """

    kind: str
    args: tuple

    @property
    def bounds(self) -> tuple[Any, Any]:
        """The smallest and largest value it can draw (infinite where unbounded)."""
        if self.kind == "choice":
            nums = [v for v in self.args if not isinstance(v, str)]
            return (min(nums), max(nums)) if len(nums) == len(self.args) else (None, None)
        if self.kind == "bernoulli":
            return 0.0, 1.0
        return self.args[-2], self.args[-1]

    @property
    def values(self) -> tuple:
        """The values of a ``choice`` (empty for the others)."""
        return tuple(self.args) if self.kind == "choice" else ()

    def ppf(self, u: np.ndarray) -> np.ndarray:
        """The values at the points `u` of the unit interval (inverse CDF).

        Parameters
        ----------
        u : ndarray
            Points in [0, 1). [1]

        Returns
        -------
        ndarray
            float64 values, or the chosen values (object array) of a ``choice``.
        """
        u = np.asarray(u, dtype=np.float64)
        if self.kind == "choice":
            k = len(self.args)
            index = np.minimum((u * k).astype(np.int64), k - 1)
            return np.array(self.args, dtype=object)[index]
        if self.kind == "uniform":
            low, high = self.args
            return low + u * (high - low)
        if self.kind == "loguniform":
            low, high = self.args
            return np.exp(math.log(low) + u * (math.log(high) - math.log(low)))
        if self.kind == "bernoulli":
            return (u < self.args[0]).astype(np.float64)
        from scipy.stats import norm

        if self.kind == "normal":
            mean, std, low, high = self.args
            lo, hi = norm.cdf((low - mean) / std), norm.cdf((high - mean) / std)
            x = mean + std * norm.ppf(lo + u * (hi - lo))
            return np.clip(x, low, high)
        median, beta, low, high = self.args  # lognormal
        mu = math.log(median)
        lo = norm.cdf((math.log(low) - mu) / beta) if low > 0 else 0.0
        hi = norm.cdf((math.log(high) - mu) / beta) if math.isfinite(high) else 1.0
        x = np.exp(mu + beta * norm.ppf(lo + u * (hi - lo)))
        return np.clip(x, low, high)

    def frozen(self):
        """The scipy.stats distribution of a continuous kind (for tests and plots)."""
        from scipy import stats

        if self.kind == "uniform":
            low, high = self.args
            return stats.uniform(low, high - low)
        if self.kind == "loguniform":
            return stats.loguniform(*self.args)
        if self.kind == "bernoulli":
            raise InputError("a bernoulli has no continuous distribution")
        if self.kind == "normal":
            mean, std, low, high = self.args
            return stats.truncnorm((low - mean) / std, (high - mean) / std, mean, std)
        if self.kind == "lognormal":
            median, beta, low, high = self.args
            mu = math.log(median)
            a = (math.log(low) - mu) / beta if low > 0 else -np.inf
            b = (math.log(high) - mu) / beta if math.isfinite(high) else np.inf
            return _LogTruncNorm(stats.truncnorm(a, b, mu, beta))
        raise InputError("a choice has no continuous distribution")

    def describe(self) -> str:
        """One line: ``uniform 0.78-0.83``, ``normal 75 +- 3 in [65, 85]``, ..."""
        if self.kind == "choice":
            return "choice of " + ", ".join(str(v) for v in self.args)
        if self.kind == "uniform":
            return f"uniform {self.args[0]:g} to {self.args[1]:g}"
        if self.kind == "loguniform":
            return f"log-uniform {self.args[0]:g} to {self.args[1]:g}"
        if self.kind == "bernoulli":
            return f"1 with probability {self.args[0]:g}, else 0"
        a, b, low, high = self.args
        trunc = "" if not (math.isfinite(high) or (low > -np.inf and low != 0.0)) \
            else f", within [{low:g}, {high:g}]"
        if self.kind == "normal":
            return f"normal, mean {a:g}, std {b:g}{trunc}"
        return f"lognormal, median {a:g}, beta {b:g}{trunc}"

    def to_dict(self) -> dict[str, Any]:
        """The table it was parsed from (truncation bounds only where given)."""
        if self.kind == "choice":
            return {"distribution": "choice", "values": list(self.args)}
        required, optional = KEYS[self.kind]
        if not optional:
            return {"distribution": self.kind, **dict(zip(required, self.args, strict=True))}
        out: dict[str, Any] = {"distribution": self.kind}
        out.update(zip(required, self.args[:len(required)], strict=True))
        if optional:
            low, high = self.args[-2:]
            if math.isfinite(low) and not (self.kind == "lognormal" and low == 0.0):
                out["low"] = low
            if math.isfinite(high):
                out["high"] = high
        return out


class _LogTruncNorm:
    """exp of a (truncated) normal: the cdf and ppf of a (truncated) lognormal."""

    def __init__(self, normal):
        self.normal = normal

    def cdf(self, x):
        with np.errstate(divide="ignore"):
            return self.normal.cdf(np.log(np.asarray(x, dtype=float)))

    def ppf(self, q):
        return np.exp(self.normal.ppf(q))


def _number(key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ParameterError(key, f"{key}={value!r} must be a finite number")
    return float(value)


def parse_distribution(table: Any) -> Distribution:
    """A `Distribution` from its study-file table (module docstring).

    Parameters
    ----------
    table : dict
        The distribution's table of a study file (``{dist = "normal", mean = ..., std = ...}``).

    Raises
    ------
    ParameterError
        Not a table, an unknown distribution or key, a missing key, a bad number (a
        ``std`` or ``beta`` not above 0, ``low`` not below ``high``, a lognormal median or
        bound not above 0), an empty or repeated ``values`` list, or truncation bounds
        that leave nothing of a normal or lognormal (both far in one tail).
    """
    if not isinstance(table, dict):
        raise ParameterError("", f"{table!r} must be an inline table {{ distribution = "
                             "..., ... }}")
    kind = table.get("distribution")
    if kind not in KEYS:
        raise ParameterError("distribution", f"distribution={kind!r} is not one of "
                             f"{', '.join(KEYS)}")
    required, optional = KEYS[kind]
    for k in table:
        if k != "distribution" and k not in required + optional:
            raise ParameterError(k, f"unknown key {k!r} for a {kind} distribution (its "
                                 f"keys: {', '.join(required + optional)})")
    for k in required:
        if k not in table:
            raise ParameterError("distribution", f"a {kind} distribution needs {k!r}")
    if kind == "choice":
        return Distribution("choice", _choice_values(table["values"]))
    args = [_number(k, table[k]) for k in required]
    if kind in ("loguniform", "bernoulli"):
        return _simple(kind, args)
    low = _number("low", table["low"]) if "low" in table else -math.inf
    high = _number("high", table["high"]) if "high" in table else math.inf
    if kind == "uniform":
        low, high = args
    elif args[1] <= 0:
        raise ParameterError(required[1], f"{required[1]}={args[1]!r} must be above 0")
    if kind == "lognormal":
        if args[0] <= 0:
            raise ParameterError("median", f"median={args[0]!r} must be above 0")
        if low < 0 or low == -math.inf:
            if "low" in table:
                raise ParameterError("low", f"low={low!r} must not be negative (a "
                                     "lognormal draws positive values)")
            low = 0.0
    if not low < high:
        raise ParameterError("high", f"low={low!r} must be below high={high!r}")
    if kind != "uniform" and _mass(kind, args, low, high) < 1e-9:
        raise ParameterError("low", f"[{low:g}, {high:g}] holds almost none of the "
                             f"{kind} distribution (it lies far in one tail)")
    return Distribution(kind, (*args, low, high) if kind != "uniform" else (low, high))


def _simple(kind: str, args: list[float]) -> Distribution:
    """A ``loguniform`` (0 < low < high) or ``bernoulli`` (0 <= p <= 1) distribution."""
    if kind == "bernoulli":
        if not 0.0 <= args[0] <= 1.0:
            raise ParameterError("p", f"p={args[0]!r} must lie in [0, 1]")
        return Distribution(kind, tuple(args))
    low, high = args
    if low <= 0:
        raise ParameterError("low", f"low={low!r} must be above 0 (a log-uniform draws "
                             "positive values)")
    if not low < high:
        raise ParameterError("high", f"low={low!r} must be below high={high!r}")
    return Distribution(kind, (low, high))


def _mass(kind: str, args: list[float], low: float, high: float) -> float:
    """The probability of [low, high] under the untruncated normal or lognormal."""
    from scipy.stats import norm

    if kind == "lognormal":
        mu, sd = math.log(args[0]), args[1]
        a = (math.log(low) - mu) / sd if low > 0 else -math.inf
        b = (math.log(high) - mu) / sd if math.isfinite(high) else math.inf
    else:
        a, b = (low - args[0]) / args[1], (high - args[0]) / args[1]
    return float(max(norm.cdf(b) - norm.cdf(a), norm.sf(a) - norm.sf(b)))


def _choice_values(values: Any) -> tuple:
    if not isinstance(values, list) or not values:
        raise ParameterError("values", f"values={values!r} must be a non-empty list")
    kinds = {isinstance(v, str) for v in values}
    if len(kinds) > 1:
        raise ParameterError("values", f"values={values!r} mixes strings and numbers")
    out = []
    for v in values:
        if not isinstance(v, str):
            v = _number("values", v)
        out.append(v)
    if len(set(out)) != len(out):
        raise ParameterError("values", f"values={values!r} repeats a value")
    return tuple(out)
