"""Plug-in attacks written in Python.

Subclass :class:`Attack` and define ``act(self, view)``; pass an instance to
``swarmfl.run(..., attack=MyAttack(), set={"byzantine.count": 3})``. The core asks it exactly
as it asks its built-in attacks (``byzantine.kind = "plugin"``): on the simulation's driver
thread, in robot order, at every learning phase of every Byzantine robot, with what that
robot's own node knows (:class:`AttackView`). ``act`` returns ``(weights, samples)`` to submit
(a float array of the model's length and the claimed sample count) or ``None`` to wait: it is
then asked again at the next tick, and the phase is skipped if it still waits when the robot's
next phase is due (``view.last_chance``).

The log header records the plug-in's name and the blake3 digest of its class's source
(``inspect.getsource`` of the class); ``swarmfl.replay(..., resimulate=True)`` and
``swarmfl.fork`` refuse a log whose plug-in is not given or whose source changed, and the
``swarmfl`` command refuses to re-simulate or fork a log made with a plug-in (it cannot run
Python); what reads the log from its records (a fold, the tables, the viewer) needs no attack.
See docs/PYTHON.md, "Plug-in attacks", for what
is deterministic.
"""

from __future__ import annotations

import inspect
import json
import re
import traceback
from types import SimpleNamespace
from typing import Any, Callable, Optional

import numpy as np

from ._swarmfl import SwarmflError

__all__ = ["Attack", "AttackView", "PluginError", "Rule"]


class PluginError(SwarmflError):
    """A plug-in raised or answered what the contract cannot take. The message names the
    plug-in, the round, the robot and the simulated time; the plug-in's own exception (with its
    traceback) is the ``__cause__``."""


class Attack:
    """Base class of a plug-in attack.

    ``name`` (default: the class's name) is what ``byzantine.plugin`` records; ``act(view)``
    returns ``(weights, samples)`` or ``None`` (wait). For randomness use ``view.rng()`` (a numpy
    generator seeded from the robot's own Byzantine stream of the phase): global random state
    would make the run depend on what else the process did.
    """

    name: Optional[str] = None

    def act(self, view: "AttackView"):
        raise NotImplementedError(f"{type(self).__name__}.act(view) is not defined")


class AttackView:
    """What a Byzantine robot's own node knows when it decides (the core's ``byzantine::View``).

    Attributes: ``robot``, ``round`` (the shared model's version on its chain), ``time_s``,
    ``last_chance`` (waiting now skips the phase), ``shared`` (w(t), float32 array),
    ``previous`` (w(t-1) or None in round 0), ``submissions`` (the round's submissions already on
    its chain: ``sender``, ``samples``, ``outlier``, ``byzantine``, ``weights``), ``coalition``
    (bool array: which robots are Byzantine), ``samples`` (its own data set, float32 array of
    shape (n, waypoints, 2): ``input_waypoints`` inputs then the targets), ``threshold`` (the
    outlier threshold, mean absolute distance per weight), ``weight_scale``,
    ``claimed_samples`` (``byzantine.claimed_samples``), ``claim_bound`` (the most samples the
    contract takes in a claim, ``contract.max_claimed_samples`` or the bound derived from the
    data window: a larger claim is refused as ``malformed``), ``config`` (every ``byzantine.*``
    key) and ``seed``.
    """

    def __init__(self, raw: dict):
        self.robot: int = raw["robot"]
        self.round: int = raw["round"]
        self.time_s: float = raw["now_ms"] / 1000.0
        self.last_chance: bool = raw["last_chance"]
        self.weight_scale: int = raw["weight_scale"]
        self.threshold: float = raw["threshold"]
        self.input_waypoints: int = raw["input_waypoints"]
        self.claimed_samples: int = raw["claimed_samples"]
        self.claim_bound: int = raw["claim_bound"]
        self.seed: int = raw["seed"]
        self._config_json: str = raw["config_json"]
        self.shared = np.frombuffer(raw["shared"], dtype="<f4")
        prev = raw["previous"]
        self.previous = None if prev is None else np.frombuffer(prev, dtype="<f4")
        self.coalition = np.array(raw["coalition"], dtype=bool)
        self.submissions = [
            SimpleNamespace(sender=s, samples=n, outlier=o, byzantine=b,
                            weights=np.frombuffer(w, dtype="<f4"))
            for s, n, o, b, w in raw["submissions"]
        ]
        count = raw["sample_count"]
        points = np.frombuffer(raw["samples"], dtype="<f4")
        self.samples = points.reshape(count, -1, 2) if count else points.reshape(0, 0, 2)

    @property
    def config(self) -> dict:
        """Every ``byzantine.*`` key of the run's configuration."""
        return json.loads(self._config_json)

    @property
    def honest_models(self) -> np.ndarray:
        """The weights of the round's submissions from robots outside the coalition, one row
        each in submission order (shape (k, n); k may be 0)."""
        rows = [s.weights for s in self.submissions if not s.byzantine]
        if not rows:
            return np.empty((0, self.shared.size), dtype=np.float32)
        return np.stack(rows)

    def rng(self) -> np.random.Generator:
        """A numpy generator seeded from the robot's Byzantine stream of this phase."""
        return np.random.default_rng(self.seed)

    def __repr__(self) -> str:
        return (f"AttackView(robot={self.robot}, round={self.round}, time_s={self.time_s}, "
                f"submissions={len(self.submissions)}, model={self.shared.size} weights)")


_NAME = re.compile(r"[A-Za-z0-9_.-]{1,100}")


def describe(attack: Any) -> tuple:
    """``(name, what was hashed, source)`` of a plug-in attack instance; raises
    :class:`SwarmflError` for what cannot be one."""
    if isinstance(attack, type):
        raise SwarmflError(
            f"attack= takes an instance, got the class {attack.__name__}: pass {attack.__name__}()")
    act = getattr(attack, "act", None)
    if not callable(act):
        raise SwarmflError(
            f"attack= takes an object with an act(view) method (a swarmfl.Attack), "
            f"got {type(attack).__name__}")
    cls = type(attack)
    name = getattr(attack, "name", None) or cls.__name__
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        raise SwarmflError(
            f"plug-in attack name {name!r}: use 1 to 100 of A-Z a-z 0-9 _ - . (set the class's "
            "name attribute)")
    try:
        return name, f"inspect.getsource({cls.__qualname__})", inspect.getsource(cls)
    except (OSError, TypeError):
        pass
    # A class of a notebook cell (before Python 3.13 inspect finds no class source there, but
    # finds its functions'): the sources of its methods, in name order.
    try:
        parts = [inspect.getsource(v) for _, v in sorted(vars(cls).items())
                 if inspect.isfunction(v)]
    except (OSError, TypeError) as e:
        raise SwarmflError(
            f"plug-in attack `{name}`: cannot read the source of class {cls.__qualname__} "
            f"({e}); the log header records its digest: define it in a file or a notebook cell"
        ) from None
    if not parts:
        raise SwarmflError(
            f"plug-in attack `{name}`: class {cls.__qualname__} defines no method of its own "
            "(act comes from a base class): define act in it")
    return name, f"inspect.getsource of {cls.__qualname__}'s methods", "".join(parts)


def _fail(name: str, view: AttackView, what: str, detail: str = "") -> PluginError:
    return PluginError(
        f"plug-in attack `{name}` {what} (round {view.round}, robot {view.robot}, "
        f"t = {view.time_s:g} s){detail}")


def adapter(name: str, attack: Any) -> Callable[[dict], Optional[tuple]]:
    """The callable the core asks: builds the view, calls ``attack.act`` and checks the
    answer, raising :class:`PluginError` with the plug-in's name, round and robot."""

    def call(raw: dict) -> Optional[tuple]:
        view = AttackView(raw)
        try:
            answer = attack.act(view)
        except Exception as e:  # the plug-in's own error, whatever it is
            tb = "".join(traceback.format_exception(type(e), e, e.__traceback__))
            raise _fail(name, view, f"raised {type(e).__name__}: {e}", f"\n{tb}") from e
        if answer is None:
            return None
        if not isinstance(answer, (tuple, list)) or len(answer) != 2:
            raise _fail(name, view, f"returned {type(answer).__name__} {answer!r:.80}; "
                                    "return (weights, samples) or None to wait")
        weights, samples = answer
        try:
            w = np.asarray(weights, dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise _fail(name, view, f"returned weights that are not numbers ({e})") from None
        if w.ndim != 1 or w.size != view.shared.size:
            raise _fail(name, view, f"returned weights of shape {w.shape}; the model has "
                                    f"{view.shared.size} weights (shape ({view.shared.size},))")
        bad = np.flatnonzero(~np.isfinite(w))
        if bad.size:
            raise _fail(name, view, f"returned {bad.size} non-finite weights (weight {bad[0]} "
                                    f"is {w[bad[0]]})")
        if isinstance(samples, (bool, np.bool_)) or not isinstance(samples, (int, np.integer)):
            raise _fail(name, view, f"returned samples {samples!r} of type "
                                    f"{type(samples).__name__}; the claimed sample count is an int")
        samples = int(samples)
        if not 0 <= samples <= 2**32 - 1:
            raise _fail(name, view, f"returned samples = {samples}; claims are 0 to 2^32 - 1")
        f32 = w.astype("<f4")
        if not np.all(np.isfinite(f32)):
            raise _fail(name, view, "returned weights beyond float32's range")
        return f32.tobytes(), samples

    return call


def plugin_arg(attack: Any) -> Optional[tuple]:
    """What the extension takes for ``attack=``: ``(name, what, source, adapter)``."""
    if attack is None:
        return None
    name, what, source = describe(attack)
    return name, what, source, adapter(name, attack)


class Rule:
    """Base class of a plug-in aggregation rule (a plain function works too).

    ``name`` (default: the class's name) is what ``contract.rule_plugin`` records;
    ``aggregate(models, f, current, samples)`` gets the round's accepted models as an
    ``(n, d)`` int64 array of fixed-point weights in submission order, the assumed Byzantine
    count ``f`` (``contract.assumed_f``), the shared model the round was opened on (``(d,)``
    int64) and the claimed sample counts (``(n,)`` int64), and returns the next shared model:
    ``d`` integers (any integer dtype), each of magnitude below 2^47. Integers in, integers out,
    like the built-in rules: round where the rule divides. The contract pays the ``n - f``
    submissions nearest (L1) to the answer, as for its own median.
    """

    name: Optional[str] = None

    def aggregate(self, models, f, current, samples):
        raise NotImplementedError(f"{type(self).__name__}.aggregate(models, f, current, samples) "
                                  "is not defined")


def describe_rule(rule: Any) -> tuple:
    """``(name, what was hashed, source, callable)`` of a plug-in rule (a function or a
    :class:`Rule` instance); raises :class:`SwarmflError` for what cannot be one."""
    if isinstance(rule, type):
        raise SwarmflError(
            f"rule= takes a function or an instance, got the class {rule.__name__}: pass "
            f"{rule.__name__}()")
    if inspect.isfunction(rule):
        name, target, fn = rule.__name__, rule, rule
        what = f"inspect.getsource({rule.__qualname__})"
    elif callable(getattr(rule, "aggregate", None)):
        cls = type(rule)
        name = getattr(rule, "name", None) or cls.__name__
        target, fn = cls, rule.aggregate
        what = f"inspect.getsource({cls.__qualname__})"
    else:
        raise SwarmflError(
            "rule= takes a function aggregate(models, f, current, samples) or a swarmfl.Rule "
            f"instance, got {type(rule).__name__}")
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        raise SwarmflError(
            f"plug-in rule name {name!r}: use 1 to 100 of A-Z a-z 0-9 _ - . (name the function, "
            "or set the class's name attribute)")
    try:
        source = inspect.getsource(target)
    except (OSError, TypeError) as e:
        if isinstance(target, type):
            try:
                parts = [inspect.getsource(v) for _, v in sorted(vars(target).items())
                         if inspect.isfunction(v)]
            except (OSError, TypeError):
                parts = []
            if parts:
                return name, f"inspect.getsource of {target.__qualname__}'s methods", \
                    "".join(parts), fn
        raise SwarmflError(
            f"plug-in rule `{name}`: cannot read its source ({e}); the run records its digest: "
            "define it in a file or a notebook cell") from None
    return name, what, source, fn


def rule_adapter(name: str, fn: Callable) -> Callable:
    """The callable the core asks: builds the arrays, calls the rule and checks its answer,
    raising :class:`PluginError` with the rule's name."""

    def fail(n: int, what: str, detail: str = "") -> PluginError:
        return PluginError(f"plug-in rule `{name}` {what} (aggregating {n} models){detail}")

    def call(current: bytes, models: bytes, n: int, samples: list, f: int) -> bytes:
        cur = np.frombuffer(current, dtype="<i8")
        mods = np.frombuffer(models, dtype="<i8").reshape(n, cur.size)
        claims = np.array(samples, dtype=np.int64)
        try:
            answer = fn(mods, f, cur, claims)
        except Exception as e:  # the plug-in's own error, whatever it is
            tb = "".join(traceback.format_exception(type(e), e, e.__traceback__))
            raise fail(n, f"raised {type(e).__name__}: {e}", f"\n{tb}") from e
        a = np.asarray(answer)
        if a.dtype.kind not in "iu":
            raise fail(n, f"returned dtype {a.dtype} (shape {a.shape}); return integers: the "
                          "models are fixed point (round where the rule divides)")
        if a.ndim != 1 or a.size != cur.size:
            raise fail(n, f"returned shape {a.shape}; the model has {cur.size} weights "
                          f"(shape ({cur.size},))")
        big = np.flatnonzero(np.abs(a.astype(object)) >= 2**47)
        if big.size:
            raise fail(n, f"returned weight {big[0]} = {a[big[0]]}, beyond int48 (|w| < 2^47)")
        return a.astype("<i8").tobytes()

    return call


def rule_arg(rule: Any) -> Optional[tuple]:
    """What the extension takes for ``rule=``: ``(name, what, source, adapter)``."""
    if rule is None:
        return None
    name, what, source, fn = describe_rule(rule)
    return name, what, source, rule_adapter(name, fn)
