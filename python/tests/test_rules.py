"""Plug-in aggregation rules written in Python (`swarmfl.run(rule=...)`, `contract.rule =
"plugin"`): a numpy coordinate-wise median reproduces the built-in median's records exactly,
the rule's name and source digest are recorded (so only the run's identity differs), a log
whose rule is absent or changed is refused by name, and a rule that raises or answers badly
raises swarmfl.PluginError without crashing the interpreter."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import swarmfl

REPO = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("SWARMFL_BIN", REPO / "target" / "release" / "swarmfl"))

# A short smoke run with an attacker the median must resist, f = 1.
SET = {"run.duration_s": 200.0, "byzantine.count": 2, "byzantine.kind": "sign-flip",
       "byzantine.scale": 2.0, "contract.assumed_f": 1}


def np_median(models, f, current, samples):
    """The built-in median (contract/rules/median.rs) in numpy: the middle value per weight,
    for an even count the mean of the two middle values rounded half away from zero."""
    s = np.sort(models, axis=0)
    n = s.shape[0]
    if n % 2:
        return s[n // 2]
    total = s[n // 2 - 1] + s[n // 2]
    return np.sign(total) * ((np.abs(total) + 1) // 2)


@pytest.fixture(scope="module")
def medians(tmp_path_factory):
    """The same run with the built-in median and with np_median."""
    out = tmp_path_factory.mktemp("rules")
    builtin = swarmfl.run(preset="smoke", seed=7, out=out / "builtin",
                          set={**SET, "contract.rule": "median"})
    plugin = swarmfl.run(preset="smoke", seed=7, out=out / "plugin", set=SET, rule=np_median)
    return builtin, plugin


def test_a_python_median_reproduces_the_builtin_median(medians):
    builtin, plugin = medians
    assert len(builtin.rounds) > 3, "several rounds aggregated"
    for table in ["rounds", "submissions", "balances"]:
        a, b = getattr(builtin, table), getattr(plugin, table)
        assert len(a) == len(b) > 0
        assert list(a.columns) == list(b.columns)
        for name in a.columns:
            np.testing.assert_array_equal(a[name].to_numpy(), b[name].to_numpy(),
                                          err_msg=f"{table}.{name}")
    last = builtin.index.last_height
    a, b = builtin.at(block=last), plugin.at(block=last)
    assert a.contract.model_digest == b.contract.model_digest
    assert a.contract.round == b.contract.round and a.contract.round > 3
    # Only the recorded rule identity (the config's rule, the params' digest) differs.
    assert plugin.summary["final_hash"] != builtin.summary["final_hash"]


def test_the_rule_is_recorded_and_a_fresh_open_needs_it(medians, tmp_path):
    _, plugin = medians
    text = plugin.index.config_toml
    assert 'rule = "plugin"' in text and 'rule_plugin = "np_median"' in text
    again = swarmfl.open(plugin.path, rule=np_median)
    np.testing.assert_array_equal(again.rounds["loss"].to_numpy(), plugin.rounds["loss"].to_numpy())


def test_replay_and_fork_need_the_same_rule(medians, tmp_path):
    _, plugin = medians
    ok = swarmfl.replay(plugin.log, resimulate=True, rule=np_median)
    assert ok["final_hash"] == plugin.summary["final_hash"]
    assert swarmfl.replay(plugin.log, rule=np_median)["checkpoints"] > 0
    with pytest.raises(swarmfl.SwarmflError, match=r"plug-in rule `np_median` \(blake3 [0-9a-f]{64} of inspect.getsource\(np_median\)\), which is not given"):
        swarmfl.replay(plugin.log, resimulate=True)

    def np_median_changed(models, f, current, samples):
        return np.median(models, axis=0).round().astype(np.int64)
    np_median_changed.__name__ = "np_median"

    with pytest.raises(swarmfl.SwarmflError, match=r"plug-in rule `np_median` changed: the log records blake3 [0-9a-f]{64} of inspect.getsource\(np_median\), the given one has [0-9a-f]{64}"):
        swarmfl.replay(plugin.log, resimulate=True, rule=np_median_changed)
    with pytest.raises(swarmfl.SwarmflError, match=r"plug-in rule `np_median` changed"):
        swarmfl.replay(plugin.log, rule=np_median_changed)
    with pytest.raises(swarmfl.SwarmflError, match=r"plug-in rule `np_median` changed"):
        swarmfl.open(plugin.path, rule=np_median_changed).rounds
    with pytest.raises(swarmfl.SwarmflError, match=r"plug-in rule `np_median` changed"):
        swarmfl.fork(plugin.log, at=3, set={"learn.learning_rate": 0.02}, rule=np_median_changed)
    fork = swarmfl.fork(plugin.log, at=3, set={"learn.learning_rate": 0.02}, out=tmp_path / "fork",
                        rule=np_median)
    assert fork.summary["final_hash"] == swarmfl.replay(fork.log, resimulate=True, rule=np_median)["final_hash"]


def test_the_command_refuses_a_plugin_rule_by_name(medians, tmp_path):
    _, plugin = medians
    for args in (["replay", plugin.log, "--resimulate"],
                 ["inspect", "--block", "3", plugin.log],
                 ["run", "--preset", "smoke", "--set", "contract.rule=plugin", "--set",
                  "contract.rule_plugin=x", "--out", tmp_path / "r"]):
        p = subprocess.run([str(BIN), *map(str, args)], capture_output=True, text=True)
        assert p.returncode != 0, args
        assert "cannot run plug-ins" in p.stderr, p.stderr
        assert "panicked" not in p.stderr and "diverged" not in p.stderr, p.stderr


def test_a_rule_log_is_drawn_from_python_with_its_rule(medians, tmp_path):
    builtin, plugin = medians
    # The command cannot run the rule, which the contract's tokens and rounds need: its page
    # holds the world (records) and a note saying where the rest is drawn; a block's picture
    # is refused, naming the same call. Its world is records: the command draws it at a time.
    p = subprocess.run([str(BIN), "view", str(plugin.log), "--out", str(tmp_path / "c.html")],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert "swarmfl.open(LOG, rule=...).view(OUT)" in p.stdout, p.stdout
    assert "swarmfl.open(LOG, rule=...).view(OUT)" in (tmp_path / "c.html").read_text()
    p = subprocess.run([str(BIN), "snapshot", str(plugin.log), "--block", "3", "--out",
                        str(tmp_path / "c3.svg")], capture_output=True, text=True)
    assert p.returncode != 0
    assert "swarmfl.open(..., rule=...).view(OUT)" in p.stderr, p.stderr
    assert "cannot run plug-ins" in p.stderr and "panicked" not in p.stderr, p.stderr
    p = subprocess.run([str(BIN), "snapshot", str(plugin.log), "--time", "30", "--out",
                        str(tmp_path / "c.svg")], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    # From Python with the rule: the page and the picture, as the built-in median's run draws
    # them (the same records but for the rule's identity).
    run = swarmfl.open(plugin.path, rule=np_median)
    page = run.view(tmp_path / "p.html")
    assert page.stat().st_size > 0
    svg = run.snapshot(tmp_path / "p.svg", block=3)
    base = builtin.snapshot(tmp_path / "b.svg", block=3)
    assert svg.read_text().replace(str(plugin.path), "") == base.read_text().replace(str(builtin.path), "")
    at30 = run.snapshot(tmp_path / "p30.svg", time_s=30)
    assert at30.read_bytes() == (tmp_path / "c.svg").read_bytes()


def boom(models, f, current, samples):
    raise ZeroDivisionError("the rule divided by zero")


def short(models, f, current, samples):
    return current[:-1]


def floats(models, f, current, samples):
    return np.median(models, axis=0)


def huge(models, f, current, samples):
    return np.full(current.size, 2**47, dtype=np.int64)


@pytest.mark.parametrize("rule, message", [
    (boom, r"(?s)plug-in rule `boom` raised ZeroDivisionError: the rule divided by zero \(aggregating \d+ models\)\nTraceback.*in boom"),
    (short, r"plug-in rule `short` returned shape \(\d+,\); the model has \d+ weights"),
    (floats, r"plug-in rule `floats` returned dtype float64"),
    (huge, r"plug-in rule `huge` returned weight 0 = 140737488355328, beyond int48"),
])
def test_a_bad_rule_raises_plugin_error_naming_it(tmp_path, rule, message):
    with pytest.raises(swarmfl.PluginError, match=message) as e:
        swarmfl.run(preset="smoke", seed=7, out=tmp_path / "bad", set=SET, rule=rule)
    if rule is boom:
        assert isinstance(e.value.__cause__, ZeroDivisionError)


def test_what_is_not_a_rule_is_refused_before_running(tmp_path):
    with pytest.raises(swarmfl.SwarmflError, match="got the class"):
        swarmfl.run(preset="smoke", set=SET, rule=swarmfl.Rule, out=tmp_path / "a")
    with pytest.raises(swarmfl.SwarmflError, match=r"rule= takes a function"):
        swarmfl.run(preset="smoke", set=SET, rule=42, out=tmp_path / "b")
    with pytest.raises(swarmfl.SwarmflError, match="set= has contract.rule"):
        swarmfl.run(preset="smoke", set={**SET, "contract.rule": "krum"}, rule=np_median,
                    out=tmp_path / "c")
    with pytest.raises(swarmfl.SwarmflError, match="contract.rule_plugin"):
        swarmfl.run(preset="smoke", set={**SET, "contract.rule_plugin": "x"}, out=tmp_path / "d")
    with pytest.raises(swarmfl.SwarmflError, match="contract.preaggregators"):
        swarmfl.run(preset="smoke", set={**SET, "contract.preaggregators": ["clip"]},
                    rule=np_median, out=tmp_path / "e")


def test_the_custom_rule_example_runs(tmp_path):
    script = REPO / "examples" / "python" / "custom_rule.py"
    p = subprocess.run([sys.executable, str(script), str(tmp_path / "ex")], capture_output=True,
                       text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert "same records as the built-in median: True" in p.stdout
