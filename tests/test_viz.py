"""Figures, animation and the main example run headless and draw what happened."""
import subprocess
import sys
from pathlib import Path

import pytest
from PIL import Image

import drakeslip as ds
from drakeslip.simulation import simulate

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def failed_run():
    """Two hops on flat ground, the second slipping mid-stance."""
    return simulate((0.0, 0.6, 3.0), [0.6, 0.6], ds.Terrain.flat())


def test_viz_leaves_the_matplotlib_backend_alone():
    check = ("import sys, matplotlib; matplotlib.use('svg'); import drakeslip.viz; "
             "assert matplotlib.get_backend() == 'svg'; assert 'matplotlib.pyplot' not in sys.modules")
    run = subprocess.run([sys.executable, "-c", check], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr


def test_plot_trajectory_draws_path_footholds_apexes_and_failure(failed_run, tmp_path):
    from drakeslip.viz import plot_trajectory

    assert failed_run.failure is ds.FailureMode.SLIP
    ax = plot_trajectory(failed_run)
    labels = ax.figure.legends[0].get_texts()
    assert {"body path", "footholds", "apexes", "failure: SLIP"} <= {t.get_text() for t in labels}
    ax.figure.savefig(tmp_path / "hop.png")
    assert Image.open(tmp_path / "hop.png").size[0] > 500


def test_plot_terrain_leaves_ditches_open():
    from drakeslip.viz import new_axes, plot_terrain

    ax = new_axes()
    plot_terrain(ax, ds.ditch_world(0), (-1.0, 4.0))
    assert ax.get_ylim()[0] > -1.0  # the ditch floor is below the view: the holes have no bottom


def test_animate_writes_a_real_time_gif(failed_run, tmp_path):
    from drakeslip.viz import animate

    frames = animate(failed_run, tmp_path / "hop.gif", fps=20)
    gif = Image.open(tmp_path / "hop.gif")
    assert gif.n_frames == frames == pytest.approx(failed_run.times[-1] * 20, abs=2)


def test_hop_example_runs_the_main_job(tmp_path):
    out = tmp_path / "hop.png"
    run = subprocess.run([sys.executable, str(ROOT / "examples" / "hop.py"), "--terrain", "step", "--seed", "3",
                          "--hops", "3", "--out", str(out)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert "outcome: ok, 3 hops" in run.stdout
    assert out.exists()
