"""The configuration of an experiment: protocol, predictors and tracker settings (design §7).

:class:`ExperimentConfig` is the paper's protocol (paper §4) by default, changed by
``KEY=VALUE`` assignments (the command line's ``--set``) and swept predictor
arguments (``--sweep``); it is stored as JSON in the experiment's store.

Examples
--------
>>> cfg = ExperimentConfig.quick().with_overrides(["trials=2"])
>>> cfg.trials, cfg.frames, [s.label for s in cfg.predictors][:2]
(2, 40, ['no motion', 'decelerating'])
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Iterable, Mapping
from typing import Any

from handvar.predictors.catalogue import (
    ARG_ALIASES,
    CATALOGUE,
    EXTRA_PREDICTORS,
    PAPER_PREDICTORS,
    PredictorSpec,
    json_scalar,
)
from handvar.validate import as_float, as_instance, as_int, one_of

__all__ = [
    "EXTRA_PREDICTORS",
    "PAPER_PREDICTORS",
    "TRIAL_KINDS",
    "ExperimentConfig",
    "PredictorSpec",
    "tracker_settings",
]

TRIAL_KINDS = ("tracker", "openloop")


def _parse_value(text: str) -> Any:
    """``true``/``false``/``none``, an int, a float, else the string itself."""
    low = text.strip().lower()
    if low in ("true", "yes", "on"):
        return True
    if low in ("false", "no", "off"):
        return False
    if low in ("none", "null"):
        return None
    for cast in (int, float):
        try:
            return cast(text)
        except ValueError:
            pass
    return text.strip()


def _split_assignment(text: str, what: str) -> tuple[str, str]:
    if not isinstance(text, str) or "=" not in text:
        raise ValueError(f"{what}: expected KEY=VALUE; got {text!r}")
    key, value = text.split("=", 1)
    key = key.strip()
    if not key:
        raise ValueError(f"{what}: expected KEY=VALUE; got {text!r}")
    return key, value


def _format_value(value: Any) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


@dataclasses.dataclass(frozen=True)
class ExperimentConfig:
    """One experiment: the paper's protocol (paper §4, design §7) by default.

    Attributes
    ----------
    sequence : str
        Synthetic sequence (``benchmark``, ``flexion``, ``flip``), rendered once.
    sequence_seed : int
        Seed of the sequence's motion.
    frames : int
        First frames of the sequence to track (the paper: all 175).
    trials : int
        Trials per predictor (the paper: 50).
    seed : int
        Trial k uses ``numpy.random.default_rng([seed, k])`` for every predictor.
    predictors : tuple of PredictorSpec
        The paper's five (:data:`PAPER_PREDICTORS`); :meth:`with_extras` adds
        the relative RVAR and the Kalman filter.
    trial_kind : {"tracker", "openloop"}
        ``"tracker"``: the SMD tracker on the silhouettes (the experiment of the
        paper).  ``"openloop"``: no tracker; the predictor runs one step ahead along
        the truth plus Gaussian noise of standard deviation `noise` (mm, degrees), and
        its predictions are the poses -- a quick check of predictors and machinery.
    noise : float
        Noise of the ``openloop`` trials.
    tracker : tuple of (str, value) pairs
        Overrides of the tracker's settings (those of paper §4 by default).
    sequence_model : {"spheres", "mesh"}
        The surface that renders the sequence (docs/results/mismatch.md): the tracker's
        own sphere-mesh by default, or the skinned mesh -- model mismatch.
    sequence_length, sequence_breadth : float
        The rendering hand's length and breadth as factors of the tracker's default
        185 × 85 mm hand (shape mismatch; the truth's joints are the rendering hand's).
    sequence_speed : float
        The motion replayed this many times faster at the same frame rate (the
        sequence has fewer frames: set `frames` to at most their number).
    sequence_noise : float
        Strength (pixels) of the silhouette corruption of a real segmentation
        (:func:`handvar.synth.mismatch.corrupt_silhouettes`, seeded by
        `sequence_seed`); 0: exact silhouettes.
    tracker_model : {"spheres", "mesh"}
        The surface the tracker fits (the mesh costs ~13.5 ms per iteration, design §15).

    ``--set sequence.model=mesh`` and the like set the ``sequence_*`` fields,
    ``--set tracker.model=mesh`` sets `tracker_model`.
    """

    sequence: str = "benchmark"
    sequence_seed: int = 0
    frames: int = 175
    trials: int = 50
    seed: int = 0
    predictors: tuple[PredictorSpec, ...] = PAPER_PREDICTORS
    trial_kind: str = "tracker"
    noise: float = 2.0
    tracker: tuple[tuple[str, Any], ...] = ()
    sequence_model: str = "spheres"
    sequence_length: float = 1.0
    sequence_breadth: float = 1.0
    sequence_speed: float = 1.0
    sequence_noise: float = 0.0
    tracker_model: str = "spheres"

    def __post_init__(self) -> None:
        from handvar.synth.sequences import SEQUENCE_NAMES

        one_of(self.sequence, SEQUENCE_NAMES, "sequence")
        for name, low in (("sequence_seed", 0), ("frames", 3), ("trials", 1), ("seed", 0)):
            object.__setattr__(self, name, as_int(getattr(self, name), name, minimum=low))
        one_of(self.trial_kind, TRIAL_KINDS, "trial_kind")
        object.__setattr__(self, "noise", as_float(self.noise, "noise", minimum=0))
        one_of(self.sequence_model, ("spheres", "mesh"), "sequence_model")
        one_of(self.tracker_model, ("spheres", "mesh"), "tracker_model")
        for name, low, high in (
            ("sequence_length", 0.5, 2.0),
            ("sequence_breadth", 0.5, 2.0),
            ("sequence_speed", 1.0, None),
            ("sequence_noise", 0.0, 50.0),
        ):
            value = as_float(getattr(self, name), name, minimum=low, maximum=high)
            object.__setattr__(self, name, value)
        specs = tuple(as_instance(self.predictors, (tuple, list), "predictors"))
        if not specs:
            raise ValueError("predictors: expected a non-empty tuple of PredictorSpec; got ()")
        for s in specs:
            as_instance(s, PredictorSpec, "predictors", what="a tuple of PredictorSpec")
        for attr in ("key", "label"):
            names = [getattr(s, attr) for s in specs]
            dup = sorted({n for n in names if names.count(n) > 1})
            if dup:
                raise ValueError(f"predictors: expected distinct {attr}s; got {dup} twice")
        object.__setattr__(self, "predictors", specs)
        tracker = dict(self.tracker.items() if isinstance(self.tracker, Mapping) else self.tracker)
        object.__setattr__(
            self, "tracker", tuple(sorted((k, json_scalar(v)) for k, v in tracker.items()))
        )

    # -- presets and changes ----------------------------------------------------
    @classmethod
    def quick(cls) -> ExperimentConfig:
        """A reduced protocol for a demonstration: 3 trials of the first 40 frames."""
        return cls(trials=3, frames=40)

    @property
    def mismatch(self) -> dict[str, Any]:
        """The settings of the sequence and tracker that differ from the paper's."""
        default = ExperimentConfig()
        return {
            name: getattr(self, name)
            for name in _MISMATCH
            if getattr(self, name) != getattr(default, name)
        }

    @property
    def reference(self) -> PredictorSpec | None:
        """The no-motion entry R̃² is measured against (the first of kind ``none``)."""
        return next((s for s in self.predictors if s.kind == "none"), None)

    @property
    def labels(self) -> list[str]:
        """The predictors' labels, in order."""
        return [s.label for s in self.predictors]

    def spec(self, key_or_label: str) -> PredictorSpec:
        """The predictor entry with this key or label."""
        for s in self.predictors:
            if key_or_label in (s.key, s.label):
                return s
        raise ValueError(
            f"predictor: expected one of {', '.join(s.key for s in self.predictors)}; "
            f"got {key_or_label!r}"
        )

    def with_extras(self) -> ExperimentConfig:
        """Add :data:`EXTRA_PREDICTORS` (relative RVAR, Kalman CV, One Euro, both adaptive
        banks), those not yet present."""
        keys = {s.key for s in self.predictors}
        extra = tuple(s for s in EXTRA_PREDICTORS if s.key not in keys)
        return dataclasses.replace(self, predictors=self.predictors + extra)

    def with_overrides(self, assignments: Iterable[str]) -> ExperimentConfig:
        """Apply ``KEY=VALUE`` assignments (the command line's ``--set``).

        Keys: a field (``trials``, ``frames``, ``seed``, ``sequence``,
        ``sequence_seed``, ``trial_kind`` or ``trial``, ``noise``, the mismatch
        fields ``sequence.model``, ``sequence.length``, ``sequence.breadth``,
        ``sequence.speed``, ``sequence.noise``, ``tracker.model``); ``predictors`` with
        a comma-separated list of keys (``none,decelerating,rvar,rvar_relative,kalman``
        ...); ``extras=true``; ``tracker.FIELD`` for a tracker setting;
        ``PREDICTOR.ARG`` for a predictor's argument (``rvar.gamma=0.7``,
        ``decelerating.rho=0.5``, ``structured_var.N=20``).
        """
        cfg = self
        for text in assignments:
            key, raw = _split_assignment(text, "--set")
            value = _parse_value(raw)
            if key == "trial":
                key = "trial_kind"
            if key.startswith("sequence.") or key == "tracker.model":
                key = key.replace(".", "_", 1)
            if key == "predictors":
                wanted = [k.strip() for k in str(raw).split(",") if k.strip()]
                unknown = [k for k in wanted if k not in CATALOGUE]
                if unknown or not wanted:
                    raise ValueError(
                        f"--set predictors: expected keys among {', '.join(CATALOGUE)}; got {raw!r}"
                    )
                cfg = dataclasses.replace(cfg, predictors=tuple(CATALOGUE[k] for k in wanted))
            elif key == "extras":
                if value is True:
                    cfg = cfg.with_extras()
                elif value is not False:
                    raise ValueError(f"--set extras: expected true or false; got {raw!r}")
            elif key.startswith("tracker."):
                group, field = _tracker_key(key.split(".", 1)[1])
                name = f"{group}.{field}"
                tracker_settings([(name, value)])  # checks the value
                kept = tuple((k, v) for k, v in cfg.tracker if k != name)
                cfg = dataclasses.replace(cfg, tracker=(*kept, (name, value)))
            elif "." in key:
                pkey, arg = key.split(".", 1)
                spec = cfg.spec(pkey)
                new = spec.with_params(**{arg: value})
                new.build()
                cfg = dataclasses.replace(
                    cfg, predictors=tuple(new if s is spec else s for s in cfg.predictors)
                )
            elif key in {f.name for f in dataclasses.fields(self)} - {"predictors", "tracker"}:
                try:
                    cfg = dataclasses.replace(cfg, **{key: value})
                except TypeError as exc:  # text of the wrong kind: the assignment is wrong
                    raise ValueError(str(exc)) from None
            else:
                raise ValueError(
                    f"--set: expected a field ({', '.join(_SETTABLE)}), tracker.FIELD or "
                    f"PREDICTOR.ARG; got {key!r}"
                )
        return cfg

    def with_sweep(self, text: str) -> ExperimentConfig:
        """Add swept variants of one predictor: ``"rvar.gamma=0.5,0.6,0.7"``.

        Each value becomes an extra predictor entry labelled like ``RVAR (gamma=0.5)``;
        a value equal to the entry's own setting is not repeated.
        """
        key, raw = _split_assignment(text, "--sweep")
        if "." not in key:
            raise ValueError(f"--sweep: expected PREDICTOR.ARG=V1,V2,...; got {text!r}")
        pkey, arg = key.split(".", 1)
        base = self.spec(pkey)
        arg = ARG_ALIASES.get(arg, arg)
        values = [_parse_value(v) for v in raw.split(",") if v.strip()]
        if not values:
            raise ValueError(f"--sweep: expected at least one value; got {text!r}")
        specs = list(self.predictors)
        for v in values:
            variant = base.with_params(**{arg: v})
            if variant.params == base.params:
                continue
            variant = dataclasses.replace(
                variant,
                key=f"{base.key}[{arg}={_format_value(v)}]",
                label=f"{base.label} ({arg}={_format_value(v)})",
            )
            variant.build()
            if all(s.key != variant.key for s in specs):
                specs.append(variant)
        return dataclasses.replace(self, predictors=tuple(specs))

    # -- JSON -----------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly form (stored in the store's attributes)."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        out["predictors"] = [s.to_dict() for s in self.predictors]
        out["tracker"] = dict(self.tracker)
        return out

    def to_json(self) -> str:
        """:meth:`to_dict` as a JSON string with sorted keys."""
        return json.dumps(self.to_dict(), sort_keys=True)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ExperimentConfig:
        """Inverse of :meth:`to_dict`."""
        as_instance(data, Mapping, "config", what="a mapping")
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"config: unknown keys {unknown}")
        kw = dict(data)
        if "predictors" in kw:
            kw["predictors"] = tuple(PredictorSpec.from_dict(d) for d in kw["predictors"])
        if "tracker" in kw:
            kw["tracker"] = tuple(dict(kw["tracker"]).items())
        return cls(**kw)

    @classmethod
    def from_json(cls, text: str) -> ExperimentConfig:
        """Inverse of :meth:`to_json`."""
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"config: expected JSON; {exc}") from None
        return cls.from_dict(data)


_MISMATCH = (
    "sequence_model",
    "sequence_length",
    "sequence_breadth",
    "sequence_speed",
    "sequence_noise",
    "tracker_model",
)
_SETTABLE = (
    "sequence",
    "sequence_seed",
    "frames",
    "trials",
    "seed",
    "trial_kind",
    "noise",
    *_MISMATCH,
)


# --- the tracker ---------------------------------------------------------------------


def tracker_settings(overrides: Iterable[tuple[str, Any]] = ()):
    """The tracker's settings (those of paper §4) with ``("group.field", value)`` overrides.

    A group is a field of :class:`handvar.tracking.TrackerSettings` (``smd``, ``cost``);
    a bare field name (``max_iterations``) is looked up in every group.

    Examples
    --------
    >>> tracker_settings([("max_iterations", 20)]).smd.max_iterations
    20
    """
    from handvar.tracking import TrackerSettings

    base = TrackerSettings()
    groups: dict[str, dict[str, Any]] = {}
    for key, value in overrides:
        group, name = _tracker_key(key)
        groups.setdefault(group, {})[name] = value
    return dataclasses.replace(
        base,
        **{g: dataclasses.replace(getattr(base, g), **kw) for g, kw in groups.items()},
    )


def _tracker_key(key: str) -> tuple[str, str]:
    """(group, field) of a tracker setting; ValueError naming the choices."""
    from handvar.tracking import TrackerSettings

    base = TrackerSettings()
    fields = {
        g.name: {f.name for f in dataclasses.fields(getattr(base, g.name))}
        for g in dataclasses.fields(base)
    }
    choices = ", ".join(f"{g}.{f}" for g in fields for f in sorted(fields[g]))
    if "." in key:
        group, name = key.split(".", 1)
        if name in fields.get(group, ()):
            return group, name
    else:
        hits = [g for g in fields if key in fields[g]]
        if len(hits) == 1:
            return hits[0], key
    raise ValueError(f"--set tracker.{key}: expected a tracker setting ({choices})")
