"""Plug-in attacks written in Python (`swarmfl.Attack`): they run through the core's attack
interface, reproduce a built-in attack's records exactly, are recorded in the log header (name
and source digest), are refused when absent or changed, and every bad answer raises a Python
exception naming the plug-in, the round and the robot."""

import os
import runpy
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import swarmfl

REPO = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("SWARMFL_BIN", REPO / "target" / "release" / "swarmfl"))

# A short smoke run with three Byzantine robots: enough for several attacked rounds.
SET = {"run.duration_s": 200.0, "byzantine.count": 3, "byzantine.scale": 2.0}


class PySignFlip(swarmfl.Attack):
    """The built-in sign-flip, in numpy: w(t) - scale (w(t) - w(t-1)) in float64, rounded once
    to float32 (byzantine/sign_flip.rs)."""

    name = "py-sign-flip"

    def act(self, view):
        if view.previous is None:
            return view.shared, view.claimed_samples
        w = view.shared.astype(np.float64)
        p = view.previous.astype(np.float64)
        return (w - view.config["scale"] * (w - p)).astype(np.float32), view.claimed_samples


@pytest.fixture(scope="module")
def signflip(tmp_path_factory):
    """The same run with the built-in sign-flip and with PySignFlip."""
    out = tmp_path_factory.mktemp("plugins")
    builtin = swarmfl.run(preset="smoke", seed=7, out=out / "builtin",
                          set={**SET, "byzantine.kind": "sign-flip"})
    plugin = swarmfl.run(preset="smoke", seed=7, out=out / "plugin", set=SET, attack=PySignFlip())
    return builtin, plugin


def test_a_python_attack_reproduces_the_builtin_it_mimics(signflip):
    builtin, plugin = signflip
    subs = plugin.submissions
    assert subs["byzantine"].sum() > 0, "the plug-in's robots submitted"
    for table in ["rounds", "submissions", "balances"]:
        a, b = getattr(builtin, table), getattr(plugin, table)
        assert len(a) == len(b) > 0
        for name in a.columns:
            np.testing.assert_array_equal(a[name].to_numpy(), b[name].to_numpy(), err_msg=f"{table}.{name}")
    # Another configuration (kind = plugin) and a plug-in in the header: another run identity.
    assert plugin.summary["final_hash"] != builtin.summary["final_hash"]


def test_a_python_attack_is_deterministic_and_changes_the_outcome(signflip, tmp_path):
    _, plugin = signflip
    again = swarmfl.run(preset="smoke", seed=7, out=tmp_path / "again", set=SET, attack=PySignFlip())
    assert again.summary["final_hash"] == plugin.summary["final_hash"]
    honest = swarmfl.run(preset="smoke", seed=7, out=tmp_path / "honest",
                         set={"run.duration_s": 200.0})
    assert not honest.rounds[["loss"]].equals(plugin.rounds[["loss"]])


def test_replay_and_fork_need_the_same_plugin(signflip, tmp_path):
    _, plugin = signflip
    ok = swarmfl.replay(plugin.log, resimulate=True, attack=PySignFlip())
    assert ok["final_hash"] == plugin.summary["final_hash"]
    assert swarmfl.replay(plugin.log, attack=PySignFlip())["checkpoints"] > 0
    with pytest.raises(swarmfl.SwarmflError, match=r"plug-in attack `py-sign-flip` \(blake3 [0-9a-f]{64} of inspect.getsource\(PySignFlip\)\), which is not given"):
        swarmfl.replay(plugin.log, resimulate=True)

    class Changed(PySignFlip):
        name = "py-sign-flip"

        def act(self, view):
            return view.shared, view.claimed_samples

    with pytest.raises(swarmfl.SwarmflError, match=r"plug-in attack `py-sign-flip` changed: the log records blake3 [0-9a-f]{64} of inspect.getsource\(PySignFlip\), the given one has [0-9a-f]{64} of inspect.getsource\(.*Changed\)"):
        swarmfl.replay(plugin.log, resimulate=True, attack=Changed())
    with pytest.raises(swarmfl.SwarmflError, match="changed"):
        swarmfl.fork(plugin.log, at=3, set={"learn.learning_rate": 0.02}, attack=Changed())
    fork = swarmfl.fork(plugin.log, at=3, set={"learn.learning_rate": 0.02}, out=tmp_path / "fork",
                        attack=PySignFlip())
    assert fork.summary["final_hash"] == swarmfl.replay(fork.log, resimulate=True, attack=PySignFlip())["final_hash"]


def test_the_command_reads_a_plugin_attacks_log_from_its_records(signflip, tmp_path):
    # The submissions are records: a fold, the viewer and a snapshot need no attack.
    _, plugin = signflip
    for args in (["replay", plugin.log],
                 ["view", plugin.log, "--out", tmp_path / "v.html"],
                 ["snapshot", plugin.log, "--time", "30", "--out", tmp_path / "s.svg"],
                 ["inspect", "--block", "3", plugin.log]):
        p = subprocess.run([str(BIN), *map(str, args)], capture_output=True, text=True)
        assert p.returncode == 0, (args, p.stderr)
    assert plugin.summary["final_hash"] in subprocess.run(
        [str(BIN), "replay", str(plugin.log)], capture_output=True, text=True).stdout
    assert (tmp_path / "v.html").stat().st_size > 0 and (tmp_path / "s.svg").stat().st_size > 0


def test_the_command_refuses_to_run_a_plugin_by_name(signflip, tmp_path):
    _, plugin = signflip
    for args in (["replay", plugin.log, "--resimulate"],
                 ["fork", plugin.log, "--at", "3", "--set", "learn.learning_rate=0.02", "--out", tmp_path / "f"],
                 ["run", "--preset", "smoke", "--set", "byzantine.kind=plugin", "--set", "byzantine.plugin=x",
                  "--set", "byzantine.count=1", "--out", tmp_path / "r"]):
        p = subprocess.run([str(BIN), *map(str, args)], capture_output=True, text=True)
        assert p.returncode != 0, args
        assert "cannot run plug-ins" in p.stderr, p.stderr
        assert "panicked" not in p.stderr and "diverged" not in p.stderr, p.stderr


def bad(answer):
    class Bad(swarmfl.Attack):
        name = "bad"

        def act(self, view):
            return answer(view)
    return Bad()


def boom(view):
    raise ZeroDivisionError("the attack divided by zero")


@pytest.mark.parametrize("answer, message", [
    (boom, r"(?s)raised ZeroDivisionError: the attack divided by zero \(round 0, robot \d+, t = [\d.]+ s\)\nTraceback.*in boom"),
    (lambda v: (v.shared[:-1], 200), r"returned weights of shape \(\d+,\); the model has \d+ weights"),
    (lambda v: ("weights", 200), r"returned weights that are not numbers"),
    (lambda v: (v.shared, 2.5), r"returned samples 2.5 of type float"),
    (lambda v: (np.full(v.shared.size, np.nan), 200), r"returned \d+ non-finite weights \(weight 0 is nan\)"),
    (lambda v: (v.shared, -1), r"returned samples = -1; claims are 0 to 2\^32 - 1"),
    (lambda v: v.shared, r"returned ndarray"),
])
def test_a_bad_plugin_raises_naming_it_the_round_and_the_robot(tmp_path, answer, message):
    with pytest.raises(swarmfl.PluginError, match=message) as e:
        swarmfl.run(preset="smoke", seed=7, out=tmp_path / "bad", set=SET, attack=bad(answer))
    text = str(e.value)
    assert text.startswith("plug-in attack `bad` ")
    assert "(round 0, robot " in text and "t = " in text
    if answer is boom:
        assert isinstance(e.value.__cause__, ZeroDivisionError)


def test_what_is_not_an_attack_is_refused_before_running(tmp_path):
    with pytest.raises(swarmfl.SwarmflError, match="takes an instance"):
        swarmfl.run(preset="smoke", set=SET, attack=PySignFlip, out=tmp_path / "a")
    with pytest.raises(swarmfl.SwarmflError, match=r"an act\(view\) method"):
        swarmfl.run(preset="smoke", set=SET, attack=object(), out=tmp_path / "b")
    with pytest.raises(swarmfl.SwarmflError, match="set= has byzantine.kind"):
        swarmfl.run(preset="smoke", set={**SET, "byzantine.kind": "faulty"}, attack=PySignFlip(),
                    out=tmp_path / "c")
    with pytest.raises(swarmfl.SwarmflError, match="byzantine.count"):
        swarmfl.run(preset="smoke", set={"run.duration_s": 50.0}, attack=PySignFlip(), out=tmp_path / "d")


def test_the_custom_attack_example_runs_and_its_attack_is_taken(tmp_path, capsys):
    script = REPO / "examples" / "python" / "custom_attack.py"
    example = runpy.run_path(str(script))  # defines main, runs nothing
    r = example["main"](tmp_path / "ex")
    out = capsys.readouterr().out
    byz = r.outcomes[r.outcomes.byzantine]
    # The attack does what it says: its claims are within the contract's bound, so its
    # submissions are judged on their models rather than all refused as malformed.
    assert len(byz) > 0
    assert (byz.outcome != "malformed").all(), byz.reason.unique()
    assert byz.outcome.isin(["accepted", "aggregated"]).any(), byz.outcome.value_counts()
    assert byz.samples.max() == r.summary["contract"]["max_claimed_samples"]
    assert f"Byzantine submissions on the final chain: {len(byz)}" in out
    assert "by verdict: " in out and "Byzantine robots" in out
    # The refusals are said when there are any.
    assert ("refused " in out) == bool((byz.reason != "").any())
    # And run as a script.
    p = subprocess.run([sys.executable, str(script), str(tmp_path / "ex2")], capture_output=True,
                       text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert "by verdict: " in p.stdout
