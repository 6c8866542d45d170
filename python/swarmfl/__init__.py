"""swarmfl from Python: run simulations, open their logs and load their tables as pandas
DataFrames.

    >>> import swarmfl
    >>> r = swarmfl.run(preset="smoke", seed=7)
    >>> r.rounds.head()

Everything is computed by the Rust core that the ``swarmfl`` command uses (the extension
module ``swarmfl._swarmfl``): a run made here writes the same ``run.swlog`` and
``summary.json`` as ``swarmfl run``, and every table is the one ``swarmfl export`` writes,
handed over column by column (no Python loop over records). Errors raise
:class:`SwarmflError` with the command's message. See docs/PYTHON.md.
"""

from __future__ import annotations

import json
import os
import re
import sys
import tempfile
from pathlib import Path
from types import SimpleNamespace
from typing import Any, Mapping, Optional, Sequence, Union

import numpy as np
import pandas as pd

from . import _swarmfl
from ._swarmfl import SwarmflError
from .plugins import Attack, AttackView, PluginError, Rule, plugin_arg, rule_arg

__all__ = ["run", "open", "Run", "SwarmflError", "config", "sweep", "results", "report",
           "replay", "fork", "Attack", "AttackView", "PluginError", "Rule"]

PathLike = Union[str, "os.PathLike[str]"]


def _frame(columns) -> pd.DataFrame:
    """A DataFrame from the extension's ``[(name, dtype, data)]`` columns."""
    data = {}
    for name, dtype, payload in columns:
        if dtype == "str":
            data[name] = pd.Series(payload, dtype="object")
        else:
            data[name] = np.frombuffer(payload, dtype=np.dtype(dtype)).copy()
    return pd.DataFrame(data)


def _toml_value(value: Any) -> str:
    """A Python value as the TOML text ``--set key=value`` takes."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise SwarmflError(
        f"cannot set a value of type {type(value).__name__} ({value!r}): "
        "use a bool, int, float, str or a list of them"
    )


def _overrides(set: Optional[Mapping[str, Any]]) -> list:
    if set is None:
        return []
    if not isinstance(set, Mapping):
        raise SwarmflError(
            f"set= takes a mapping of key to value, e.g. set={{'world.robots': 30}}, got {type(set).__name__}"
        )
    return [f"{key}={_toml_value(value)}" for key, value in set.items()]


def config(preset: Optional[str] = None, set: Optional[Mapping[str, Any]] = None,
           config: Optional[PathLike] = None) -> str:
    """The resolved configuration (TOML text) of a preset, a file and overrides, as
    ``swarmfl config`` prints it; raises :class:`SwarmflError` on a bad key or value."""
    return _swarmfl.config_toml(preset, None if config is None else os.fspath(config), _overrides(set))


def _with_plugin(overrides: list, plugin: Optional[tuple], kind_key: str, name_key: str,
                 arg: str, what: str) -> list:
    """The overrides plus ``KIND_KEY = "plugin"`` and ``NAME_KEY = NAME`` for a plug-in passed
    as ``ARG=`` (a ``set=`` that gives KIND_KEY another value is an error)."""
    if plugin is None:
        return overrides
    for o in overrides:
        key, _, value = o.partition("=")
        if key.strip() == kind_key and value.strip().strip('"') != "plugin":
            raise SwarmflError(
                f"{arg}= runs a plug-in {what} ({kind_key} = \"plugin\"), but set= has {o}: "
                "drop one of them")
    return overrides + [f'{kind_key}="plugin"', f"{name_key}={_toml_value(plugin[0])}"]


def _with_attack(overrides: list, plugin: Optional[tuple]) -> list:
    """The overrides for a plug-in attack: ``byzantine.kind = "plugin"``, ``byzantine.plugin``."""
    return _with_plugin(overrides, plugin, "byzantine.kind", "byzantine.plugin", "attack", "attack")


def _with_rule(overrides: list, plugin: Optional[tuple]) -> list:
    """The overrides for a plug-in rule: ``contract.rule = "plugin"``, ``contract.rule_plugin``."""
    return _with_plugin(overrides, plugin, "contract.rule", "contract.rule_plugin", "rule", "rule")


def run(preset: Optional[str] = None, seed: int = 1, set: Optional[Mapping[str, Any]] = None,
        out: Optional[PathLike] = None, config: Optional[PathLike] = None,
        quiet: bool = True, attack: Optional[Attack] = None, rule: Any = None) -> "Run":
    """Simulates a run, as ``swarmfl run --preset PRESET --seed SEED --set K=V ... --out OUT``.

    ``set`` maps configuration keys to values (``{"byzantine.count": 3, "contract.rule":
    "median"}``); ``config`` names a TOML file overlaid on the preset. Without ``out`` the run
    goes into a new temporary directory (kept: its path is ``Run.path``). ``quiet=False`` prints
    progress lines on stderr, as the command does off a terminal. Ctrl-C stops the simulation at its next record
    and raises ``KeyboardInterrupt`` (``out`` then holds a truncated log and no summary).
    ``attack`` is a plug-in attack (a :class:`swarmfl.Attack` instance) that the Byzantine
    robots run (``byzantine.count`` of them: set it); a plug-in that raises or answers badly
    raises :class:`PluginError` naming the round and robot. ``rule`` is a plug-in aggregation
    rule (a function ``aggregate(models, f, current, samples)`` or a :class:`swarmfl.Rule`
    instance, see :mod:`swarmfl.plugins`) that the contract runs (``contract.rule =
    "plugin"``); one that raises or answers badly raises :class:`PluginError` naming it.
    Returns the :class:`Run`.
    """
    if preset is None and config is None:
        preset = "paper"
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise SwarmflError(f"seed must be a non-negative integer, got {seed!r}")
    if out is None:
        out = tempfile.mkdtemp(prefix=f"swarmfl-{preset or 'run'}-seed{seed}-")
    plugin = plugin_arg(attack)
    rplugin = rule_arg(rule)
    overrides = _with_rule(_with_attack(_overrides(set), plugin), rplugin)
    summary = _swarmfl.run(preset, None if config is None else os.fspath(config), overrides,
                           seed, os.fspath(out), quiet, plugin, rplugin)
    r = Run(Path(out) / "run.swlog", rule=rule)
    r._summary = json.loads(summary)
    return r


def _log_path(path: PathLike) -> Path:
    p = Path(path)
    if p.is_dir():
        p = p / "run.swlog"
    if not p.exists():
        raise SwarmflError(f"cannot open {p}: no such file (give a run directory or its run.swlog)")
    return p


def replay(log: PathLike, resimulate: bool = False, attack: Optional[Attack] = None,
           rule: Any = None) -> dict:
    """Replays a log (``swarmfl replay [--resimulate]``): folds its events and checks every
    checkpoint, or re-simulates the run and compares every record. A log made with a plug-in
    attack needs it (``attack=``), with the source its header records: otherwise this raises
    :class:`SwarmflError` naming the plug-in and both digests; so does a log made with a plug-in
    rule without it (``rule=``), or with a changed one. Returns ``records``,
    ``checkpoints``, ``blocks`` and ``final_hash``; a difference raises :class:`SwarmflError`."""
    records, checkpoints, blocks, final_hash = _swarmfl.replay(
        os.fspath(_log_path(log)), bool(resimulate), plugin_arg(attack), rule_arg(rule))
    return {"records": records, "checkpoints": checkpoints, "blocks": blocks,
            "final_hash": final_hash}


def fork(log: PathLike, at: int, set: Optional[Mapping[str, Any]] = None,
         out: Optional[PathLike] = None, quiet: bool = True,
         attack: Optional[Attack] = None, rule: Any = None) -> "Run":
    """Forks a chain run at block ``at`` with the overrides ``set`` (``swarmfl fork LOG --at H
    --set K=V``): re-simulates the parent up to the fork point, checking every record, then
    continues under the new configuration. ``attack`` is the parent's plug-in attack (required,
    with the same source, when the parent has one) or one the overrides switch to; ``rule`` the
    parent's plug-in rule (required, with the same source, when the parent has one).
    ``quiet=False`` prints the fork point and progress lines on stderr. Returns the fork's
    :class:`Run` (in ``out``, default a new temporary directory; its summary is
    ``Run.summary``)."""
    if not isinstance(at, int) or isinstance(at, bool) or at < 0:
        raise SwarmflError(f"at must be a non-negative block height, got {at!r}")
    parent = _log_path(log)
    if out is None:
        out = tempfile.mkdtemp(prefix=f"swarmfl-fork-at-{at}-")
    plugin = plugin_arg(attack)
    overrides = _overrides(set)
    if plugin is not None and any(o.partition("=")[0].strip() == "byzantine.kind" for o in overrides):
        overrides = _with_attack(overrides, plugin)
    rplugin = rule_arg(rule)
    if rplugin is not None and any(o.partition("=")[0].strip() == "contract.rule" for o in overrides):
        overrides = _with_rule(overrides, rplugin)
    _swarmfl.fork(os.fspath(parent), at, overrides, os.fspath(out), quiet, plugin, rplugin)
    return Run(Path(out) / "run.swlog", rule=rule)


def _grid_value(value: Any) -> str:
    """A grid value as ``--grid`` text: a plain word stays bare (``median``, so that the
    point's directory reads ``contract.rule=median``), anything else is TOML."""
    if isinstance(value, str) and re.fullmatch(r"[A-Za-z0-9_.+-]+", value):
        return value
    return _toml_value(value)


def _grid(grid: Optional[Mapping[str, Any]]) -> list:
    if grid is None:
        return []
    if not isinstance(grid, Mapping):
        raise SwarmflError(
            "grid= takes a mapping of key to a list of values, e.g. "
            f"grid={{'contract.rule': ['median', 'krum']}}, got {type(grid).__name__}"
        )
    if len(grid) == 0:
        raise SwarmflError(
            f"grid= is empty, so there is nothing to sweep: give each key a list of values, "
            f"e.g. {_GRID_EXAMPLE}")
    axes = []
    for key, values in grid.items():
        if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
            values = [values]
        values = list(values)
        if not values:
            raise SwarmflError(
                f"grid[{key!r}] is an empty list: give it at least one value, e.g. "
                f"grid={{{key!r}: [...]}}, or leave the key out")
        axes.append(f"{key}=" + ",".join(_grid_value(v) for v in values))
    return axes


_GRID_EXAMPLE = ("swarmfl.sweep(grid={'contract.rule': ['median', 'krum'], "
                 "'byzantine.count': [1, 3]}, preset='smoke')")


def _check_sweep_arguments(experiment: Optional[str], grid: Optional[Mapping[str, Any]],
                           preset: Optional[str]) -> None:
    """The sweep's choice of experiment or grid, told in this function's arguments (the
    command's own messages name --grid and --preset)."""
    if experiment is not None and grid is not None:
        raise SwarmflError(
            f"give either experiment= ({experiment!r}) or grid=, not both: a grid runs on "
            "preset= (default 'paper'), an experiment on its own preset")
    if experiment is not None and preset is not None:
        raise SwarmflError(
            f"preset={preset!r}: the experiment {experiment!r} has its own preset; preset= is "
            "for a grid= sweep")
    if experiment is None and grid is None:
        raise SwarmflError(
            "nothing to sweep: name an experiment (e.g. swarmfl.sweep('e2-faulty'); "
            f"`swarmfl sweep --help` lists them) or give grid=, e.g. {_GRID_EXAMPLE}")


class _Progress:
    """The sweep's progress: a tqdm bar (``tqdm.auto``: a widget in a notebook, a bar on a
    terminal) if tqdm is installed, else one line rewritten on a terminal and one line per
    task elsewhere (a notebook's output cell)."""

    def __init__(self, enabled: bool, label: str):
        self.enabled = enabled
        self.label = label
        self.bar = None
        self.tty = hasattr(sys.stderr, "isatty") and sys.stderr.isatty()

    def __call__(self, done: int, total: int, line: str, error: Optional[str]) -> None:
        if not self.enabled:
            return
        if self.bar is None:
            try:
                from tqdm.auto import tqdm
                self.bar = tqdm(total=total, desc=self.label, unit="task")
            except ImportError:
                self.bar = False
        if self.bar:
            self.bar.update(done - self.bar.n)
            self.bar.set_postfix_str(line.split("] ", 1)[-1], refresh=True)
            if error is not None:
                self.bar.write(line)
        elif self.tty:
            end = "\n" if done == total or error is not None else ""
            print(f"\r{self.label}: {line}\x1b[K", end=end, file=sys.stderr, flush=True)
        else:
            print(f"{self.label}: {line}", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.bar:
            self.bar.close()


def sweep(experiment: Optional[str] = None, *, grid: Optional[Mapping[str, Any]] = None,
          preset: Optional[str] = None, seeds: Optional[int] = None,
          set: Optional[Mapping[str, Any]] = None, out: Optional[PathLike] = None,
          jobs: Optional[int] = None, shard: Optional[str] = None, keep_logs: bool = False,
          progress: bool = True) -> pd.DataFrame:
    """Runs a sweep, as ``swarmfl sweep``, and returns its results as one tidy frame
    (:func:`results`).

    Either a built-in ``experiment`` (``"e2-faulty"``; its preset and grid) or a ``grid``: a
    mapping of configuration keys to lists of values (``{"contract.rule": ["median", "krum"],
    "byzantine.count": [1, 3]}``), every combination a point, on ``preset`` (default
    ``paper``). ``seeds`` runs seeds 1..N per point (default: the experiment's, 1 for a grid);
    ``set`` fixes other keys for every task; ``shard="I/N"`` runs a share. Results go to
    ``out`` (default a new temporary directory); tasks already there are skipped, so the same
    call resumes an interrupted sweep. Every configuration is resolved before any run: a bad
    key or value raises :class:`SwarmflError` naming it. ``progress`` shows a bar (tqdm if
    installed, else plain lines). Ctrl-C stops the sweep (the runs under way stop without a
    result file; calling again redoes them) and raises ``KeyboardInterrupt``; a failed task raises :class:`SwarmflError` after the others
    ran. The frame's ``attrs["sweep"]`` holds the counts and the wall time.
    """
    if seeds is not None and (not isinstance(seeds, int) or isinstance(seeds, bool) or seeds < 1):
        raise SwarmflError(f"seeds must be a positive integer, got {seeds!r}")
    _check_sweep_arguments(experiment, grid, preset)
    axes = _grid(grid)
    if out is None:
        out = tempfile.mkdtemp(prefix="swarmfl-sweep-")
    label = experiment or f"grid-{preset or 'paper'}"
    bar = _Progress(progress, f"sweep {label}")
    try:
        selected, ran, skipped, failed, wall_s = _swarmfl.sweep(
            experiment, preset, axes, _overrides(set), seeds, jobs, shard, os.fspath(out),
            keep_logs, bar)
    finally:
        bar.close()
    if failed:
        lines = "\n".join(f"  {point} seed {seed}: {error}" for point, seed, error in failed)
        raise SwarmflError(
            f"{len(failed)} tasks failed; call again to retry them (the others are in {out}):\n{lines}")
    frame = results(out)
    frame.attrs["sweep"] = {"out": os.fspath(out), "selected": selected, "ran": ran,
                            "skipped": skipped, "wall_s": wall_s}
    return frame


def results(dir: PathLike) -> pd.DataFrame:
    """A sweep's results directory as one tidy frame, one row per run: ``experiment, point,
    seed, x``, every override as a column of its own (``contract.rule``, ``byzantine.count``,
    ... typed: integers, floats, booleans or text), ``duration_s`` (simulated), the metrics
    ``swarmfl report`` averages (``rounds``, ``final_loss``, ``final_heldout_loss``,
    ``honest_gain``, ``byzantine_gain``, ``chain_mb``, ...; NaN where a run has none), ``wall_s``,
    ``final_hash`` and ``config_hash``. Built by the core's report loader: it refuses what
    ``swarmfl report`` refuses (damaged files, a point mixing configurations)."""
    return _frame(_swarmfl.results(os.fspath(dir)))


def report(dir: PathLike, out: PathLike) -> Path:
    """Writes the report of a results directory (``swarmfl report DIR --out OUT``): figures,
    report.md, numbers.csv. Returns the path of report.md."""
    return Path(_swarmfl.report(os.fspath(dir), os.fspath(out)))


def open(path: PathLike, rule: Any = None) -> "Run":
    """Opens an existing run: its directory (holding ``run.swlog``) or the log itself. A run
    made with a plug-in rule needs it (``rule=``, the same source): its tables re-execute the
    contract."""
    p = Path(path)
    if p.is_dir():
        p = p / "run.swlog"
    if not p.exists():
        raise SwarmflError(f"cannot open {p}: no such file (give a run directory or its run.swlog)")
    return Run(p, rule=rule)


def _namespace(value: Any) -> Any:
    """JSON values as attribute-access objects (lists stay lists)."""
    if isinstance(value, dict):
        return SimpleNamespace(**{k: _namespace(v) for k, v in value.items()})
    if isinstance(value, list):
        return [_namespace(v) for v in value]
    return value


class Run:
    """A run's log and what is computed from it. Tables are computed on first use, from one
    fold of the log (checking every checkpoint), and cached."""

    def __init__(self, log: PathLike, rule: Any = None):
        self.log = Path(log)
        self._rule = rule
        self.path = self.log.parent
        self._summary: Optional[dict] = None
        self._index = None
        self._cache: dict = {}

    def __repr__(self) -> str:
        return f"swarmfl.Run({str(self.log)!r})"

    @property
    def index(self):
        if self._index is None:
            self._index = _swarmfl.Index(os.fspath(self.log), rule_arg(self._rule))
        return self._index

    def _offer_rule(self) -> None:
        """Registers the run's plug-in rule (if any) for the folds that take no ``rule``: the
        index's fold registers it and refuses a changed one by name."""
        if self._rule is not None:
            self.index

    @property
    def aggregation(self) -> str:
        """``chain``, ``gossip`` or ``central``."""
        return self.index.aggregation

    @property
    def summary(self) -> dict:
        """``summary.json`` as a dict (the run's directory must hold it)."""
        if self._summary is None:
            p = self.path / "summary.json"
            if not p.exists():
                raise SwarmflError(f"cannot read {p}: no such file (re-make it with swarmfl run)")
            self._summary = json.loads(p.read_text())
        return self._summary

    @property
    def summary_frame(self) -> pd.DataFrame:
        """The summary flattened into one row (nested keys joined by dots)."""
        return pd.json_normalize(self.summary)

    def _table(self, name: str) -> pd.DataFrame:
        if name not in self._cache:
            self._cache[name] = _frame(getattr(self.index, name)())
        return self._cache[name].copy()

    @property
    def rounds(self) -> pd.DataFrame:
        """Every aggregation: a chain run's closed rounds (round, block, time_s, loss,
        heldout_loss, accepted, outliers, mean_honest_distance); a gossip or central run's
        aggregations (round, time_s, robot (-1 = the server), models, loss, heldout_loss)."""
        return self._table("rounds")

    @property
    def submissions(self) -> pd.DataFrame:
        """Per counted submission of every closed round (chain runs): round, block, robot,
        byzantine, outcome, distance (mean absolute distance per weight, model units),
        samples (claimed), stake_tokens, reward_tokens."""
        return self._table("submissions")

    @property
    def balances(self) -> pd.DataFrame:
        """Every robot's balance after every block (chain runs): block, time_s, robot,
        balance_tokens, byzantine."""
        return self._table("balances")

    @property
    def outcomes(self) -> pd.DataFrame:
        """Every model submission on the final canonical chain with the contract's verdict,
        refused ones included (``submissions`` holds only those a round counted): block,
        time_s, robot, byzantine, samples (claimed), outcome (``accepted``, ``aggregated``,
        ``outlier``, ``duplicate``, ``insufficient_stake``, ``malformed``, ...) and reason (why
        a ``malformed`` or refused call was refused, else empty)."""
        return self._table("outcomes")

    @property
    def chain_bytes(self) -> pd.DataFrame:
        """Every node's canonical chain size at every sealing (chain runs)."""
        return self._table("chain_bytes")

    @property
    def trajectories(self) -> pd.DataFrame:
        """The samples of every robot's final data set, one row per waypoint."""
        return self._table("trajectories")

    def poses(self, every_s: float = 1.0) -> pd.DataFrame:
        """Every robot's pose (time_s, robot, x, y, theta) every ``every_s`` simulated seconds."""
        self._offer_rule()
        key = ("poses", float(every_s))
        if key not in self._cache:
            self._cache[key] = _frame(_swarmfl.poses(os.fspath(self.log), float(every_s)))
        return self._cache[key].copy()

    def at(self, block: Optional[int] = None, time_s: Optional[float] = None):
        """The state right after ``block`` of the final canonical chain (a chain run), or at
        the last checkpoint at or before ``time_s`` (a baseline run), as attribute objects
        (``.to_dict`` is not needed: ``vars()`` works; the raw dict is ``.raw``)."""
        if (block is None) == (time_s is None):
            raise SwarmflError("give exactly one of block= (a chain run) or time_s= (a baseline run)")
        self._offer_rule()
        if block is not None:
            if not isinstance(block, int) or isinstance(block, bool) or block < 0:
                raise SwarmflError(f"block must be a non-negative integer, got {block!r}")
            raw = json.loads(_swarmfl.at_block(os.fspath(self.log), block))
        else:
            raw = json.loads(_swarmfl.at_time(os.fspath(self.log), float(time_s)))
        ns = _namespace(raw)
        ns.raw = raw
        return ns

    def bisect(self, expr: str, monotone: bool = False):
        """The first block where the predicate ``expr`` holds (``swarmfl bisect``'s language,
        e.g. ``"round >= 5"``), or None; for a baseline run, the first checkpoint's time (s).
        The leaf values that made it true are in ``Run.last_bisect``."""
        if self.aggregation == "chain":
            hit = self.index.bisect(expr, monotone)
            if hit is None:
                self.last_bisect = None
                return None
            height, time_s, leaves = hit
            self.last_bisect = {"block": height, "time_s": time_s, "values": dict(leaves)}
            return height
        hit = _swarmfl.bisect_by_time(os.fspath(self.log), expr, monotone)
        if hit is None:
            self.last_bisect = None
            return None
        time_s, leaves = hit
        self.last_bisect = {"time_s": time_s, "values": dict(leaves)}
        return time_s

    def blame(self, outcome: str = "heldout_loss", until: Optional[str] = None,
              block: Optional[int] = None, robots: Optional[Sequence[int]] = None,
              as_honest: bool = True, quiet: bool = True) -> pd.DataFrame:
        """Each robot's influence on ``outcome`` (``swarmfl blame``): the outcome (an
        expression over ``bisect``'s identifiers) read at the end of the run, at ``block`` or at
        the first block where ``until`` holds, minus the outcome of the exact re-simulation in
        which the robot never submits. One row per robot, largest influence first: robot,
        influence, byzantine, without, influence_as_honest (Byzantine robots), submissions,
        accepted_rounds, outlier_rounds, first_report_s. The outcome, its block and the costs
        are in ``frame.attrs``."""
        raw = json.loads(_swarmfl.blame(os.fspath(self.log), outcome, until, block,
                                        None if robots is None else [int(r) for r in robots],
                                        as_honest, quiet))
        frame = pd.DataFrame(raw.pop("robots"))
        frame.attrs.update(raw)
        return frame

    def contributions(self, outcome: str = "heldout_loss", until: Optional[str] = None,
                      block: Optional[int] = None, samples: int = 0, seed: int = 1,
                      quiet: bool = True) -> pd.DataFrame:
        """Whole-run contributions (``swarmfl contributions``): per robot its leave-one-out and,
        with ``samples`` > 0, its Shapley value over ``samples`` orders drawn with ``seed`` and
        the standard error (shapley_se). Positive values make the outcome larger. The outcome,
        the outcome with no robot submitting (``nobody``) and the costs are in
        ``frame.attrs``."""
        raw = json.loads(_swarmfl.contributions(os.fspath(self.log), outcome, until, block,
                                                int(samples), int(seed), quiet))
        frame = pd.DataFrame(raw.pop("robots"))
        frame.attrs.update(raw)
        return frame

    def view(self, out: PathLike) -> Path:
        """Writes the run's viewer, one self-contained HTML file, into ``out`` (as ``swarmfl
        view LOG --out OUT``) and returns its path. A run with a plug-in rule is drawn with the
        rule this ``Run`` was given (the command cannot run it)."""
        self._offer_rule()
        _swarmfl.view(os.fspath(self.log), os.fspath(out))
        return Path(out)

    def snapshot(self, out: PathLike, time_s: Optional[float] = None,
                 block: Optional[int] = None) -> Path:
        """Draws the world at ``time_s`` simulated seconds or right after ``block`` of the
        final canonical chain (exactly one) into ``out``, SVG or PNG by its extension (as
        ``swarmfl snapshot LOG --time T --out OUT``), and returns its path."""
        if (block is None) == (time_s is None):
            raise SwarmflError("give exactly one of time_s= (simulated seconds) or block= (a "
                               "height of the final canonical chain)")
        if block is not None and (not isinstance(block, int) or isinstance(block, bool)
                                  or block < 0):
            raise SwarmflError(f"block must be a non-negative integer, got {block!r}")
        if time_s is not None and not (isinstance(time_s, (int, float)) and 0 <= time_s < float("inf")):
            raise SwarmflError(f"time_s must be a non-negative number of seconds, got {time_s!r}")
        self._offer_rule()
        _swarmfl.snapshot(os.fspath(self.log), os.fspath(out),
                          None if time_s is None else float(time_s), block)
        return Path(out)

    def export(self, out: PathLike) -> None:
        """Writes the CSV tables into ``out``, as ``swarmfl export``."""
        _swarmfl.export(os.fspath(self.log), os.fspath(out))
