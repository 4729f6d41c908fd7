"""Processes killed with SIGKILL at any moment: a stress sweep resumes to its full set of rows, no output file is
ever left partial, no temporary file remains, and a render killed mid-video leaves the old video and nothing else.

The processes are the real command line (``python -m mjcable ...``) in a working folder of their own, which must
stay empty (MuJoCo writes no ``MUJOCO_LOG.TXT`` there)."""

import csv
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
import warnings
from pathlib import Path

import numpy as np
import psutil
import pytest
from matplotlib import image as mpimg

from mjcable import io
from mjcable.bench import results, stress
from mjcable.bench.outcome import OUTCOMES

ROOT = Path(__file__).resolve().parents[1]
TRIES = 20
# A kill comes at a moment drawn uniformly over the time the try would take for its imports and the next few runs
# not yet in the CSV, or, once every run is in, for the stability map and stress.md: so about half the kills land
# among the runs and half in the reports. A try that added no row doubles the next one's span (a run may take longer
# than the estimate).
STARTUP, PER_RUN, RUNS_PER_TRY, REPORTS = 2.0, 1.0, 4, 1.5  # s, s, -, s
FFMPEG_WAIT = 30.0  # s for the orphaned ffmpeg of a killed render to finish


# Figure.savefig that hands matplotlib a file which takes half of the first write (the PNG signature) and then kills
# the process: a sweep killed while its plot is being written, at a moment a random kill rarely finds.
DYING_SAVEFIG = """
import os, signal
import matplotlib.figure


class Dying:
    def __init__(self, f):
        self.f = f

    def write(self, data):
        self.f.write(bytes(data)[:len(data) // 2])
        self.f.flush()
        os.kill(os.getpid(), signal.SIGKILL)

    def __getattr__(self, name):
        return getattr(self.f, name)


savefig = matplotlib.figure.Figure.savefig


def dying_savefig(self, fname, **kw):
    if isinstance(fname, (str, os.PathLike)):  # matplotlib would open the path itself
        kw.setdefault("format", os.path.splitext(str(fname))[1][1:])
        with open(fname, "wb") as f:
            return savefig(self, Dying(f), **kw)
    return savefig(self, Dying(fname), **kw)


matplotlib.figure.Figure.savefig = dying_savefig
"""


def _env() -> dict:
    return dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))


def _start(args, cwd: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "mjcable", *args], cwd=cwd, env=_env(), stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)


def _check_outputs(out: Path, *, resumed: bool) -> int:
    """Every file in ``out`` is whole (the CSV: every row but, after a kill, a last one cut short); returns the
    number of complete rows."""
    rows = 0
    for path in sorted(p for p in out.rglob("*") if p.is_file()):
        assert not path.name.startswith(io.TEMP_PREFIX), path
        if path.suffix == ".png":
            assert mpimg.imread(path).shape[:2] > (100, 100), path
        elif path.suffix == ".md":
            assert path.read_text().startswith("# mjcable stress --quick"), path
        elif path.suffix == ".npy":
            assert np.isfinite(np.load(path)).all(), path
        elif path.name == "stress.csv":
            data = path.read_bytes()
            lines = data.decode("utf-8").split("\r\n")
            assert lines[-1] == "" or not resumed, "a resumed sweep ends its CSV with a whole row"
            records = list(csv.reader(lines[:-1]))  # the last piece: "" or a row a kill cut short
            if records:
                assert records[0] == results.COLUMNS
            assert all(len(r) == len(results.COLUMNS) for r in records[1:]), path
            rows += max(len(records) - 1, 0)
        else:
            raise AssertionError(f"unexpected file {path}")
    return rows


@pytest.mark.slow
def test_a_sweep_killed_at_random_moments_resumes_to_every_row(tmp_path):
    out, cwd = tmp_path / "out", tmp_path / "cwd"
    cwd.mkdir()
    args = ["stress", "--quick", "--models", "springs", "--jobs", "1", "--out", str(out)]
    expected = {c.key for c in stress.stress_cases(quick=True, models=["springs"])}
    rng = np.random.default_rng(20)
    kills = {"runs left": 0, "every run in": 0, "none (finished)": 0}
    left, stalled = len(expected), 0
    for _ in range(TRIES):
        proc = _start(args, cwd)
        try:
            span = STARTUP + (PER_RUN * min(left, RUNS_PER_TRY) if left else REPORTS)
            proc.wait(timeout=rng.uniform(0.2, span * 2 ** stalled))
            phase = "none (finished)"
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGKILL)
            proc.wait()
            phase = None
        now = len(expected) - (_check_outputs(out, resumed=False) if out.exists() else 0)
        kills[phase or ("every run in" if now == 0 else "runs left")] += 1
        stalled = stalled + 1 if 0 < now == left else 0
        left = now
    proc = _start(args, cwd)
    assert proc.wait(timeout=600) == 0
    assert _check_outputs(out, resumed=True) == len(expected)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no row left out
        rows = results.read_rows(out / "stress.csv")
    assert sorted(r["key"] for r in rows) == sorted(expected)  # every run, once
    assert all(r["outcome"] in OUTCOMES for r in rows)
    assert {p.name for p in out.iterdir()} == {"stress.csv", "stress.md", "stability_springs.png"}
    assert list(cwd.iterdir()) == []
    print(f"{TRIES} tries, kills: {kills}")


def test_a_sweep_killed_while_writing_its_plot_leaves_the_old_plot(tmp_path):
    path = tmp_path / "stability_springs.png"
    mpimg.imsave(path, np.full((120, 160, 3), 0.5))
    old = path.read_bytes()
    rows = [dict(scenario="speed", model="springs", dt=dt, params=json.dumps({"speed": v}), outcome=o)
            for o, dt, v in (("stable", 0.002, 1.0), ("diverged", 0.05, 20.0), ("tunneled", 0.05, 1.0))]
    code = DYING_SAVEFIG + textwrap.dedent(f"""
        from mjcable.bench import plots
        plots.stability_map({rows!r}, "springs", {str(path)!r})
    """)
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=_env(), capture_output=True, timeout=120)
    assert proc.returncode == -signal.SIGKILL, proc.stderr.decode()  # killed inside savefig
    assert path.read_bytes() == old
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]


@pytest.mark.slow
def test_a_render_killed_mid_video_leaves_the_old_video_and_no_temporary_file(tmp_path):
    video = tmp_path / "video.mp4"
    video.write_bytes(b"old")
    proc = _start(["render", "--scene", "hang", "--model", "springs", "-o", str(video), "--seconds", "60",
                   "--width", "96", "--height", "72"], tmp_path)
    parent = psutil.Process(proc.pid)
    deadline = time.monotonic() + 120.0
    ffmpeg = []
    while not ffmpeg and proc.poll() is None and time.monotonic() < deadline:
        ffmpeg = [c for c in parent.children() if "ffmpeg" in c.name()]
        time.sleep(0.05)
    assert ffmpeg, "the render never started ffmpeg"
    time.sleep(1.0)  # frames are being written
    assert proc.poll() is None, "the render finished before it could be killed"
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    _, alive = psutil.wait_procs(ffmpeg, timeout=FFMPEG_WAIT)  # ffmpeg sees its input end and finishes its file
    assert not alive
    assert video.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["video.mp4"]
