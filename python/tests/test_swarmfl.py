"""The Python package against the `swarmfl` command's own numbers.

Needs the command built (`cargo build --release --locked -p replay-cli`, as CI does) next to the
installed package: its path is $SWARMFL_BIN or target/release/swarmfl of this repository.
"""

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import swarmfl

REPO = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("SWARMFL_BIN", REPO / "target" / "release" / "swarmfl"))


def cli(*args, check=True):
    assert BIN.exists(), f"{BIN} is missing: build it with cargo build --release --locked -p replay-cli"
    p = subprocess.run([str(BIN), *map(str, args)], capture_output=True, text=True)
    if check:
        assert p.returncode == 0, p.stderr
    return p


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    """The smoke preset, seed 7, made from Python, and the CLI's export of its log."""
    out = tmp_path_factory.mktemp("smoke")
    r = swarmfl.run(preset="smoke", seed=7, out=out / "run")
    cli("export", r.log, "--out", out / "csv")
    return r, out / "csv"


def test_a_run_from_python_is_the_commands_run(smoke, tmp_path):
    r, _ = smoke
    # The same preset and seed through the command: its summary.json names the same final hash
    # (so the test follows every intended change of records without a pinned hash to edit).
    cli("run", "--preset", "smoke", "--seed", "7", "--out", tmp_path / "cli", "--quiet")
    theirs = json.loads((tmp_path / "cli" / "summary.json").read_text())["final_hash"]
    assert len(theirs) == 64
    assert r.summary["final_hash"] == theirs
    assert swarmfl.open(r.path).summary["final_hash"] == theirs
    assert r.aggregation == "chain"
    assert len(r.rounds) == r.summary["contract"]["rounds"]


@pytest.mark.parametrize("table", ["rounds", "submissions", "balances", "chain_bytes", "trajectories"])
def test_every_table_equals_the_commands_csv(smoke, table):
    r, csv = smoke
    frame = getattr(r, table)
    theirs = pd.read_csv(csv / f"{table}.csv")
    assert list(frame.columns) == list(theirs.columns)
    assert len(frame) == len(theirs) > 0
    for name in frame.columns:
        a, b = frame[name].to_numpy(), theirs[name].to_numpy()
        # The CSV holds each value's shortest round-trip text: read back, it is the same number.
        np.testing.assert_array_equal(a, b.astype(a.dtype), err_msg=name)


def test_submissions_add_up_to_the_rounds(smoke):
    r, _ = smoke
    s, rounds = r.submissions, r.rounds
    counts = s.groupby(["round", "outcome"]).size().unstack(fill_value=0)
    assert (counts.loc[rounds["round"], "accepted"].to_numpy() == rounds["accepted"].to_numpy()).all()
    assert set(s["outcome"]) <= {"accepted", "outlier"}
    assert (s["distance"] >= 0).all()


def test_outcomes_hold_every_submission_the_summary_counts(smoke):
    r, _ = smoke
    o = r.outcomes
    assert list(o.columns) == ["block", "time_s", "robot", "byzantine", "samples", "outcome",
                               "reason"]
    counted = {k: v for k, v in r.summary["contract"]["submissions"].items() if v}
    assert o["outcome"].value_counts().to_dict() == counted
    assert (o["reason"] != "").sum() == counted.get("malformed", 0)


def test_view_and_snapshot_write_the_commands_files(smoke, tmp_path):
    r, _ = smoke
    page = r.view(tmp_path / "run.html")
    cli("view", r.log, "--out", tmp_path / "cli.html")
    assert page.read_bytes() == (tmp_path / "cli.html").read_bytes()
    for kwargs, flag in [({"time_s": 30.0}, ["--time", "30"]), ({"block": 2}, ["--block", "2"])]:
        svg = r.snapshot(tmp_path / f"{flag[0][2:]}.svg", **kwargs)
        cli("snapshot", r.log, *flag, "--out", tmp_path / f"cli-{flag[0][2:]}.svg")
        assert svg.read_bytes() == (tmp_path / f"cli-{flag[0][2:]}.svg").read_bytes()
    with pytest.raises(swarmfl.SwarmflError, match="exactly one of time_s="):
        r.snapshot(tmp_path / "x.svg")
    with pytest.raises(swarmfl.SwarmflError, match="time_s must be a non-negative number"):
        r.snapshot(tmp_path / "x.svg", time_s=-1)


def test_at_and_bisect_match_inspect_and_bisect(smoke):
    r, _ = smoke
    block = r.bisect("round >= 2")
    first = int(r.rounds.loc[r.rounds["round"] == 2, "block"].iloc[0])
    assert block == first
    theirs = json.loads(cli("bisect", r.log, "--until", "round >= 2", "--json").stdout)
    assert theirs["hit"]["height"] == block
    state = r.at(block=block)
    assert state.block.height == block
    assert state.contract.round == 2
    theirs = json.loads(cli("inspect", r.log, "--block", block, "--json").stdout)
    theirs.pop("inspect_ms")
    theirs.pop("last_height")
    assert state.raw == theirs
    assert r.bisect("round >= 100000") is None


def test_poses_are_thinned_at_the_rate_asked(smoke):
    r, _ = smoke
    robots = 15
    p = r.poses(every_s=10.0)
    times = np.unique(p["time_s"].to_numpy())
    assert len(p) == robots * len(times)
    assert times[0] == 0.0 and np.all(np.abs(np.diff(times) - 10.0) < 0.15)
    assert len(r.poses(every_s=60.0)) < len(p)


def test_a_gossip_run_has_its_aggregations_as_rounds(tmp_path):
    r = swarmfl.run(preset="smoke", seed=3, out=tmp_path / "g",
                    set={"learn.aggregation": "gossip", "run.duration_s": 300})
    rounds = r.rounds
    assert r.aggregation == "gossip"
    assert len(rounds) == r.summary["contract"]["rounds"] > 0
    np.testing.assert_allclose(rounds["loss"], r.summary["contract"]["loss_by_round"], equal_nan=True)
    cli("export", r.log, "--out", tmp_path / "csv")
    assert len(pd.read_csv(tmp_path / "csv" / "rounds.csv")) == len(rounds)
    with pytest.raises(swarmfl.SwarmflError, match="a gossip run has no"):
        r.balances
    t = r.bisect("round >= 1")
    assert t is not None and t <= rounds["time_s"].iloc[0] + 30


def test_bad_input_raises_the_commands_message(tmp_path):
    with pytest.raises(swarmfl.SwarmflError, match="no such file"):
        swarmfl.open(tmp_path / "nothing")
    with pytest.raises(swarmfl.SwarmflError) as e:
        swarmfl.run(preset="smoke", set={"world.nope": 1}, out=tmp_path / "x")
    theirs = cli("run", "--preset", "smoke", "--set", "world.nope=1", "--out", tmp_path / "y",
                 check=False)
    assert theirs.returncode == 2
    assert theirs.stderr.strip() == f"error: {e.value}"
    with pytest.raises(swarmfl.SwarmflError, match="preset"):
        swarmfl.run(preset="no-such-preset", out=tmp_path / "z")
    bad = tmp_path / "bad.swlog"
    bad.write_bytes(b"not a log")
    with pytest.raises(swarmfl.SwarmflError):
        swarmfl.open(bad).rounds
    with pytest.raises(swarmfl.SwarmflError):
        swarmfl.run(preset="smoke", set={"world.robots": object()})
