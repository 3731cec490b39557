"""Rendering: top-down rgb_array frames, the human mode's GUI, and Gymnasium's video wrappers."""

from __future__ import annotations

import math
import sys
import types
from pathlib import Path

import gymnasium as gym
import numpy as np
import pybullet
import pytest
from gymnasium.utils.env_checker import check_env
from gymnasium.wrappers import RecordVideo, RenderCollection

from d3dwa_bullet import ENV_ID
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.learning import render as rd
from d3dwa_bullet.learning.env import D3DWAEnv
from d3dwa_bullet.planning.actions import ACTIONS_FULL
from d3dwa_bullet.world.model import Box, Cylinder, World

PROGRESS = ACTIONS_FULL.encode((3.0, 1.0, 2.0, 3.0))
"""Drives toward the goal; tau = 3 s."""
WORLD = World(
    "boxes",
    "a box beside the way, a post beyond the goal",
    (0.0, 0.0, 0.0),
    (2.0, 0.0),
    (Box((1.0, 0.8), (0.6, 0.4)), Cylinder((3.0, 0.0), 0.2)),
)


def pixel(canvas: rd.TopDownCanvas, x: float, y: float) -> tuple[int, int]:
    """(row, col) of a world point in the canvas's frames."""
    col, row = canvas.pixels(np.array([[x, y]]))[0] >> rd.SHIFT
    return int(row), int(col)


def count(frame: np.ndarray, colour: rd.RGB) -> int:
    return int(np.all(frame == colour, axis=-1).sum())


@pytest.fixture
def env():
    e = D3DWAEnv(worlds=(WORLD,), render_mode="rgb_array")
    yield e
    e.close()


def test_metadata_lists_both_modes_at_the_control_rate():
    assert D3DWAEnv.metadata["render_modes"] == ["human", "rgb_array"]
    assert D3DWAEnv.metadata["render_fps"] == 10


@pytest.mark.parametrize("mode", ["rgb", "ansi", "rgb_array_list"])
def test_an_unknown_render_mode_is_refused(mode):
    with pytest.raises(ConfigError, match=repr(mode)):
        D3DWAEnv(worlds=(WORLD,), render_mode=mode)


def test_without_a_render_mode_render_returns_none():
    env = D3DWAEnv(worlds=(WORLD,))
    env.reset(seed=0)
    with pytest.warns(UserWarning, match="no render_mode"):
        assert env.render() is None
    env.close()


def test_render_before_reset_is_an_error(env):
    with pytest.raises(RuntimeError, match="reset"):
        env.render()


def test_a_frame_shows_world_robot_scan_and_the_chosen_rollout(env):
    env.reset(seed=0)
    first = env.render()
    assert first.dtype == np.uint8 and first.ndim == 3 and first.shape[2] == 3
    assert first.shape[0] % rd.ALIGN == 0 and first.shape[1] % rd.ALIGN == 0
    canvas = rd.TopDownCanvas(WORLD)
    assert first.shape == canvas.shape
    assert first[pixel(canvas, 1.0, 0.8)].tolist() == list(rd.OBSTACLE)  # box centre
    assert first[pixel(canvas, 3.0, 0.0)].tolist() == list(rd.OBSTACLE)  # post centre
    assert first[pixel(canvas, 2.0, 0.0)].tolist() == list(rd.GOAL)
    assert first[pixel(canvas, 0.0435, 0.08)].tolist() == list(rd.BODY)  # inside the body box
    assert first[pixel(canvas, 0.5, -0.5)].tolist() == list(rd.BACKGROUND)
    assert count(first, rd.SCAN) > 20  # returns on the box and the post
    assert count(first, rd.ROLLOUT) == 0  # nothing planned yet

    for _ in range(5):
        env.step(PROGRESS)
    frame = env.render()
    assert frame.shape == first.shape
    assert count(frame, rd.ROLLOUT) > 20
    ep = env.episode
    x, y, yaw = ep.truth[-1]
    assert x > 0.02  # the robot moved, and its body is drawn where it is now
    ahead = (x + 0.0435 * math.cos(yaw) - 0.08 * math.sin(yaw), y + 0.08 * math.cos(yaw))
    assert frame[pixel(canvas, *ahead)].tolist() == list(rd.BODY)
    # the rollout's end, planned at the previous pose with tau = 3 s, is drawn green
    end = rd.body_to_world(ep.truth[-2], rd.rollout_path(ep.last_plan.v, ep.last_plan.w, 3.0, 0.1))
    r, c = pixel(canvas, *end[-1])
    patch = frame[r - 1 : r + 2, c - 1 : c + 2].reshape(-1, 3).tolist()
    assert list(rd.ROLLOUT) in patch


def test_rendering_does_not_change_the_episode(env):
    plain = D3DWAEnv(worlds=(WORLD,))
    for e in (env, plain):
        e.reset(seed=3)
    for _ in range(8):
        a = env.step(PROGRESS)
        env.render()
        b = plain.step(PROGRESS)
        np.testing.assert_array_equal(a[0], b[0])
        assert a[1] == b[1]
    plain.close()


def test_rendering_after_the_episode_ended_still_works(env):
    env.reset(seed=0)
    done = False
    while not done:
        _, _, term, trunc, info = env.step(PROGRESS)
        done = term or trunc
    assert info["outcome"] == "goal"
    frame = env.render()
    assert frame.shape == rd.TopDownCanvas(WORLD).shape  # rendering after the end works


@pytest.fixture
def gui_modes(monkeypatch):
    """PyBullet's connect, recorded: the GUI cannot open headless, so DIRECT answers it."""
    modes: list[int] = []
    connect = pybullet.connect

    def fake_connect(mode, *args, **kwargs):
        modes.append(mode)
        return connect(pybullet.DIRECT)

    monkeypatch.setattr(pybullet, "connect", fake_connect)
    monkeypatch.setenv("DISPLAY", ":0")  # so render_mode="human" is accepted (D3DWAEnv checks)
    return modes


def test_check_env_with_the_render_check_of_every_mode(gui_modes):
    """Gymnasium's checker renders this env and one made in each declared mode."""
    env = gym.make(ENV_ID, worlds=(WORLD,), render_mode="rgb_array").unwrapped
    check_env(env)
    env.close()
    assert pybullet.GUI in gui_modes  # the "human" env it made opened the GUI


def test_rollout_path_is_the_unicycle_arc():
    straight = rd.rollout_path(0.4, 0.0, 2.0, 0.1)
    assert straight.shape == (21, 2)
    np.testing.assert_allclose(straight[:, 0], 0.4 * 0.1 * np.arange(21), atol=1e-12)
    np.testing.assert_allclose(straight[:, 1], 0.0, atol=1e-12)
    v, w = 0.3, 0.6
    arc = rd.rollout_path(v, w, 4.0, 0.1)
    t = 0.1 * np.arange(41)
    radius = v / w
    np.testing.assert_allclose(arc[:, 0], radius * np.sin(w * t), atol=1e-12)
    np.testing.assert_allclose(arc[:, 1], radius * (1 - np.cos(w * t)), atol=1e-12)
    turn = rd.rollout_path(0.0, 1.0, 2.0, 0.1)  # rotation in place stays put
    np.testing.assert_allclose(turn, 0.0, atol=1e-12)


def test_body_to_world_rotates_then_translates():
    pts = rd.body_to_world((1.0, 2.0, math.pi / 2), np.array([[1.0, 0.0], [0.0, 1.0]]))
    np.testing.assert_allclose(pts, [[1.0, 3.0], [0.0, 2.0]], atol=1e-12)


def test_a_large_world_fits_the_largest_side():
    big = World("big", "", (0.0, 0.0, 0.0), (40.0, 10.0), ())
    canvas = rd.TopDownCanvas(big, rd.RenderParams(max_side=640))
    assert max(canvas.shape[:2]) <= 640 + rd.ALIGN
    assert canvas.scale < rd.RenderParams().pixels_per_metre


def test_render_collection_gathers_one_frame_per_step():
    env = RenderCollection(gym.make(ENV_ID, worlds=(WORLD,), render_mode="rgb_array"))
    env.reset(seed=0)
    for _ in range(4):
        env.step(PROGRESS)
    frames = env.render()
    assert len(frames) == 5
    assert {f.shape for f in frames} == {rd.TopDownCanvas(WORLD).shape}
    assert not np.array_equal(frames[0], frames[-1])  # the robot moved between them
    env.close()


def _record(tmp_path: Path, steps: int) -> list[Path]:
    folder = tmp_path / "videos"
    env = RecordVideo(
        gym.make(ENV_ID, worlds=(WORLD,), render_mode="rgb_array"),
        str(folder),
        episode_trigger=lambda _: True,
    )
    env.reset(seed=0)
    for _ in range(steps):
        env.step(PROGRESS)
    env.close()  # stops the recording and writes the episode's video
    return sorted(folder.glob("*.mp4"))


class _FrameSink:
    """Stands in for moviepy's ImageSequenceClip: keeps the frames, writes them as .npy."""

    clips: list[_FrameSink] = []

    def __init__(self, frames, fps):
        self.frames, self.fps = list(frames), fps
        _FrameSink.clips.append(self)

    def write_videofile(self, path, logger=None):
        np.save(path, np.stack(self.frames), allow_pickle=False)
        Path(path + ".npy").rename(path)


def test_record_video_hands_its_encoder_every_frame(tmp_path, monkeypatch):
    """RecordVideo's own bookkeeping with our frames; the encoder is a stand-in, so this
    runs without moviepy (the next test encodes for real where moviepy is installed)."""
    names = ("moviepy", "moviepy.video", "moviepy.video.io", "moviepy.video.io.ImageSequenceClip")
    for name in names:
        monkeypatch.setitem(sys.modules, name, types.ModuleType(name))
    sys.modules[names[-1]].ImageSequenceClip = _FrameSink  # type: ignore[attr-defined]
    _FrameSink.clips.clear()
    videos = _record(tmp_path, 6)
    assert len(videos) == 1 and len(_FrameSink.clips) == 1
    clip = _FrameSink.clips[0]
    assert clip.fps == 10 and len(clip.frames) == 7  # the reset's frame and one per step
    assert np.load(videos[0]).shape == (7, *rd.TopDownCanvas(WORLD).shape)


def test_record_video_writes_an_mp4(tmp_path):
    pytest.importorskip("moviepy")
    videos = _record(tmp_path, 6)
    assert len(videos) == 1 and videos[0].stat().st_size > 1000


def test_human_mode_opens_the_gui_and_paces_steps(monkeypatch, gui_modes):
    clock, sleeps = [100.0], []  # a wall clock that only sleeping moves

    def fake_sleep(seconds: float) -> None:
        sleeps.append(seconds)
        clock[0] += seconds

    monkeypatch.setattr("d3dwa_bullet.learning.render.time.monotonic", lambda: clock[0])
    monkeypatch.setattr("d3dwa_bullet.learning.render.time.sleep", fake_sleep)
    env = D3DWAEnv(worlds=(WORLD,), render_mode="human")
    env.reset(seed=0)
    assert gui_modes == [pybullet.GUI]
    assert env.render() is None
    for _ in range(3):
        env.step(PROGRESS)
    assert sleeps == pytest.approx([0.1, 0.1])  # one control period apart, none before the first
    env.close()
