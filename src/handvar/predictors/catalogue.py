"""The predictors of the paper and beyond, by name, with the paper's settings.

One catalogue serves the command line (``handvar track --predictor``), the open-loop
evaluation (``handvar predict``) and the experiments: a :class:`PredictorSpec` names
a predictor kind and its constructor arguments, is JSON-friendly (an experiment
store records it) and builds a fresh predictor on demand.

Examples
--------
>>> make_predictor("rvar")
RVAR(gamma=0.8, cutoff=8, mode='paper')
>>> [s.key for s in PAPER_PREDICTORS]
['none', 'decelerating', 'full_var', 'structured_var', 'rvar']
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = [
    "ARG_ALIASES",
    "CATALOGUE",
    "EXTRA_PREDICTORS",
    "PAPER_PREDICTORS",
    "SHORT_NAMES",
    "PredictorSpec",
    "catalogue_key",
    "json_scalar",
    "make_predictor",
]

# --- predictors --------------------------------------------------------------------

_KINDS = ("none", "decelerating", "var", "rvar", "kalman", "one_euro", "adaptive")
_PARAM_NAMES = {
    "none": (),
    "decelerating": ("rho",),
    "var": ("order", "memory", "structured", "max_step"),
    "rvar": ("gamma", "cutoff", "mode", "memory"),
    "kalman": ("q", "r"),
    "one_euro": ("min_cutoff", "beta", "d_cutoff", "rate"),
    "adaptive": (
        "memory",
        "ar_memory",
        "rate",
        "sweeps",
        "ridge",
        "prior_frames",
        "pool",
        "experts",
        "gamma",
        "var_memory",
        "max_step",
        "ar_gate",
        "join",
        "first_step",
    ),
}
# The paper's symbols and a few spellings accepted for the constructor arguments.
ARG_ALIASES = {
    "ρ": "rho",
    "γ": "gamma",
    "c": "cutoff",
    "n": "memory",
    "N": "memory",
    "p": "order",
}


def json_scalar(value: Any) -> Any:
    """A JSON-friendly scalar (bool, int, float, str or None)."""
    if isinstance(value, np.generic):
        value = value.item()
    if value is None or isinstance(value, bool | int | float | str):
        return value
    raise ValueError(f"value: expected a number, a boolean or a string; got {value!r}")


@dataclasses.dataclass(frozen=True)
class PredictorSpec:
    """A motion predictor of an experiment, by kind and constructor arguments.

    Parameters
    ----------
    key : str
        Short identifier used on the command line (``rvar``, ``structured_var``).
    label : str
        Name in the store and on the figures (``"RVAR"``).
    kind : {"none", "decelerating", "var", "rvar", "kalman", "one_euro", "adaptive"}
        :class:`~handvar.predictors.NoMotion`, :class:`~handvar.predictors.Decelerating`,
        :class:`~handvar.predictors.VAR` (``structured=True``: the blocks of eq. 25),
        :class:`~handvar.predictors.RVAR` (``memory``: N of its structured VAR),
        :class:`~handvar.predictors.KalmanCV`, :class:`~handvar.predictors.OneEuro` or
        :class:`~handvar.predictors.AdaptiveBank` (its weight groups and its fast
        blend's VAR blocks: the given blocks, or for hand parameters
        :func:`~handvar.predictors.hand_groups` and :func:`hand_blocks`).
    params : tuple of (str, value) pairs
        Constructor arguments; missing ones take the predictor's defaults.
    """

    key: str
    label: str
    kind: str
    params: tuple[tuple[str, Any], ...] = ()

    def __post_init__(self) -> None:
        if not isinstance(self.key, str) or not self.key:
            raise ValueError(f"key: expected a non-empty string; got {self.key!r}")
        if not isinstance(self.label, str) or not self.label:
            raise ValueError(f"label: expected a non-empty string; got {self.label!r}")
        if self.kind not in _KINDS:
            raise ValueError(f"kind: expected one of {', '.join(_KINDS)}; got {self.kind!r}")
        items = dict(self.params.items() if isinstance(self.params, Mapping) else self.params)
        clean = {}
        for name, value in items.items():
            name = ARG_ALIASES.get(name, name)
            if name not in _PARAM_NAMES[self.kind]:
                allowed = ", ".join(_PARAM_NAMES[self.kind]) or "none"
                raise ValueError(
                    f"params: expected arguments of a {self.kind} predictor ({allowed}); "
                    f"got {name!r}"
                )
            clean[name] = json_scalar(value)
        object.__setattr__(self, "params", tuple(sorted(clean.items())))

    @property
    def kwargs(self) -> dict[str, Any]:
        """The constructor arguments as a dict."""
        return dict(self.params)

    def build(self, blocks=None):
        """A fresh predictor (raises ValueError on a bad argument).

        Parameters
        ----------
        blocks : sequence of sequences of int, optional
            The kinematic blocks of the structured VARs (the structured VAR itself and
            the one inside RVAR); default :func:`hand_blocks`, eq. 25 for the 26 hand
            parameters.  Series in another layout (3D keypoints, say) pass their own.
        """
        from handvar.predictors import (
            RVAR,
            VAR,
            AdaptiveBank,
            Decelerating,
            KalmanCV,
            NoMotion,
            OneEuro,
            hand_blocks,
            hand_groups,
        )

        kw = self.kwargs
        if self.kind == "adaptive":
            if blocks is None:  # hand parameters: the table's groups, eq. 25's blocks
                return AdaptiveBank(hand_groups(), var_blocks=hand_blocks(), **kw)
            return AdaptiveBank(blocks, var_blocks=blocks, **kw)
        if self.kind == "one_euro":
            return OneEuro(**kw)
        blocks = hand_blocks() if blocks is None else blocks
        if self.kind == "none":
            return NoMotion()
        if self.kind == "decelerating":
            return Decelerating(**kw)
        if self.kind == "kalman":
            return KalmanCV(**kw)
        if self.kind == "var":
            structured = kw.pop("structured", False)
            kw = {k: (int(v) if k in ("order", "memory") else v) for k, v in kw.items()}
            return VAR(blocks=blocks if structured else None, **kw)
        memory = int(kw.pop("memory", 30))  # paper §4.3: the structured VAR's N
        if "cutoff" in kw:
            kw["cutoff"] = int(kw["cutoff"])
        return RVAR(structured=VAR(order=1, memory=memory, blocks=blocks), **kw)

    def with_params(self, **changes: Any) -> PredictorSpec:
        """A copy with some constructor arguments changed."""
        return dataclasses.replace(self, params=tuple({**self.kwargs, **changes}.items()))

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly form."""
        return {"key": self.key, "label": self.label, "kind": self.kind, "params": self.kwargs}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> PredictorSpec:
        """Inverse of :meth:`to_dict`."""
        try:
            return cls(data["key"], data["label"], data["kind"], tuple(data["params"].items()))
        except (KeyError, TypeError, AttributeError) as exc:
            raise ValueError(
                f"predictor: expected a mapping with key, label, kind, params; got {data!r}"
            ) from exc


# The paper's five predictors with its settings (paper §4: ρ = 0.4; paper §4.2: full
# VAR, N = 150; paper §4.3: structured VAR, N = 30; paper §5: RVAR, γ = 0.8, c = 8, eq.
# 26–28 as printed; all
# VARs of order 1 with the 10° step bound).
PAPER_PREDICTORS: tuple[PredictorSpec, ...] = (
    PredictorSpec("none", "no motion", "none"),
    PredictorSpec("decelerating", "decelerating", "decelerating", (("rho", 0.4),)),
    PredictorSpec("full_var", "full VAR", "var", (("order", 1), ("memory", 150))),
    PredictorSpec(
        "structured_var",
        "structured VAR",
        "var",
        (("order", 1), ("memory", 30), ("structured", True)),
    ),
    PredictorSpec("rvar", "RVAR", "rvar", (("gamma", 0.8), ("cutoff", 8), ("mode", "paper"))),
)
# Beyond the paper (design §16): eq. 27 fitted on its origin-free edge α + β = 1, the
# relative interpolation mentioned after eq. 27, the textbook constant-velocity Kalman
# filter, the One Euro filter of keypoint pipelines and the adaptive bank.
EXTRA_PREDICTORS: tuple[PredictorSpec, ...] = (
    PredictorSpec(
        "rvar_edge", "RVAR edge", "rvar", (("gamma", 0.8), ("cutoff", 8), ("mode", "edge"))
    ),
    PredictorSpec(
        "rvar_relative",
        "RVAR relative",
        "rvar",
        (("gamma", 0.8), ("cutoff", 8), ("mode", "relative")),
    ),
    PredictorSpec("kalman", "Kalman CV", "kalman"),
    PredictorSpec("one_euro", "One Euro", "one_euro"),
    # The bank that steers the tracker leaves out the experts that carry the whole last
    # step forward (design §16, "In closed loop"); the bank of all twelve experts is the
    # open-loop one.
    PredictorSpec("adaptive", "adaptive bank", "adaptive", (("experts", "steering"),)),
    PredictorSpec("adaptive_open", "adaptive bank (all experts)", "adaptive"),
)
CATALOGUE: dict[str, PredictorSpec] = {s.key: s for s in PAPER_PREDICTORS + EXTRA_PREDICTORS}

#: Short names of the command line, and the catalogue key each stands for.
SHORT_NAMES: dict[str, str] = {
    "decel": "decelerating",
    "fullvar": "full_var",
    "svar": "structured_var",
    "rvar-edge": "rvar_edge",
    "rvar-rel": "rvar_relative",
    "euro": "one_euro",
    "bank": "adaptive",
    "bank-all": "adaptive_open",
}


def make_predictor(name: str):
    """A fresh predictor from the catalogue, by key or command-line short name.

    Parameters
    ----------
    name : str
        A key of :data:`CATALOGUE` (``"none"``, ``"decelerating"``, ``"full_var"``,
        ``"structured_var"``, ``"rvar"`` (eq. 26–28 as printed), ``"rvar_edge"``,
        ``"rvar_relative"``, ``"kalman"``, ``"one_euro"``, ``"adaptive"``,
        ``"adaptive_open"``) or a short name (``decel``, ``fullvar``, ``svar``,
        ``rvar-edge``, ``rvar-rel``, ``euro``, ``bank``, ``bank-all``).
    """
    return CATALOGUE[catalogue_key(name)].build()


def catalogue_key(name: str, argument: str = "predictor") -> str:
    """The catalogue key that `name` (a key or a short name) stands for.

    Raises ``ValueError`` naming `argument` when it is neither.

    >>> catalogue_key("bank"), catalogue_key("rvar")
    ('adaptive', 'rvar')
    """
    key = SHORT_NAMES.get(name, name)
    if key not in CATALOGUE:
        names = ", ".join([*CATALOGUE, *SHORT_NAMES])
        raise ValueError(f"{argument}: expected one of {names}; got {name!r}")
    return key
