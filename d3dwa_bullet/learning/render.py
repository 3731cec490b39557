"""Top-down frames of an episode for ``D3DWAEnv.render()``: numpy and OpenCV, no matplotlib.

One frame shows, in the world frame seen from above (x right, y up): the obstacles (grey),
a 1 m grid, the goal and its tolerance (red), the start (black), the path driven so far
(light blue), the chosen rollout of the last planning step (green; magenta when the planner
fell back), the current scan's valid returns (orange) and the robot's body box (blue, with
the planner's footprint circles outlined) at its true pose, and a line of text with the
time and the outcome.

A ``TopDownCanvas`` is made once per world: it fixes the view (``World.bounds`` plus a
margin, at ``RenderParams.pixels_per_metre`` or less so the longer side fits
``max_side``) and draws the static layer once; ``frame`` copies that layer and draws the
moving parts, a fraction of a millisecond per frame. Sizes are multiples of 16 pixels so
video encoders take them as they are. :func:`has_display` says whether the other render
mode, the PyBullet GUI, can open a window at all.
"""

from __future__ import annotations

import math
import os
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import cv2
import numpy as np

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.geometry import body_outline
from d3dwa_bullet.params import Footprint
from d3dwa_bullet.planning.planner import PlannerAction
from d3dwa_bullet.world.model import World, obstacle_outline

if TYPE_CHECKING:  # for the annotation only: drawing needs no simulator
    from d3dwa_bullet.episode import Episode

RGB = tuple[int, int, int]


def has_display() -> bool:
    """Whether a GUI window can open: on Linux, DISPLAY or WAYLAND_DISPLAY is set."""
    if not sys.platform.startswith("linux"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def check_render_mode(render_mode: str | None, modes: list[str]) -> None:
    """ConfigError unless render_mode is None or one of modes, and "human" has a display."""
    if render_mode is not None and render_mode not in modes:
        raise ConfigError(f"render_mode {render_mode!r} is not one of {modes}")
    if render_mode == "human" and not has_display():
        raise ConfigError(
            "render_mode='human' opens the PyBullet GUI, but this machine has no display "
            "(neither DISPLAY nor WAYLAND_DISPLAY is set); use render_mode='rgb_array' "
            "for frames, or None"
        )


BACKGROUND: RGB = (255, 255, 255)
GRID: RGB = (232, 232, 232)
OBSTACLE: RGB = (120, 120, 120)
GOAL: RGB = (220, 30, 30)
START: RGB = (0, 0, 0)
TRAIL: RGB = (130, 180, 235)
ROLLOUT: RGB = (0, 160, 0)
FALLBACK: RGB = (200, 0, 200)
SCAN: RGB = (255, 140, 0)
BODY: RGB = (40, 80, 200)
FOOTPRINT: RGB = (40, 80, 200)
TEXT: RGB = (0, 0, 0)

SHIFT = 4
"""Fractional bits of the pixel coordinates handed to OpenCV (sub-pixel drawing)."""
ALIGN = 16
"""Frame height and width are multiples of this, pixels."""


@dataclass(frozen=True)
class RenderParams:
    """How a top-down frame is laid out."""

    pixels_per_metre: float = 80.0
    """Scale of the view, pixels per metre (lowered for a world that would not fit)."""
    max_side: int = 800
    """Largest frame height or width, pixels."""
    margin: float = 0.5
    """Free border around obstacles, start and goal, m."""
    goal_tolerance: float = 0.10
    """Radius of the goal disc, m (the episode's TerminationParams.goal_tolerance)."""
    scan_dot: int = 1
    """Half-size of a scan return's square dot, pixels."""

    def __post_init__(self) -> None:
        if not (self.pixels_per_metre > 0 and self.max_side >= ALIGN and self.margin >= 0):
            raise ConfigError(f"RenderParams out of range: {self!r}")


def rollout_path(v: float, w: float, tau: float, dt: float) -> np.ndarray:
    """The unicycle arc of constant (v, w) from base_link: (n + 1, 2) float64, m, body frame.

    Points at t = 0, dt, ..., tau (n = round(tau / dt)), in the chord form of
    ``geometry.arc_step`` (exact for any w, smooth through w = 0).
    """
    n = max(1, int(round(tau / dt)))
    t = dt * np.arange(n + 1)
    half = 0.5 * w * t
    chord = v * t * np.sinc(half / np.pi)
    return np.column_stack((chord * np.cos(half), chord * np.sin(half)))


def body_to_world(pose: Sequence[float], points: np.ndarray) -> np.ndarray:
    """(N, 2) points in base_link at pose (x, y, yaw) -> (N, 2) world frame, m."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    return np.column_stack((x + c * pts[:, 0] - s * pts[:, 1], y + s * pts[:, 0] + c * pts[:, 1]))


class TopDownCanvas:
    """The view of one world and its static layer (see module docstring)."""

    def __init__(
        self,
        world: World,
        params: RenderParams = RenderParams(),
        footprint: Footprint = Footprint(),
    ) -> None:
        self.world, self.params, self.footprint = world, params, footprint
        xmin, ymin, xmax, ymax = world.bounds(margin=params.margin)
        scale = min(params.pixels_per_metre, params.max_side / max(xmax - xmin, ymax - ymin))
        width = _aligned((xmax - xmin) * scale)
        height = _aligned((ymax - ymin) * scale)
        self.scale = scale
        """Pixels per metre."""
        # centre the world's box in the aligned frame
        self.origin = (
            0.5 * (xmin + xmax) - 0.5 * width / scale,
            0.5 * (ymin + ymax) + 0.5 * height / scale,
        )
        """World (x, y) of the frame's top-left corner, m."""
        self.shape = (height, width, 3)
        self.background = self._static_layer()

    def pixels(self, xy: np.ndarray) -> np.ndarray:
        """(N, 2) world points, m -> (N, 2) int32 pixel (column, row) with SHIFT fraction bits."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        col = (xy[:, 0] - self.origin[0]) * self.scale
        row = (self.origin[1] - xy[:, 1]) * self.scale
        return np.round(np.column_stack((col, row)) * (1 << SHIFT)).astype(np.int32)

    def frame(
        self,
        pose: Sequence[float],
        points: np.ndarray,
        rollout: np.ndarray | None = None,
        fallback: bool = False,
        trail: np.ndarray | None = None,
        text: str = "",
    ) -> np.ndarray:
        """One (H, W, 3) uint8 RGB frame.

        pose: (x, y, yaw) true pose of base_link, m and rad, world frame.
        points: (M, 2) valid scan returns, m, base_link frame at ``pose``.
        rollout: (n, 2) the chosen sample's path, m, world frame (None: none drawn).
        fallback: the rollout is the planner's fallback (drawn in another colour).
        trail: (K, 2) the path driven so far, m, world frame.
        """
        img = self.background.copy()
        if trail is not None and len(trail) > 1:
            self._polyline(img, trail, TRAIL, 2)
        if rollout is not None and len(rollout) > 1:
            self._polyline(img, rollout, FALLBACK if fallback else ROLLOUT, 2)
        self._dots(img, body_to_world(pose, points), SCAN, self.params.scan_dot)
        body = body_outline(pose, samples_per_side=1)
        cv2.fillPoly(img, [self.pixels(body)], BODY, cv2.LINE_AA, SHIFT)
        centres = body_to_world(pose, np.column_stack(
            (self.footprint.centers_x, np.zeros(len(self.footprint.centers_x)))
        ))  # fmt: skip
        radius = int(round(self.footprint.radius * self.scale * (1 << SHIFT)))
        for c in self.pixels(centres):
            cv2.circle(img, (int(c[0]), int(c[1])), radius, FOOTPRINT, 1, cv2.LINE_AA, SHIFT)
        nose = body_to_world(pose, np.array([[0.0, 0.0], [0.3, 0.0]]))
        self._polyline(img, nose, BACKGROUND, 2)
        if text:
            cv2.putText(img, text, (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.5, TEXT, 1, cv2.LINE_AA)
        return img

    # --- drawing helpers -------------------------------------------------------------------

    def _static_layer(self) -> np.ndarray:
        img = np.empty(self.shape, dtype=np.uint8)
        img[:] = BACKGROUND
        h, w = self.shape[:2]
        x0, y0 = self.origin
        for gx in range(math.ceil(x0), math.floor(x0 + w / self.scale) + 1):
            col = int(round((gx - x0) * self.scale))
            img[:, col : col + 1] = GRID
        for gy in range(math.ceil(y0 - h / self.scale), math.floor(y0) + 1):
            row = int(round((y0 - gy) * self.scale))
            img[row : row + 1, :] = GRID
        for ob in self.world.obstacles:
            cv2.fillPoly(img, [self.pixels(obstacle_outline(ob))], OBSTACLE, cv2.LINE_AA, SHIFT)
        goal = self.pixels(np.array([self.world.goal]))[0]
        tol = max(int(round(self.params.goal_tolerance * self.scale * (1 << SHIFT))), 3 << SHIFT)
        cv2.circle(img, (int(goal[0]), int(goal[1])), tol, GOAL, -1, cv2.LINE_AA, SHIFT)
        start = self.world.start
        arrow = body_to_world(start, np.array([[-0.1, 0.08], [0.15, 0.0], [-0.1, -0.08]]))
        cv2.polylines(img, [self.pixels(arrow)], True, START, 1, cv2.LINE_AA, SHIFT)
        return img

    def _polyline(self, img: np.ndarray, xy: np.ndarray, colour: RGB, thickness: int) -> None:
        cv2.polylines(img, [self.pixels(xy)], False, colour, thickness, cv2.LINE_AA, SHIFT)

    def _dots(self, img: np.ndarray, xy: np.ndarray, colour: RGB, half: int) -> None:
        """Square dots of side 2 half + 1 at world points, vectorised (no loop over points)."""
        if not len(xy):
            return
        px = self.pixels(xy) >> SHIFT
        h, w = img.shape[:2]
        offsets = np.arange(-half, half + 1)
        cols = (px[:, 0, None, None] + offsets[None, None, :]).repeat(len(offsets), axis=1)
        rows = (px[:, 1, None, None] + offsets[None, :, None]).repeat(len(offsets), axis=2)
        cols, rows = cols.ravel(), rows.ravel()
        inside = (cols >= 0) & (cols < w) & (rows >= 0) & (rows < h)
        img[rows[inside], cols[inside]] = colour


def _aligned(pixels: float) -> int:
    return max(ALIGN, ALIGN * math.ceil(pixels / ALIGN))


def episode_frame(canvas: TopDownCanvas, ep: Episode, action: PlannerAction | None) -> np.ndarray:
    """The frame of an episode now: the robot at its true pose, its trail and scan, and the
    rollout it chose at the last step with ``action`` (None before the first step)."""
    config = ep.config
    rollout = None
    plan = ep.last_plan
    if plan is not None and action is not None and len(ep.truth) > 1:
        # planned at the pose before the last control period; (v, w) is the chosen
        # sample (the fallback's too)
        path = rollout_path(plan.v, plan.w, action.tau, config.planner.dt)
        rollout = body_to_world(ep.truth[-2], path)
    t = ep.sim.step_count * config.sim.control_period
    text = f"{ep.world.name}  t = {t:.1f} s"
    if action is not None:
        text += f"  tau = {action.tau:g} s"
    if ep.outcome is not None:
        text += f"  {ep.outcome}"
    return canvas.frame(
        ep.truth[-1],
        ep.points,
        rollout=rollout,
        fallback=bool(plan is not None and plan.fallback),
        trail=np.asarray(ep.truth)[:, :2],
        text=text,
    )


class Pacer:
    """Holds each human-mode step to one control period of wall time (watchable speed)."""

    def __init__(self, fps: float) -> None:
        self.period = 1.0 / fps
        self._next_frame = 0.0

    def wait(self) -> None:
        """Sleep until one period has passed since the last step (not at all if it has)."""
        now = time.monotonic()
        if now < self._next_frame:
            time.sleep(self._next_frame - now)
        self._next_frame = max(now, self._next_frame) + self.period
