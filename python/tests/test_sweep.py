"""swarmfl.sweep and swarmfl.results against `swarmfl sweep --grid` and `swarmfl report`."""

import numpy as np
import pandas as pd
import pytest

import swarmfl
from test_swarmfl import cli

# Tiny runs: 6 robots for 40 simulated seconds (quorum 3, where krum assumes no Byzantine
# robot); each takes a fraction of a second.
FIXED = {"run.duration_s": 40, "world.robots": 6, "byzantine.kind": "faulty",
         "contract.assumed_f": 0}
GRID = {"contract.rule": ["median", "krum"], "byzantine.count": [1, 2]}


def test_a_grid_sweep_is_the_commands_and_its_frame_has_every_override(tmp_path, capsys):
    frame = swarmfl.sweep(grid=GRID, preset="smoke", seeds=2, set=FIXED, out=tmp_path / "py",
                          jobs=2)
    assert frame.attrs["sweep"]["ran"] == 8
    # One row per run, in grid order (first axis slowest), every override a typed column.
    assert len(frame) == 8
    assert list(frame["contract.rule"]) == ["median"] * 4 + ["krum"] * 4
    assert frame["byzantine.count"].dtype == np.int64
    assert list(frame["byzantine.count"]) == [1, 1, 2, 2, 1, 1, 2, 2]
    assert list(frame["seed"]) == [1, 2] * 4
    assert (frame["world.robots"] == 6).all() and (frame["byzantine.kind"] == "faulty").all()
    assert (frame["duration_s"] == 40.0).all()
    for column in ["final_loss", "honest_gain", "rounds", "wall_s", "final_hash"]:
        assert column in frame.columns
    # The progress went to stderr: a tqdm bar if installed, else a line per task.
    err = capsys.readouterr().err
    try:
        import tqdm  # noqa: F401
        assert "8/8" in err, err
    except ImportError:
        assert "sweep grid-smoke: [8/8] grid-smoke" in err, err

    # The command's grid sweep of the same settings gives the same runs.
    sets = [a for k, v in FIXED.items() for a in ("--set", f"{k}={v}")]
    cli("sweep", "--preset", "smoke", "--grid", "contract.rule=median,krum",
        "--grid", "byzantine.count=1,2", "--seeds", "2", *sets, "--jobs", "2",
        "--out", tmp_path / "cli")
    theirs = swarmfl.results(tmp_path / "cli")
    assert list(theirs["final_hash"]) == list(frame["final_hash"])
    assert list(theirs["point"]) == list(frame["point"])

    # The same call again resumes: nothing left to run.
    again = swarmfl.sweep(grid=GRID, preset="smoke", seeds=2, set=FIXED, out=tmp_path / "py",
                          progress=False)
    assert (again.attrs["sweep"]["ran"], again.attrs["sweep"]["skipped"]) == (0, 8)
    pd.testing.assert_frame_equal(again.drop(columns="wall_s"), frame.drop(columns="wall_s"))

    # The report records every override and the duration beside the numbers.
    swarmfl.report(tmp_path / "py", tmp_path / "report")
    numbers = pd.read_csv(tmp_path / "report" / "numbers.csv")
    row = numbers[(numbers.point == "contract.rule=krum+byzantine.count=2")
                  & (numbers.metric == "final_loss")].iloc[0]
    assert row.duration_s == 40
    assert row.overrides.startswith("contract.rule=krum byzantine.count=2 run.duration_s=40")
    mean = frame[frame.point == row.point]["final_loss"].mean()
    assert row["mean"] == pytest.approx(mean, rel=1e-12)


def test_a_bad_grid_raises_before_anything_runs_naming_the_key(tmp_path):
    out = tmp_path / "bad"
    with pytest.raises(swarmfl.SwarmflError, match="unknown configuration key `contract.rulez`"):
        swarmfl.sweep(grid={"contract.rulez": ["median"]}, preset="smoke", out=out)
    with pytest.raises(swarmfl.SwarmflError, match="contract.rule"):
        swarmfl.sweep(grid={"contract.rule": ["median", "nosuchrule"]}, preset="smoke", out=out)
    with pytest.raises(swarmfl.SwarmflError, match="world.robots is both a grid axis"):
        swarmfl.sweep(grid={"world.robots": [3, 4]}, preset="smoke", set=FIXED, out=out)
    with pytest.raises(swarmfl.SwarmflError, match="nothing to sweep"):
        swarmfl.sweep(out=out)
    assert not out.exists() or not any(out.rglob("seed*.json"))
    with pytest.raises(swarmfl.SwarmflError, match="no result files"):
        swarmfl.results(tmp_path)


def test_an_empty_grid_is_told_in_python_terms(tmp_path):
    out = tmp_path / "empty"
    with pytest.raises(swarmfl.SwarmflError) as e:
        swarmfl.sweep(grid={}, preset="smoke", out=out)
    assert str(e.value).startswith("grid= is empty, so there is nothing to sweep: give each key "
                                   "a list of values, e.g. swarmfl.sweep(grid={"), str(e.value)
    assert "--grid" not in str(e.value)
    with pytest.raises(swarmfl.SwarmflError, match=r"grid\['contract.rule'\] is an empty list"):
        swarmfl.sweep(grid={"contract.rule": []}, preset="smoke", out=out)
    with pytest.raises(swarmfl.SwarmflError, match="give either experiment= .* or grid=, not both"):
        swarmfl.sweep("e2-faulty", grid={"contract.rule": ["median"]}, out=out)
    with pytest.raises(swarmfl.SwarmflError, match="nothing to sweep") as e:
        swarmfl.sweep(out=out)
    assert "--grid" not in str(e.value)
    assert not out.exists()


def test_a_progress_callback_that_raises_stops_the_sweep(tmp_path, monkeypatch):
    # What Ctrl-C does (KeyboardInterrupt from the wait's signal check) is what an exception in
    # the progress hook does: no new task starts, the ones under way are written, it is raised.
    def boom(self, done, total, line, error):
        raise KeyboardInterrupt

    monkeypatch.setattr(swarmfl._Progress, "__call__", boom)
    with pytest.raises(KeyboardInterrupt):
        swarmfl.sweep(grid=GRID, preset="smoke", seeds=2, set=FIXED, out=tmp_path / "s", jobs=1)
    done = sorted(tmp_path.joinpath("s").rglob("seed*.json"))
    assert 1 <= len(done) < 8
    monkeypatch.undo()
    rest = swarmfl.sweep(grid=GRID, preset="smoke", seeds=2, set=FIXED, out=tmp_path / "s",
                         progress=False)
    assert rest.attrs["sweep"]["skipped"] == len(done) and len(rest) == 8


def test_ctrl_c_interrupts_a_run(tmp_path):
    # SIGINT from another thread while the run goes: Python's handler flags it, the package's
    # wait loop sees it and stops the simulation at its next record.
    import os
    import signal
    import threading

    # A process started in the background by a shell without job control (as CI runners may
    # start it) inherits SIGINT ignored, and Python then never raises KeyboardInterrupt: install
    # Python's own handler for the test, as an interactive session has it.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            swarmfl.run(preset="smoke", seed=3, set={"run.duration_s": 3000}, out=tmp_path / "r")
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    assert (tmp_path / "r" / "run.swlog").exists()
    assert not (tmp_path / "r" / "summary.json").exists()
