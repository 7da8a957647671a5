"""Meshcat replays: the scene's parts, the written HTML, what a real browser shows of it (the hopper drawn and
followed by the camera at several times of the animation, a check that fails where the hopper is not drawn), and
the simulate() hook that adds systems to the diagram."""
import json
import os
import shutil
import signal
import subprocess
from pathlib import Path

import numpy as np
import pytest

import drakeslip as ds
from drakeslip.simulation import simulate

PLANNED = [0.4, 1.0, 1.6]
PREDICTED = [(0.8, 0.9, 3.0), (1.7, 1.1, 2.5)]
WINDOW = (1280, 800)   # the window the replays are looked at in, and checked in
OVERFLOW_RGB = (1.0, 0.0, 1.0)   # what covers a page held by ``held_at`` that overflows its window
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--use-gl=angle", "--use-angle=swiftshader",
                  "--enable-unsafe-swiftshader", "--disable-gpu-sandbox", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--no-first-run", "--disable-quic",
                  "--hide-scrollbars", "--enable-logging=stderr", "--log-level=0"]  # the page's console on stderr


@pytest.fixture(scope="module")
def failed_run():
    """Two hops on flat ground, the second slipping mid-stance (about 1 s)."""
    return simulate((0.0, 0.6, 3.0), [0.6, 0.6], ds.Terrain.flat())


@pytest.fixture(scope="module")
def stepping_run():
    """Four hops down and up steps, aimed by the controller at given footholds, and a fifth that slips (3.7 s)."""
    from drakeslip.rollout import rollout

    footholds = [0.7625, 1.5125, 2.0875, 3.7125, 5.0]
    run = rollout(ds.ApexState(0.0, 0.9, 2.0), ds.step_world(3), ds.SlipParams(), footholds=footholds,
                  controller=ds.StepLengthController.load_default(), log=True).simulation
    assert run.failure == ds.FailureMode.SLIP and len(run.apexes) == 4 and run.times[-1] > 3.0
    return run, footholds, [(a[0] + 0.1, a[1] + 0.05) for a in run.apexes]   # predicted apexes near the reached


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


def screenshot(page: Path, png: Path, size=(1280, 640), budget_ms: int = 5000, wait: bool = True):
    """Open ``page`` in headless Chromium (software GL) for ``budget_ms`` of virtual time and save a PNG;
    returns Chromium's stderr (with ``wait=False``, the running process: ``finish`` it). The whole process group
    is ended if it hangs."""
    profile = png.parent / f"profile-{png.stem}"
    command = [browser(), *CHROMIUM_FLAGS, f"--user-data-dir={profile}", f"--window-size={size[0]},{size[1]}",
               f"--virtual-time-budget={budget_ms}", f"--screenshot={png}", page.resolve().as_uri()]
    run = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           start_new_session=True)
    return finish(run, png) if wait else run


def finish(run: subprocess.Popen, png: Path) -> str:
    """Wait for the Chromium ``run`` that writes ``png``; returns its stderr."""
    try:
        _, err = run.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(run.pid, signal.SIGKILL)
        run.communicate()
        raise
    assert png.is_file(), f"no screenshot; chromium said:\n{err[-3000:]}"
    return err


def near_mask(image: np.ndarray, rgb, tolerance: float = 60.0) -> np.ndarray:
    """Which pixels lie within ``tolerance`` (RGB distance, 0-255 scale) of the colour ``rgb`` (0-1 scale). The
    renderer's tone mapping moves saturated colours by up to about 55."""
    target = 255.0 * np.asarray(rgb)
    return np.linalg.norm(image.astype(float) - target, axis=-1) < tolerance


def near(image: np.ndarray, rgb, tolerance: float = 60.0) -> int:
    """How many pixels lie within ``tolerance`` of the colour ``rgb`` (``near_mask``)."""
    return int(near_mask(image, rgb, tolerance).sum())


def held_at(page: Path, t: float, out: Path, hide: str | None = None) -> Path:
    """A copy of the replay ``page`` at ``out`` whose animation is held at ``t`` seconds (paused and sought, as
    Meshcat's time slider does) and, with ``hide``, whose object at that Meshcat path is invisible. The copy covers
    itself in OVERFLOW_RGB when its content overflows the window (a page that would scroll)."""
    hide_js = "" if hide is None else \
        f'viewer.scene_tree.find({json.dumps(hide.strip("/").split("/"))}).set_property("visible", false);'
    script = f"""<script>
setInterval(() => {{
  if (viewer.animator.actions.length) {{ viewer.animator.pause(); viewer.animator.seek({t}); }}
  {hide_js}
  const page = document.scrollingElement;
  if ((page.scrollHeight > innerHeight || page.scrollWidth > innerWidth) && !document.getElementById("overflow")) {{
    const cover = document.createElement("div");
    cover.id = "overflow";
    cover.style.cssText = "position:fixed;left:0;top:0;width:100vw;height:100vh;z-index:99999;background:#f0f";
    document.body.appendChild(cover);
  }}
}}, 50);
</script>
"""
    head, tail, end = page.read_text().rpartition("</body>")
    out.write_text(head + script + tail + end)
    return out


def shots(page: Path, times, folder: Path, hide: str | None = None) -> list:
    """Screenshots (RGB arrays, WINDOW in size) of ``page`` held at each of ``times`` (``held_at``), rendered
    side by side."""
    from PIL import Image

    pngs = [folder / f"{page.stem}-{i}{'-hidden' if hide else ''}.png" for i in range(len(times))]
    copies = [held_at(page, t, png.with_suffix(".html"), hide) for t, png in zip(times, pngs)]
    runs = [screenshot(copy, png, WINDOW, budget_ms=4000, wait=False) for copy, png in zip(copies, pngs)]
    for run, png in zip(runs, pngs):
        console = [line for line in finish(run, png).splitlines() if ":CONSOLE" in line]
        assert not any("Uncaught" in line or "rror" in line for line in console), console
    return [np.asarray(Image.open(png).convert("RGB")) for png in pngs]


def assert_body_drawn(images, body_rgb, header_px: int, terrain_rgb, tolerance: float = 45.0) -> None:
    """The screenshots ``images`` (of one replay at different times) show the body, in its own colour
    ``body_rgb``, in every one, at one place across the window while the terrain moves under it (the camera
    follows the body), and no page that overflows its window."""
    scenes = [image[header_px + 2:] for image in images]
    assert all(near(scene, OVERFLOW_RGB, 30) == 0 for scene in scenes), "the page overflows the window: it scrolls"
    bodies = [near_mask(scene, body_rgb, tolerance) for scene in scenes]
    counts = [int(body.sum()) for body in bodies]
    assert min(counts) > 500, f"the body is not drawn in every screenshot: {counts} pixels of its colour"
    width = scenes[0].shape[1]
    columns = [float(np.nonzero(body)[1].mean()) for body in bodies]
    assert max(columns) < 0.5 * width and max(columns) - min(columns) < 0.03 * width, columns
    ground = [near_mask(scene, terrain_rgb, 30) for scene in scenes]
    moved = [float((a != b).mean()) for a, b in zip(ground, ground[1:])]
    assert len(images) == 1 or min(moved) > 0.01, f"the terrain did not move under the body: {moved}"


def test_terrain_boxes_merge_cells_and_leave_ditches_open():
    from drakeslip.replay_scene import terrain_boxes

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
    from drakeslip.replay_scene import text_segments

    for mode in ds.FailureMode:
        segments, width = text_segments(mode.name, 0.1)
        assert segments.shape[1:] == (2, 2) and len(segments) >= 2 * len(mode.name.replace("_", ""))
        assert 0.08 * len(mode.name) < width < 0.1 * len(mode.name)
        assert segments[..., 1].min() >= 0 and segments[..., 1].max() == pytest.approx(0.1)


def test_the_leg_is_drawn_at_its_length(failed_run):
    from drakeslip.slip_hopper import Mode
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


@pytest.fixture(scope="module")
def stepping_page(stepping_run, tmp_path_factory):
    from drakeslip.meshcat_replay import write_replay

    run, planned, predicted = stepping_run
    return write_replay(run, tmp_path_factory.mktemp("replay") / "replay.html", planned, predicted,
                        title="four hops, a slip")


def test_the_replay_follows_the_hopper_in_headless_chromium(stepping_run, stepping_page):
    """The written page opens offline in a real browser, fits its window, and shows the body at 0.6 s, 1.9 s and
    the end of the run, at one place across the window while the terrain slides under it; the markers, and the
    failure at the end only."""
    require_browser()
    from drakeslip import meshcat_replay as mr
    from drakeslip import replay_scene as rs

    text = stepping_page.read_text()
    assert "<title>four hops, a slip</title>" in text and "failed: SLIP at t = 3.6" in text
    assert stepping_page.stat().st_size < 5_000_000
    images = shots(stepping_page, [0.6, 1.9, 9.0], stepping_page.parent)
    assert_body_drawn(images, mr.BODY_RGB, rs.HEADER_PX, rs.TERRAIN_RGB)
    scenes = [image[rs.HEADER_PX + 2:] for image in images]
    counts = {name: [near(scene, getattr(rs, f"{name}_RGB")) for scene in scenes]
              for name in ("PLANNED", "PREDICTED", "EXECUTED", "FAILURE")}
    counts["LEG"] = [near(scene, mr.LEG_RGB) for scene in scenes]
    assert all(max(n) > 200 for n in counts.values()), counts
    assert counts["FAILURE"][0] < 20 and counts["FAILURE"][1] < 20, counts
    for scene in scenes:
        assert 0.1 < (scene.astype(int).sum(axis=-1) < 720).mean() < 0.9


def test_the_body_check_fails_on_a_page_without_the_hopper(stepping_page):
    """The same page held at 1.9 s with the hopper hidden: the terrain is there, the check of the body fails."""
    require_browser()
    from drakeslip import meshcat_replay as mr
    from drakeslip import replay_scene as rs

    images = shots(stepping_page, [1.9], stepping_page.parent, hide="/drakeslip/world/hopper")
    assert near(images[0][rs.HEADER_PX + 2:], rs.TERRAIN_RGB) > 0.1 * WINDOW[0] * WINDOW[1]
    with pytest.raises(AssertionError, match="the body is not drawn"):
        assert_body_drawn(images, mr.BODY_RGB, rs.HEADER_PX, rs.TERRAIN_RGB)


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
    from drakeslip import replay_scene as rs

    screenshot(page, tmp_path / "replay.png", budget_ms=3000)
    scene = np.asarray(Image.open(tmp_path / "replay.png").convert("RGB"))[rs.HEADER_PX + 2:]
    counts = {name: near(scene, getattr(rs, f"{name}_RGB")) for name in ("TERRAIN", "PLANNED", "EXECUTED")}
    counts["BODY"] = near(scene, mr.BODY_RGB)
    assert counts["TERRAIN"] > 0.1 * scene.shape[0] * scene.shape[1] and all(n > 50 for n in counts.values()), counts
