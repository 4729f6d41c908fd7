"""The ``mjcable`` command: demo, render, export, and the lazily imported bench/stress/env subcommands."""

import dataclasses
import math
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from mjcable import catalog, cli, export, render

TINY = ["--seconds", "0.1", "--fps", "20", "--width", "64", "--height", "48"]


def run(argv, capsys):
    """Run the command; return (exit status, stdout, stderr)."""
    try:
        status = cli.main(argv)
    except SystemExit as exc:
        status = exc.code
    out = capsys.readouterr()
    return status, out.out, out.err


def test_demo_renders_a_model_registered_at_run_time(capsys):
    """The demo asks the catalogue when it runs: a model registered just before is among those it renders."""
    catalog.register(dataclasses.replace(catalog.get("xpbd"), name="throwaway"))
    try:
        scene, models, problems = cli.demo_selection()
        assert scene == cli.DEMO_SCENE
        assert "throwaway" in models and problems == {}
        assert models == catalog.names()
        status, out, _ = run(["render", "--help"], capsys)  # the parser lists the models when it is built
        assert status == 0 and "throwaway" in out
    finally:
        catalog.unregister("throwaway")
    assert "throwaway" not in cli.demo_selection()[1]


def test_the_demos_harness_part_has_every_model_with_several_cables_and_junctions():
    scene, models, problems, left_out = cli.demo_harness_selection()
    assert len(scene.cables) == 3 and len(scene.junctions) == 2
    able = tuple(m for m in catalog.names() if catalog.get(m).several_cables and catalog.get(m).junctions)
    assert models == able and problems == {}
    assert left_out == tuple(m for m in catalog.names() if m not in able)


def test_demo_renders_what_it_selects(tmp_path, monkeypatch, capsys):
    """The demo's video holds one tile per selected model (two here, to stay fast; all of them: the slow test)."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(cli, "demo_selection", lambda: ("hang", ("springs", "xpbd"), {}))
    harness = cli.demo_harness_selection()[0]
    monkeypatch.setattr(cli, "demo_harness_selection", lambda: (harness, ("joints",), {}, ("xpbd",)))
    status, out, err = run(["demo", *TINY], capsys)
    assert status == 0, err
    assert "springs, xpbd" in err and "'hang'" in err
    assert "then joints on a Y-harness" in err and "leaves out xpbd" in err
    video, fps = render.read_video(Path(out.strip()))
    assert video.shape == (4, 48, 2 * 64, 3) and fps == pytest.approx(20)  # the hang's 2 frames, the harness' 2
    assert sorted(p.name for p in tmp_path.iterdir()) == [cli.DEMO_FILE]


@pytest.mark.slow
def test_demo_writes_a_video_of_every_available_model_in_the_current_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    status, out, err = run(["demo", *TINY], capsys)
    assert status == 0, err
    path = Path(out.strip())
    assert path == (tmp_path / cli.DEMO_FILE).resolve() and path.is_file()
    video, fps = render.read_video(path)
    n = len(catalog.names())  # every model builds the demo scene
    rows = math.ceil(n / 4)  # up to 4 per row, rows filled evenly
    columns = math.ceil(n / rows)
    several = [m for m in catalog.names() if catalog.get(m).several_cables and catalog.get(m).junctions]
    assert video.shape == (4 if several else 2, rows * 48, columns * 64, 3) and fps == pytest.approx(20)
    assert video.std() > 10.0  # not blank
    assert sorted(p.name for p in tmp_path.iterdir()) == [cli.DEMO_FILE]


def test_render_one_model_and_a_grid(tmp_path, capsys):
    one = tmp_path / "one.mp4"
    status, out, err = run(["render", "--scene", "hang", "--model", "springs", "-o", str(one), *TINY], capsys)
    assert status == 0, err
    assert Path(out.strip()) == one.resolve()
    assert render.read_video(one)[0].shape == (2, 48, 64, 3)
    two = tmp_path / "two.mp4"
    status, out, err = run(["render", "--scene", "hang", "--model", "springs", "flexrod", "-o", str(two), *TINY],
                           capsys)
    assert status == 0, err
    assert render.read_video(two)[0].shape == (2, 48, 128, 3)


@pytest.mark.parametrize("argv, words", [
    (["render", "--scene", "hang", "-o", "x.mp4"], ["--model"]),
    (["render", "--model", "springs", "-o", "x.mp4"], ["--scene", "--env"]),
    (["render", "--scene", "moon", "--model", "springs", "-o", "x.mp4"], ["--scene", "moon"]),
    (["render", "--scene", "hang", "--env", "drape", "--model", "springs", "-o", "x.mp4"], ["--env"]),
    (["render", "--scene", "hang", "--model", "verlet", "-o", "x.mp4"], ["model", "verlet"]),
    (["render", "--scene", "hang", "--model", "springs", "-o", "x.mp4", "--seconds", "-1"], ["--seconds", "-1"]),
    (["render", "--scene", "hang", "--model", "springs", "-o", "x.mp4", "--width", "63"], ["width", "63"]),
    (["render", "--scene", "hang", "--model", "springs", "-o", "x.avi"], ["mp4"]),
    (["render", "--scene", "hang", "--model", "springs", "-o", "x.mp4", "--camera", "nope"], ["camera", "nope"]),
    (["demo", "--seconds", "abc"], ["--seconds", "abc"]),
    (["bench", "--jobs", "0"], ["--jobs"]),
    (["fly"], ["fly"]),
    ([], ["COMMAND"]),
])
def test_bad_arguments_exit_2_with_a_message(argv, words, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    status, _, err = run(argv, capsys)
    assert status == 2
    for word in words:
        assert word in err
    assert list(tmp_path.iterdir()) == []


def test_export_writes_models(tmp_path, capsys):
    status, out, err = run(["export", "--out", str(tmp_path)], capsys)
    assert status == 0, err
    written = sorted(Path(line).name for line in out.split())
    assert written == sorted(p.name for p in tmp_path.iterdir())
    assert written and set(written) <= {name for _, _, name in export.expected_files()}
    assert "hang_springs.xml" in written


def test_bench_and_stress_forward_their_options(monkeypatch, capsys):
    seen = {}
    fake = types.ModuleType("mjcable.bench")
    fake.cli_bench = lambda args: seen.setdefault("bench", args) and None
    fake.cli_stress = lambda args: seen.setdefault("stress", args) and 0
    monkeypatch.setitem(sys.modules, "mjcable.bench", fake)
    assert run(["bench", "--quick", "--out", "b", "--jobs", "2", "--models", "xpbd", "pbd"], capsys)[0] == 0
    assert run(["stress", "--out", "s"], capsys)[0] == 0
    bench, stress = seen["bench"], seen["stress"]
    assert (bench.quick, bench.out, bench.jobs, bench.models) == (True, "b", 2, ["xpbd", "pbd"])
    assert (stress.quick, stress.out, stress.jobs, stress.models) == (False, "s", None, None)


@pytest.mark.envs
def test_render_env_records_an_episode(tmp_path, monkeypatch, capsys):
    """--env goes through mjcable.envs.load(task, model, random=seed); a dm_control suite task stands in for it."""
    from dm_control import suite

    calls = []

    def load(task, model, *, random=None):
        calls.append((task, model, random))
        return suite.load("cartpole", "balance", task_kwargs={"random": random})

    monkeypatch.setitem(sys.modules, "mjcable.envs", types.SimpleNamespace(load=load))
    path = tmp_path / "episode.mp4"
    status, out, err = run(["render", "--env", "reach_sag", "--model", "xpbd", "--seed", "3", "-o", str(path),
                            *TINY], capsys)
    assert status == 0, err
    assert calls == [("reach_sag", "xpbd", 3)]
    video, _ = render.read_video(path)
    assert video.shape == (2, 48, 64, 3)
    assert np.ptp(video) > 50


def test_module_runs_as_a_script():
    out = subprocess.run([sys.executable, "-m", "mjcable.cli", "--help"], capture_output=True, text=True, check=True)
    for command in ("demo", "render", "export", "bench", "stress"):
        assert command in out.stdout


@pytest.mark.slow  # (keeps the quick suite of a cold clone under 5 minutes)
@pytest.mark.envs
def test_render_env_with_mjcable_envs_shows_the_cable(tmp_path, capsys):
    path = tmp_path / "reach.mp4"
    status, _, err = run(["render", "--env", "reach_sag", "--model", "springs", "--seed", "0", "-o", str(path),
                          "--seconds", "0.2", "--fps", "10", "--width", "96", "--height", "72"], capsys)
    assert status == 0, err
    video, _ = render.read_video(path)
    assert video.shape == (2, 72, 96, 3)
    red = (video[..., 0].astype(int) - video[..., 1] > 60) & (video[..., 0] > 120)
    assert red.sum(axis=(1, 2)).min() > 20  # the cable (drawn centreline) is in every frame


@pytest.mark.parametrize("command", ["stress", "bench"])
def test_sweep_out_that_is_a_file_is_a_usage_error(command, tmp_path):
    existing = tmp_path / "results.csv"
    existing.write_text("keep me\n")
    with pytest.raises(SystemExit) as exit_info:
        cli.main([command, "--quick", "--out", str(existing)])
    assert exit_info.value.code == 2
    assert existing.read_text() == "keep me\n"
