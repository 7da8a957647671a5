"""Meshcat replays: the scene's parts, the written HTML, what a real browser shows of it, and the simulate() hook
that adds systems to the diagram."""
import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

import drakeslip as ds
from drakeslip.simulation import simulate

PLANNED = [0.4, 1.0, 1.6]
PREDICTED = [(0.8, 0.9, 3.0), (1.7, 1.1, 2.5)]
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--use-gl=angle", "--use-angle=swiftshader",
                  "--enable-unsafe-swiftshader", "--disable-gpu-sandbox", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--no-first-run", "--disable-quic",
                  "--hide-scrollbars", "--enable-logging=stderr", "--log-level=0"]  # the page's console on stderr


@pytest.fixture(scope="module")
def failed_run():
    """Two hops on flat ground, the second slipping mid-stance (about 1 s)."""
    return simulate((0.0, 0.6, 3.0), [0.6, 0.6], ds.Terrain.flat())


def browser() -> str | None:
    for name in ("chromium", "chromium-browser"):
        if shutil.which(name):
            return shutil.which(name)
    return "/usr/bin/chromium" if os.access("/usr/bin/chromium", os.X_OK) else None


def require_browser() -> None:
    """Skip the calling test, saying why, when no Chromium is installed; where DRAKESLIP_REQUIRE_BROWSER=1 (as
    .ci/run sets it) a missing browser fails the test instead, so CI cannot pass without rendering."""
    if browser() is not None:
        return
    reason = "no Chromium installed (Debian: apt-get install chromium): the replay was not rendered in a browser"
    if os.environ.get("DRAKESLIP_REQUIRE_BROWSER") == "1":
        pytest.fail(f"{reason}, and DRAKESLIP_REQUIRE_BROWSER=1 requires it")
    pytest.skip(reason)


def screenshot(page: Path, png: Path, size=(1280, 640), budget_ms: int = 5000) -> str:
    """Open ``page`` in headless Chromium (software GL) for ``budget_ms`` of virtual time and save a PNG;
    returns Chromium's stderr. The whole process group is ended if it hangs."""
    profile = png.parent / f"profile-{png.stem}"
    command = [browser(), *CHROMIUM_FLAGS, f"--user-data-dir={profile}", f"--window-size={size[0]},{size[1]}",
               f"--virtual-time-budget={budget_ms}", f"--screenshot={png}", page.resolve().as_uri()]
    run = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           start_new_session=True)
    try:
        _, err = run.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(run.pid, signal.SIGKILL)
        run.communicate()
        raise
    assert png.is_file(), f"no screenshot; chromium said:\n{err[-3000:]}"
    return err


def near(image: np.ndarray, rgb, tolerance: float = 60.0) -> int:
    """How many pixels lie within ``tolerance`` (RGB distance, 0-255 scale) of the colour ``rgb`` (0-1 scale).
    The renderer's tone mapping moves saturated colours by up to about 55."""
    target = 255.0 * np.asarray(rgb)
    return int((np.linalg.norm(image.astype(float) - target, axis=-1) < tolerance).sum())


def test_terrain_boxes_merge_cells_and_leave_ditches_open():
    from drakeslip.meshcat_replay import terrain_boxes

    terrain = ds.ditch_world(0)
    boxes = terrain_boxes(terrain, -1.0, 6.0, floor=-0.5)
    assert boxes[0][0] == -1.0 and boxes[-1][1] <= 6.0 + terrain.cell
    for (left, right, top), (next_left, _, _) in zip(boxes, boxes[1:]):
        assert right <= next_left + 1e-9
        if right < next_left - 1e-9:  # a gap between boxes is a ditch, all of it
            assert terrain.is_ditch_at((right + next_left) / 2)
    for x in np.arange(-1.0, 6.0, 0.05):
        covered = any(left <= x < right for left, right, _ in boxes)
        assert covered != terrain.is_ditch_at(x), x
    assert len(boxes) < np.sum(terrain.heights > terrain.ditch_height)  # equal cells merged


def test_every_failure_name_has_letters():
    from drakeslip.meshcat_replay import text_segments

    for mode in ds.FailureMode:
        segments, width = text_segments(mode.name, 0.1)
        assert segments.shape[1:] == (2, 2) and len(segments) >= 2 * len(mode.name.replace("_", ""))
        assert 0.08 * len(mode.name) < width < 0.1 * len(mode.name)
        assert segments[..., 1].min() >= 0 and segments[..., 1].max() == pytest.approx(0.1)


def test_the_leg_is_drawn_at_its_length(failed_run):
    from drakeslip.hopper import Mode
    from drakeslip.meshcat_replay import RETRACTED_FRACTION, leg_geometry

    p, h = failed_run.params, failed_run.hybrid
    stance = np.flatnonzero(h[:, 0] == Mode.STANCE)
    lengths = [leg_geometry(*failed_run.states[i, :2], h[i], p)[1] for i in stance]
    assert min(lengths) < 0.9 * p.leg_length and max(lengths) <= p.leg_length + 1e-6  # compressing in stance
    deployed = np.flatnonzero((h[:, 0] == Mode.FLIGHT) & (h[:, 1] == 1))
    angle, length = leg_geometry(*failed_run.states[deployed[0], :2], h[deployed[0]], p)
    assert length == p.leg_length and angle == h[deployed[0], 2]
    retracted = np.flatnonzero((h[:, 0] == Mode.FLIGHT) & (h[:, 1] == 0))
    assert leg_geometry(*failed_run.states[retracted[0], :2], h[retracted[0]], p) == (
        0.0, RETRACTED_FRACTION * p.leg_length)


def test_draw_replay_builds_the_scene_and_a_real_time_animation(failed_run):
    from pydrake.geometry import Meshcat

    from drakeslip.meshcat_replay import draw_replay

    meshcat = Meshcat()
    frames = draw_replay(meshcat, failed_run, PLANNED, PREDICTED, fps=40)
    assert frames == pytest.approx(failed_run.times[-1] * 40, abs=2)
    for path in ("world/terrain/0", "world/hopper/body", "world/hopper/leg/spring", "world/planned/2",
                 "world/predicted/1", "world/executed/1", "world/failure/label", "world/path"):
        assert meshcat.HasPath(f"/drakeslip/{path}"), path
    slow = draw_replay(meshcat, failed_run, fps=40, follow=False, speed=0.5, prefix="/slow")
    assert slow == pytest.approx(2 * frames, abs=2)  # half speed: twice the frames
    with pytest.raises(ValueError, match="no logged trajectory"):
        draw_replay(meshcat, simulate((0.0, 0.6, 2.0), [0.25], ds.Terrain.flat(), log=False))


def test_the_replay_renders_in_headless_chromium(failed_run, tmp_path):
    """The written page opens offline in a real browser and draws the terrain, body, leg and every marker."""
    require_browser()
    from PIL import Image

    from drakeslip import meshcat_replay as mr

    page = mr.write_replay(failed_run, tmp_path / "replay.html", PLANNED, PREDICTED, title="two hops, a slip")
    text = page.read_text()
    assert "<title>two hops, a slip</title>" in text and "failed: SLIP at t = 1.0" in text
    assert page.stat().st_size < 5_000_000
    start = time.perf_counter()
    err = screenshot(page, tmp_path / "replay.png")  # 5 s of page time: the 1 s run has ended, failure shown
    elapsed = time.perf_counter() - start
    image = np.asarray(Image.open(tmp_path / "replay.png").convert("RGB"))
    assert image.shape == (640, 1280, 3)
    scene = image[mr.HEADER_PX + 2:]
    counts = {name: near(scene, getattr(mr, f"{name}_RGB"))
              for name in ("TERRAIN", "BODY", "LEG", "PLANNED", "PREDICTED", "EXECUTED", "FAILURE")}
    assert counts["TERRAIN"] > 0.1 * scene.shape[0] * scene.shape[1], (counts, elapsed)
    assert all(n > 200 for n in counts.values()), (counts, elapsed)
    not_white = (scene.astype(int).sum(axis=-1) < 720).mean()
    assert 0.1 < not_white < 0.9, not_white
    console = [line for line in err.splitlines() if ":CONSOLE" in line]
    assert not any("Uncaught" in line or "rror" in line for line in console), console


def test_simulate_adds_your_systems_to_the_diagram():
    from pydrake.systems.primitives import LogVectorOutput

    seen = {}

    def add_to(builder, hopper):
        sink = LogVectorOutput(hopper.GetOutputPort("state"), builder)
        seen["systems"] = {type(system).__name__ for system in builder.GetSystems()}
        seen["policy_connected"] = builder.IsConnectedOrExported(hopper.get_input_port(0))

        def when_done(simulator):
            log = sink.FindLog(simulator.get_context())
            seen["times"], seen["states"] = log.sample_times().copy(), log.data().T.copy()
        return when_done

    args = ((0.0, 0.6, 2.0), [0.25, 0.2], ds.Terrain.flat())
    plain, hooked = simulate(*args), simulate(*args, add_to=add_to)
    assert {"SlipHopper", "ApexPolicy"} <= seen["systems"] and seen["policy_connected"]
    np.testing.assert_array_equal(seen["times"], hooked.times)
    np.testing.assert_array_equal(seen["states"], hooked.states)
    np.testing.assert_array_equal(hooked.states, plain.states)  # the run is the same with the sink added
    assert hooked.events == plain.events and hooked.integrator_steps == plain.integrator_steps


def test_hop_example_writes_a_replay(run_script, tmp_path):
    code, _, err = run_script("hop", "--out", tmp_path / "hop.png", "--html", tmp_path / "hop.htm")
    assert code == 2 and "must end in .html" in err
    code, out, _ = run_script("hop", "--terrain", "step", "--seed", "3", "--hops", "2", "--out", tmp_path / "hop.png",
                              "--html", tmp_path / "hop.html")
    assert code == 0 and f"replay: {tmp_path / 'hop.html'}" in out
    text = (tmp_path / "hop.html").read_text()
    assert "hop.py: step terrain, seed 3" in text and "planned footholds" in text and "predicted apexes" in text


def test_plan_and_hop_writes_a_replay_that_renders(run_script, tmp_path):
    """--html is checked before any work; the replay of a short receding-horizon run shows the planned footholds,
    the predicted apexes and the executed footholds in a real browser (skipped, after the page's own checks, where
    none is installed)."""
    code, _, err = run_script("plan_and_hop", "--out", tmp_path / "p.png", "--html", tmp_path / "p.htm")
    assert code == 2 and "must end in .html" in err and len(err.splitlines()) == 1
    page = tmp_path / "replay.html"
    code, out, _ = run_script("plan_and_hop", "--terrain", "step", "--seed", "3", "--goal", "3", "--planner", "step",
                              "--noise", "none", "--executed", "3", "--out", tmp_path / "p.png", "--html", page)
    assert code == 0 and f"replay: {page}" in out
    text = page.read_text()
    assert "plan_and_hop.py: step on step terrain seed 3, reached the goal" in text
    assert "planned footholds" in text and "predicted apexes" in text and page.stat().st_size > 100_000
    require_browser()
    from PIL import Image

    from drakeslip import meshcat_replay as mr

    screenshot(page, tmp_path / "replay.png", budget_ms=3000)
    scene = np.asarray(Image.open(tmp_path / "replay.png").convert("RGB"))[mr.HEADER_PX + 2:]
    counts = {name: near(scene, getattr(mr, f"{name}_RGB")) for name in ("TERRAIN", "BODY", "PLANNED", "EXECUTED")}
    assert counts["TERRAIN"] > 0.1 * scene.shape[0] * scene.shape[1] and all(n > 50 for n in counts.values()), counts
