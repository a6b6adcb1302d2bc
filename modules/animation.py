# Generated from solutions/animation.py by `make modules` (every homework stubbed): do not edit by hand.
"""Pictures of a mechanism drawn from its model file, and animations of a result.

Every body is drawn as a polyline through the points where joints and springs attach to it and its
centre of mass (a body held at one point only as a uniform link, as long again past its centre of mass;
a body whose points all coincide as a block), every joint as a circle, every spring-damper as a zig-zag,
every gear as its pitch circle, a prismatic joint as its rail. The points are taken in the body frames once, from
the file's configuration, s' = A_0^T (P - r_0) (as the model builders do), and placed at any state q by

    P = r + A s'                         (course notes, eq. 2.1 planar; eq. 9.1 spatial)

The drawing uses no function a student writes: the rotation matrices come from ``rotation_matrices``, so a
student's package draws its own results before (and while) its ``rotation`` is being written.

    anim = animate_result(model, system, result, "slider_crank.gif")   # also .mp4 (ffmpeg)

In a notebook or a browser, the viewer (``viewer.py``) draws the same geometry from data: it turns, zooms and plays
without pictures of frames.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from matplotlib.animation import FuncAnimation, PillowWriter, writers
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from .io.model import GROUND, Model
from .results import Result
from .rotation_matrices import euler_rotation, planar_rotation

SPRING_COILS = 8
"""Zig-zags of a drawn spring."""


# -- body frames, without the student's functions -------------------------------------------------------
def spatial_rotation(p: np.ndarray) -> np.ndarray:
    """A(p) of Euler parameters p = (e0, e), normalized first (eq. 8.12)."""
    p = np.asarray(p, dtype=float)
    return euler_rotation(p / np.linalg.norm(p))


def body_frame(q: np.ndarray, body: int, dimension: int) -> tuple[np.ndarray, np.ndarray]:
    """(r, A) of a body at the coordinates q; ground (-1) is the global frame."""
    if body < 0:
        return np.zeros(dimension), np.eye(dimension)
    if dimension == 2:
        x, y, phi = q[3 * body : 3 * body + 3]
        return np.array([x, y]), planar_rotation(phi)
    block = q[7 * body : 7 * body + 7]
    return block[:3], spatial_rotation(block[3:])


# -- what to draw ----------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Attachment:
    """A point fixed in a body (-1: ground), in the body's frame."""

    body: int
    point: np.ndarray

    def at(self, q: np.ndarray, dimension: int) -> np.ndarray:
        """The global position r + A s' at the coordinates q."""
        r, A = body_frame(q, self.body, dimension)
        return r + A @ self.point


@dataclass
class Geometry:
    """The drawing of a mechanism, in body frames: what ``draw_mechanism`` and ``animate_result`` place.

    shapes[b] holds the polylines of body b (body-frame points, one array (k, dimension) each);
    joints, springs and links are attachments; rails are (attachment, unit axis in that body's frame); axes the
    same for the axes of spatial joints that turn (revolute, cylindrical, universal).
    """

    dimension: int
    body_names: list[str]
    shapes: list[list[np.ndarray]]
    joints: list[tuple[str, Attachment]] = field(default_factory=list)
    springs: list[tuple[str, Attachment, Attachment]] = field(default_factory=list)
    links: list[tuple[str, Attachment, Attachment]] = field(default_factory=list)
    rails: list[tuple[str, Attachment, np.ndarray]] = field(default_factory=list)
    axes: list[tuple[str, Attachment, np.ndarray]] = field(default_factory=list)
    scale: float = 1.0


def file_configuration(model: Model) -> np.ndarray:
    """q as the model file places the bodies (before assembly)."""
    q = [np.concatenate([b.location, np.atleast_1d(b.orientation)]) for b in model.bodies]
    return np.concatenate(q).astype(float) if q else np.zeros(0)


class _FileFrames:
    """The bodies' frames in the file's configuration, to take global points into body frames."""

    def __init__(self, model: Model):
        self.model = model
        self.dimension = model.dimension
        self.q0 = file_configuration(model)

    def attachment(self, body_name: str, point, frame: str = "global") -> Attachment:
        body = self.model.body_index(body_name)
        point = np.asarray(point, dtype=float)
        if frame == "body" or body < 0:
            return Attachment(body, point)
        r, A = body_frame(self.q0, body, self.dimension)
        return Attachment(body, A.T @ (point - r))

    def origin(self, body_name: str) -> Attachment:
        return Attachment(self.model.body_index(body_name), np.zeros(self.dimension))

    def axis(self, body_name: str, axis, frame: str = "global") -> np.ndarray:
        axis = np.asarray(axis, dtype=float)
        axis = axis / np.linalg.norm(axis)
        body = self.model.body_index(body_name)
        if frame == "body" or body < 0:
            return axis
        return body_frame(self.q0, body, self.dimension)[1].T @ axis


def _joint_points(spec: dict, frames: _FileFrames) -> tuple[Attachment, Attachment]:
    """Where a joint attaches to its two bodies (the joint point, or each body's origin)."""
    frame = spec.get("frame", "global")
    b1, b2 = spec["body1"], spec["body2"]
    if "location" in spec or "point1" in spec or "point2" in spec:
        p1 = spec.get("point1", spec.get("location"))
        p2 = spec.get("point2", spec.get("location"))
        first = frames.attachment(b1, p1, frame) if p1 is not None else frames.origin(b1)
        second = frames.attachment(b2, p2, frame) if p2 is not None else frames.origin(b2)
        return first, second
    return frames.origin(b1), frames.origin(b2)


def _ordered_outline(points: list[np.ndarray]) -> np.ndarray:
    """The points of a body as one polyline: around their centroid (closed) or along their line."""
    unique: list[np.ndarray] = []
    for p in points:
        if all(np.linalg.norm(p - u) > 1e-9 for u in unique):
            unique.append(p)
    pts = np.array(unique)
    if len(pts) <= 2:
        return pts
    centred = pts - pts.mean(axis=0)
    _, sigma, vt = np.linalg.svd(centred)
    if sigma[1] < 1e-6 * sigma[0]:  # on one line: from one end to the other
        return pts[np.argsort(centred @ vt[0])]
    plane = centred @ vt[:2].T
    order = np.argsort(np.arctan2(plane[:, 1], plane[:, 0]))
    return np.vstack([pts[order], pts[order][:1]])


def _circle(center: np.ndarray, radius: float, n: int = 40) -> np.ndarray:
    """A pitch circle with one spoke, so that its rotation shows."""
    angle = np.linspace(0.0, 2 * np.pi, n + 1)
    ring = center + radius * np.column_stack([np.cos(angle), np.sin(angle)])
    return np.vstack([center, ring])


class _Builder:
    """Collects, body by body, the points to draw while the model's elements are read."""

    def __init__(self, model: Model):
        self.frames = _FileFrames(model)
        dim = model.dimension
        self.points: list[list[np.ndarray]] = [[np.zeros(dim)] for _ in model.bodies]  # centre of mass first
        self.extra: list[list[np.ndarray]] = [[] for _ in model.bodies]
        self.geometry = Geometry(dim, [b.name for b in model.bodies], [])

    def attach(self, *attachments: Attachment) -> None:
        for a in attachments:
            if a.body >= 0:
                self.points[a.body].append(a.point)

    def joint(self, spec: dict) -> None:
        """A joint: its point on both bodies; a rail for a sliding pair; pitch circles for gears."""
        g, name, kind = self.geometry, spec.get("name", ""), spec["type"]
        if kind == "gear" and g.dimension == 2:
            for body, radius in ((spec["body1"], spec["radius1"]), (spec["body2"], spec["radius2"])):
                centre = self.frames.origin(body)
                if centre.body >= 0:
                    self.extra[centre.body].append(_circle(centre.point, float(radius)))
            return
        first, second = _joint_points(spec, self.frames)
        self.attach(first, second)
        if kind == "revolute_revolute":  # a massless link between two pins
            g.links.append((name, first, second))
            g.joints += [(name, first), (name, second)]
            return
        if kind in ("prismatic", "revolute_prismatic", "cylindrical", "rack_pinion") and "axis" in spec:
            g.rails.append((name, first, self.frames.axis(spec["body1"], spec["axis"], spec.get("frame", "global"))))
        if g.dimension == 3 and kind in ("revolute", "cylindrical", "universal") and "axis" in spec:
            g.axes.append((name, first, self.frames.axis(spec["body1"], spec["axis"], spec.get("frame", "global"))))
        g.joints.append((name, second))

    def between(self, spec: dict) -> tuple[Attachment, Attachment]:
        """The two points of a spring-damper or a distance driver."""
        frame = spec.get("frame", "global")
        first = self.frames.attachment(spec["body1"], spec["point1"], frame)
        second = self.frames.attachment(spec["body2"], spec["point2"], frame)
        self.attach(first, second)
        return first, second

    def shapes(self) -> list[list[np.ndarray]]:
        """Each body's outline (and its extra polylines)."""
        for points in self.points:
            held = [p for p in points[1:] if np.linalg.norm(p) > 1e-9]
            if held and all(np.linalg.norm(p - held[0]) < 1e-9 for p in held):
                points.append(-held[0])  # held at one point only: a uniform link, as long again past its centre
        return [[_ordered_outline(points), *more] for points, more in zip(self.points, self.extra, strict=True)]


def mechanism_geometry(model: Model) -> Geometry:
    """What to draw of a model: body outlines through their attachment points, joints, springs, rails."""
    builder = _Builder(model)
    for spec in model.joints:
        builder.joint(spec)
    for spec in model.motors:
        if spec.get("type") == "distance":
            builder.geometry.links.append((spec.get("name", ""), *builder.between(spec)))
    for spec in model.spring_dampers:
        if spec.get("type", "TSDA") == "TSDA" and "point1" in spec:  # a rotational one (RSDA) has no line
            builder.geometry.springs.append((spec.get("name", ""), *builder.between(spec)))
    geometry = builder.geometry
    geometry.shapes = builder.shapes()
    geometry.scale = _scale(geometry, builder.frames.q0)
    return geometry


def _scale(geometry: Geometry, q: np.ndarray) -> float:
    """The size of the mechanism in the file's configuration (for spring widths and blocks)."""
    points = np.vstack(list(_all_points(geometry, q)) or [np.zeros((1, geometry.dimension))])
    size = float(np.max(np.ptp(points, axis=0))) if len(points) > 1 else 0.0
    return size if size > 1e-9 else 1.0


def _all_points(geometry: Geometry, q: np.ndarray):
    for body, shapes in enumerate(geometry.shapes):
        r, A = body_frame(q, body, geometry.dimension)
        for shape in shapes:
            yield r + shape @ A.T
    for _, a in geometry.joints:
        yield a.at(q, geometry.dimension)[None, :]
    for _, a, b in geometry.springs + geometry.links:
        yield np.vstack([a.at(q, geometry.dimension), b.at(q, geometry.dimension)])


# -- placing the drawing at a state ----------------------------------------------------------------------
def zigzag(start: np.ndarray, end: np.ndarray, width: float, coils: int = SPRING_COILS) -> np.ndarray:
    """A spring between two points: straight ends, ``coils`` zig-zags of ``width`` between them."""
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    axis = end - start
    length = float(np.linalg.norm(axis))
    if length < 1e-12:
        return np.vstack([start, end])
    u = axis / length
    k = int(np.argmin(np.abs(u)))
    normal = np.eye(len(u))[k] - u[k] * u if len(u) == 3 else np.array([-u[1], u[0]])
    normal /= np.linalg.norm(normal)
    s = np.linspace(0.15, 0.85, 2 * coils + 1)
    side = np.zeros_like(s)
    side[1:-1:2], side[2:-1:2] = 1.0, -1.0
    zig = start + np.outer(s * length, u) + np.outer(side * width / 2, normal)
    return np.vstack([start, zig, end])


def body_lines(geometry: Geometry, q: np.ndarray) -> list[list[np.ndarray]]:
    """The polylines of every body at q (global points), in ``geometry.shapes`` order."""
    lines = []
    for body, shapes in enumerate(geometry.shapes):
        r, A = body_frame(q, body, geometry.dimension)
        placed = []
        for shape in shapes:
            if len(shape) == 1:  # a block: a square of a tenth of the mechanism around its only point
                half = 0.05 * geometry.scale
                square = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1], [-1, -1]]) * half
                shape = shape[0] + (square if geometry.dimension == 2 else np.column_stack([square, np.zeros(5)]))
            placed.append(r + shape @ A.T)
        lines.append(placed)
    return lines


def rail_line(geometry: Geometry, rail: tuple[str, Attachment, np.ndarray], q: np.ndarray, half: float) -> np.ndarray:
    """A prismatic joint's line of travel on its first body, ``half`` to either side of the joint point."""
    _, a, axis = rail
    r, A = body_frame(q, a.body, geometry.dimension)
    centre = r + A @ a.point
    direction = A @ axis
    return np.vstack([centre - half * direction, centre + half * direction])


def joint_paths(geometry: Geometry, result: Result, names: list[str] | None = None) -> dict[str, np.ndarray]:
    """Paths of joint points over a result: {joint name: (N, dimension)} (by default every joint that moves)."""
    paths = {}
    for name, a in geometry.joints:
        if (names is None or name in names) and a.body >= 0 and name not in paths:
            path = np.array([a.at(q, geometry.dimension) for q in result.q])
            if names is not None or np.max(np.ptp(path, axis=0)) > 1e-9 * geometry.scale:  # pivots stay put
                paths[name] = path
    missing = set(names or ()) - set(paths)
    if missing:
        known = ", ".join(n for n, a in geometry.joints if a.body >= 0)
        raise ValueError(f"no moving joint named {', '.join(sorted(missing))} (joints: {known})")
    return paths


# -- drawing ----------------------------------------------------------------------------------------------
class _Drawing:
    """The artists of one mechanism on one axes, moved to a state by ``update(q)``."""

    def __init__(self, ax, geometry: Geometry, rail_half: list[float], colors=None):
        self.ax, self.g, self.rail_half = ax, geometry, rail_half
        dim = geometry.dimension
        empty = [[] for _ in range(dim)]
        cycle = colors or [f"C{k % 10}" for k in range(len(geometry.shapes))]
        self.rails = [ax.plot(*empty, color="0.55", lw=1.0, ls="--")[0] for _ in geometry.rails]
        self.links = [ax.plot(*empty, color="0.3", lw=1.5)[0] for _ in geometry.links]
        self.springs = [ax.plot(*empty, color="0.25", lw=1.0)[0] for _ in geometry.springs]
        self.bodies = [
            [ax.plot(*empty, color=cycle[b], lw=3.0, solid_capstyle="round")[0] for _ in shapes]
            for b, shapes in enumerate(geometry.shapes)
        ]
        self.centres = ax.plot(*empty, ls="none", marker="o", ms=3, color="k")[0]
        grounded = [a for _, a in geometry.joints if a.body < 0]
        grounded += [a for _, a, b in geometry.springs if a.body < 0] + [
            b for _, a, b in geometry.springs if b.body < 0
        ]
        self.ground = np.array([a.point for a in grounded]) if grounded else np.zeros((0, dim))
        if len(self.ground):
            ax.plot(*self.ground.T, ls="none", marker="^", ms=11, color="0.6", zorder=1)
        style = {"ls": "none", "marker": "o", "ms": 6, "mfc": "white", "mec": "k", "mew": 1.2, "zorder": 5}
        self.joints = ax.plot(*empty, **style)[0]

    def _set(self, line, points: np.ndarray) -> None:
        if self.g.dimension == 2:
            line.set_data(points[:, 0], points[:, 1])
        else:
            line.set_data_3d(points[:, 0], points[:, 1], points[:, 2])

    def update(self, q: np.ndarray) -> list:
        g, dim = self.g, self.g.dimension
        for lines, placed in zip(self.bodies, body_lines(g, q), strict=True):
            for line, points in zip(lines, placed, strict=True):
                self._set(line, points)
        for line, rail, half in zip(self.rails, g.rails, self.rail_half, strict=True):
            self._set(line, rail_line(g, rail, q, half))
        for line, (_, a, b) in zip(self.links, g.links, strict=True):
            self._set(line, np.vstack([a.at(q, dim), b.at(q, dim)]))
        for line, (_, a, b) in zip(self.springs, g.springs, strict=True):
            self._set(line, zigzag(a.at(q, dim), b.at(q, dim), 0.04 * g.scale))
        centres = np.array([body_frame(q, b, dim)[0] for b in range(len(g.shapes))]).reshape(-1, dim)
        self._set(self.centres, centres)
        self._set(self.joints, np.array([a.at(q, dim) for _, a in g.joints]).reshape(-1, dim))
        return [
            *self.rails,
            *self.links,
            *self.springs,
            *(x for lines in self.bodies for x in lines),
            self.centres,
            self.joints,
        ]


def rail_halves(geometry: Geometry, states: np.ndarray) -> list[float]:
    """Half-lengths of the drawn rails: the travel of the sliding point over the states, plus a margin."""
    halves = []
    for name, a, axis in geometry.rails:
        partner = next((b for n, b in geometry.joints if n == name), None)
        travel = 0.0
        if partner is not None:
            for q in states:
                r, A = body_frame(q, a.body, geometry.dimension)
                offset = A.T @ (partner.at(q, geometry.dimension) - r) - a.point
                travel = max(travel, abs(float(offset @ axis)))
        halves.append(travel + 0.1 * geometry.scale)
    return halves


def drawing_limits(geometry: Geometry, states: np.ndarray, halves: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """The box holding the drawing at every state, with a margin."""
    points = []
    for q in states:
        points += [p for placed in body_lines(geometry, q) for p in placed]
        points += list(_all_points(geometry, q))
        points += [rail_line(geometry, rail, q, h) for rail, h in zip(geometry.rails, halves, strict=True)]
    points = np.vstack(points)
    low, high = points.min(axis=0), points.max(axis=0)
    margin = 0.08 * max(float(np.max(high - low)), 1e-3)
    return low - margin, high + margin


def _axes(fig: Figure, geometry: Geometry, low: np.ndarray, high: np.ndarray):
    """An axes with equal scales on the box (planar: x-y; spatial: 3D)."""
    if geometry.dimension == 2:
        ax = fig.add_subplot()
        ax.set_xlim(low[0], high[0])
        ax.set_ylim(low[1], high[1])
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.grid(True, alpha=0.25)
        return ax
    ax = fig.add_subplot(projection="3d")
    centre, half = (low + high) / 2, float(np.max(high - low)) / 2
    for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre, strict=True):
        setter(c - half, c + half)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    return ax


class _FrameCanvas(FigureCanvasAgg):
    """An Agg canvas whose idle redraw does nothing: an animation's frames are drawn once, when saved
    (matplotlib would otherwise draw every frame twice, once on update and once on grabbing)."""

    def draw_idle(self, *args, **kwargs) -> None:
        pass


def _figure(size=(5.6, 4.2), animated: bool = False) -> Figure:
    fig = Figure(figsize=size, dpi=80)
    (_FrameCanvas if animated else FigureCanvasAgg)(fig)
    return fig


def draw_mechanism(model: Model, q: np.ndarray, ax=None, title: str | None = None) -> Figure:
    """A picture of the mechanism at the coordinates q (a Figure; in a notebook it shows itself)."""
    geometry = mechanism_geometry(model)
    states = np.atleast_2d(np.asarray(q, dtype=float))
    halves = rail_halves(geometry, states)
    if ax is None:
        fig = _figure()
        ax = _axes(fig, geometry, *drawing_limits(geometry, states, halves))
    else:
        fig = ax.figure
    _Drawing(ax, geometry, halves).update(states[0])
    ax.set_title(title if title is not None else model.name)
    return fig


def frame_indices(t: np.ndarray, max_frames: int) -> np.ndarray:
    """Indices of the output points to show: all of them, or every k-th (and the last)."""
    step = max(1, math.ceil(len(t) / max_frames))
    frames = np.arange(0, len(t), step)
    return frames if frames[-1] == len(t) - 1 else np.append(frames, len(t) - 1)


def animate_result(
    model: Model,
    system,
    result: Result,
    path: str | Path | None = None,
    *,
    max_frames: int = 120,
    speed: float = 1.0,
    trace: list[str] | None = None,
    title: str | None = None,
) -> FuncAnimation:
    """An animation of the mechanism over a result; written to ``path`` when given.

    Parameters
    ----------
    model : the model the result was computed for (the drawing comes from its file)
    system : its assembled ``System`` (``build_system(model)[0]``): gives the coordinate layout
    result : any analysis result (kinematic, dynamic, inverse)
    path : ``.gif`` (Pillow), ``.mp4`` (needs ffmpeg), or None (a page in a browser: ``viewer.result_view``)
    max_frames : at most this many frames (output points are skipped evenly); ``speed``: 1 is real time
    trace : joint names whose paths are drawn as they are travelled (e.g. ``["B"]``)

    Returns
    -------
    FuncAnimation
        (a notebook shows ``viewer.notebook_animation`` instead: data, not frames of pixels)

    Raises
    ------
    ValueError
        An unknown file type or joint name, ffmpeg missing for .mp4, or a result of another model.
    """
    if path is not None:
        check_writable(Path(path))
    n = system.coordinates_per_body * len(model.bodies)
    if result.q.ndim != 2 or result.q.shape[1] != n:
        raise ValueError(f"the result has {result.q.shape[-1]} coordinates, the model {model.name!r} has {n}")
    geometry = mechanism_geometry(model)
    frames = frame_indices(result.t, max_frames)
    states = result.q[frames]
    halves = rail_halves(geometry, states)
    fig = _figure(animated=True)
    ax = _axes(fig, geometry, *drawing_limits(geometry, states, halves))
    ax.set_title(title if title is not None else f"{model.name}: {result.info.get('analysis', '')} analysis")
    paths = joint_paths(geometry, result, trace) if trace else {}
    traces = {name: ax.plot(*[[] for _ in range(geometry.dimension)], lw=0.8, color="0.4")[0] for name in paths}
    drawing = _Drawing(ax, geometry, halves)
    clock = (
        ax.text2D(0.02, 0.95, "", transform=ax.transAxes)
        if geometry.dimension == 3
        else ax.text(0.02, 0.95, "", transform=ax.transAxes)
    )

    def frame(k: int) -> list:
        index = frames[k]
        artists = drawing.update(result.q[index])
        for name, line in traces.items():
            drawing._set(line, paths[name][: index + 1])
        clock.set_text(f"t = {result.t[index]:.3f} s")
        return [*artists, *traces.values(), clock]

    dt = float(result.t[frames[1]] - result.t[frames[0]]) if len(frames) > 1 else 0.1
    interval = max(20.0, 1000.0 * dt / speed)
    anim = FuncAnimation(fig, frame, frames=len(frames), interval=interval, blit=False, repeat=True)
    if path is not None:
        save_animation(anim, path, fps=1000.0 / interval)
    return anim


def check_writable(path: Path) -> None:
    """Refuse, before any rendering, a file type that cannot be written."""
    suffix = path.suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise ValueError(
            f"{path}: animations are .gif or .mp4 files (a page, by viewer.py: .html), not {suffix or 'no suffix'!r}"
        )
    if suffix == ".mp4" and not writers.is_available("ffmpeg"):
        raise ValueError(f"{path}: writing .mp4 needs ffmpeg, which is not installed; write a .gif instead")


def save_animation(anim: FuncAnimation, path: str | Path, fps: float = 25.0) -> Path:
    """Write an animation: ``.gif`` with Pillow, ``.mp4`` with ffmpeg."""
    path = Path(path)
    check_writable(path)
    fps = max(1, round(fps))
    suffix = path.suffix.lower()
    if suffix == ".gif":
        anim.save(path, writer=PillowWriter(fps=fps))
    else:
        anim.save(path, writer="ffmpeg", fps=fps)
    return path


__all__ = [
    "GROUND",
    "Attachment",
    "Geometry",
    "animate_result",
    "body_frame",
    "draw_mechanism",
    "file_configuration",
    "drawing_limits",
    "frame_indices",
    "joint_paths",
    "mechanism_geometry",
    "rail_halves",
    "save_animation",
    "zigzag",
]
