"""The mechanism in a browser: one viewer for notebooks and HTML files, data rather than pictures.

A result is sent as numbers: at each shown output time, the global points of every body's outline,
joint, spring, rail and traced point, placed by

    P = r + A s'                         (course notes, eq. 2.1 planar; eq. 9.1 spatial)

from the drawing that ``animation.mechanism_geometry`` takes from the model file. They make a Plotly figure
(JSON: one trace per kind of part, one frame per output time) with a time slider and play/pause; Plotly's
JavaScript draws it, and a spatial scene turns and zooms with the mouse. In JupyterLab the figure is a
``application/vnd.plotly.v1+json`` output, drawn by Plotly's MIME renderer (it ships in the plotly wheel with
plotly.js and renders untrusted notebooks); ``write_html`` puts plotly.js into the file. Nothing is fetched
from the network.

    view = result_view(model, system, result, trace=["B"], plots=["crank.phi"])   # a notebook cell shows it
    view.write_html("slider_crank.html")                                          # any browser, offline
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from html import escape
from importlib.resources import files
from pathlib import Path

import numpy as np

from .animation import (
    Attachment,
    Geometry,
    body_frame,
    body_lines,
    drawing_limits,
    file_configuration,
    frame_indices,
    joint_paths,
    mechanism_geometry,
    rail_halves,
    rail_line,
    zigzag,
)
from .io.model import Model
from .io.results import result_columns
from .results import Result

MIME = "application/vnd.plotly.v1+json"
"""The output type of a figure in a notebook (Plotly's MIME renderer draws it)."""

COLORS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22"]
"""Body colours, as matplotlib's default cycle (the static pictures of ``animation`` use the same)."""

CONFIG = {"displaylogo": False, "responsive": True, "showLink": False, "showSendToCloud": False}
"""Plotly's options: no logo, no link to a web service (nothing leaves the machine)."""

DIGITS = 5
"""Significant digits of a coordinate sent, relative to the mechanism's size: 1e-5 of it is below a pixel."""


# -- the parts at one state, as polylines -----------------------------------------------------------------
def _joined(lines: list[np.ndarray], dimension: int, unit: float) -> dict[str, list]:
    """Polylines as one trace's coordinates: x, y (and z) lists with None between two lines."""
    axes: dict[str, list] = {name: [] for name in "xyz"[:dimension]}
    for line in lines:
        rounded = np.round(np.asarray(line, dtype=float) / unit) * unit
        for k, name in enumerate(axes):
            if axes[name]:
                axes[name].append(None)
            axes[name].extend(float(f"{v:.{DIGITS + 2}g}") for v in rounded[:, k])
    return axes


@dataclass(frozen=True)
class _Parts:
    """The moving parts of a mechanism, in a fixed order: each becomes one trace of every frame."""

    geometry: Geometry
    rail_half: list[float]
    unit: float

    def at(self, q: np.ndarray) -> list[dict[str, list]]:
        """Rails, links, springs, each body, the centres of mass, the joints, the spatial joints' axes and each
        body's frame (its x, y (and z) axes from the centre of mass) at q (global points)."""
        g, dim = self.geometry, self.geometry.dimension
        rails = [rail_line(g, rail, q, half) for rail, half in zip(g.rails, self.rail_half, strict=True)]
        axes = [rail_line(g, axis, q, 0.12 * g.scale) for axis in g.axes]
        links = [np.vstack([a.at(q, dim), b.at(q, dim)]) for _, a, b in g.links]
        springs = [zigzag(a.at(q, dim), b.at(q, dim), 0.04 * g.scale) for _, a, b in g.springs]
        centres = [np.array([body_frame(q, b, dim)[0] for b in range(len(g.shapes))]).reshape(-1, dim)]
        joints = [np.array([a.at(q, dim) for _, a in g.joints]).reshape(-1, dim)]  # one run: a label per point
        frames = [[], [], []][:dim]
        for body in range(len(g.shapes)):
            r, A = body_frame(q, body, dim)
            for k in range(dim):  # the body's k-th axis: column k of A (eq. 2.1, eq. 9.1)
                frames[k].append(np.vstack([r, r + 0.08 * g.scale * A[:, k]]))
        groups = [rails, links, springs, *body_lines(g, q), centres, joints, axes, *frames]
        return [_joined(lines, dim, self.unit) for lines in groups]


def _style(geometry: Geometry, frames: bool = False) -> list[dict]:
    """How each trace of ``_Parts.at`` is drawn (same order); the body frames shown (``frames``) or listed in the
    legend, where a click shows them."""
    line = {"mode": "lines", "hoverinfo": "skip", "showlegend": False}
    bodies = [
        {"mode": "lines", "name": name, "line": {"color": COLORS[b % len(COLORS)], "width": 6}, "hoverinfo": "name"}
        for b, name in enumerate(geometry.body_names)
    ]
    names = [name for name, _ in geometry.joints]
    return [
        {**line, "name": "rails", "line": {"color": "#8c8c8c", "width": 1.5, "dash": "dash"}},
        {**line, "name": "links", "line": {"color": "#4d4d4d", "width": 2.5}},
        {**line, "name": "springs", "line": {"color": "#404040", "width": 1.5}},
        *bodies,
        {"mode": "markers", "name": "centres of mass", "marker": {"color": "black", "size": 4}, "showlegend": False},
        {
            "mode": "markers+text",
            "name": "joints",
            "text": names,
            "textposition": "top right",
            "hovertemplate": "%{text}<extra></extra>",
            "marker": {"color": "white", "size": 9, "line": {"color": "black", "width": 1.5}},
            "showlegend": False,
        },
        {**line, "name": "joint axes", "line": {"color": "#555555", "width": 2, "dash": "dashdot"}},
        *(
            {
                **line,
                "name": f"body {axis} axes",
                "line": {"color": color, "width": 2},
                "showlegend": True,
                "visible": True if frames else "legendonly",
            }
            for axis, color in zip("xyz"[: geometry.dimension], ("#d62728", "#2ca02c", "#1f77b4"), strict=False)
        ),
    ]


def _ground(geometry: Geometry) -> dict:
    """The trace of the points held by the ground (joints and spring ends on it)."""
    held = [a.point for _, a in geometry.joints if a.body < 0]
    held += [p.point for _, a, b in geometry.springs for p in (a, b) if p.body < 0]
    points = np.array(held).reshape(-1, geometry.dimension)
    planar = geometry.dimension == 2
    marker = {"symbol": "triangle-up" if planar else "diamond", "size": 12, "color": "#999999"}
    return {
        "type": _kind(geometry.dimension),
        "mode": "markers",
        "name": "ground",
        "showlegend": False,
        "marker": marker,
        "hoverinfo": "skip",
        **_joined([points], geometry.dimension, geometry.scale * 10.0**-DIGITS),
    }


def _fit(geometry: Geometry, states: np.ndarray) -> tuple[_Parts, np.ndarray, np.ndarray]:
    """The parts to place at the states, and the box (low, high corners) that holds them at every one."""
    halves = rail_halves(geometry, states)
    low, high = drawing_limits(geometry, states, halves)
    return _Parts(geometry, halves, geometry.scale * 10.0**-DIGITS), low, high


def _kind(dimension: int) -> str:
    """Plotly's trace type of a planar or spatial drawing."""
    return "scatter" if dimension == 2 else "scatter3d"


# -- the figure ---------------------------------------------------------------------------------------------
def _trace(kind: str, coordinates: dict, style: dict | None = None) -> dict:
    return {"type": kind, **(style or {}), **coordinates}


def _scene_layout(dimension: int, low: np.ndarray, high: np.ndarray, gravity: np.ndarray) -> dict:
    """Axes that fit the mechanism at equal scale: planar x-y; spatial a box as tall as the motion needs."""
    if dimension == 2:
        return {
            "xaxis": {"range": [low[0], high[0]], "title": {"text": "x [m]"}, "zeroline": False, "domain": [0, 1]},
            "yaxis": {"range": [low[1], high[1]], "title": {"text": "y [m]"}, "scaleanchor": "x", "zeroline": False},
        }
    extent = np.maximum(high - low, 1e-9)
    ratio = np.maximum(extent / extent.max(), 0.25)
    axes = {
        f"{name}axis": {"range": [float(lo), float(hi)], "title": {"text": f"{name} [m]"}}
        for name, lo, hi in zip("xyz", low, high, strict=True)
    }
    up = -gravity / np.linalg.norm(gravity) if np.linalg.norm(gravity) > 0 else np.array([0.0, 0.0, 1.0])
    eye = np.array([1.0, 1.0, 1.0]) - 0.5 * up  # from above the horizon, at the distance of Plotly's default
    eye *= 1.9 / np.linalg.norm(eye)
    camera = {
        "up": dict(zip("xyz", map(float, up), strict=True)),
        "eye": dict(zip("xyz", map(float, eye), strict=True)),
    }
    return {
        "scene": {
            **axes,
            "aspectmode": "manual",
            "aspectratio": dict(zip("xyz", map(float, ratio), strict=True)),
            "camera": camera,
        }
    }


def _controls(labels: list[str], duration: float, redraw: bool) -> dict:
    """Play/pause buttons and a time slider over the frames ``labels``."""
    still = {"frame": {"duration": 0, "redraw": redraw}, "mode": "immediate", "transition": {"duration": 0}}
    play = {"frame": {"duration": duration, "redraw": redraw}, "fromcurrent": True, "transition": {"duration": 0}}
    buttons = [
        {"label": "Play", "method": "animate", "args": [None, play]},
        {"label": "Pause", "method": "animate", "args": [[None], still]},
    ]
    steps = [{"label": label, "method": "animate", "args": [[label], still]} for label in labels]
    return {
        "updatemenus": [
            {
                "type": "buttons",
                "direction": "left",
                "showactive": False,
                "x": 0.0,
                "xanchor": "left",
                "y": 0.0,
                "yanchor": "top",
                "pad": {"t": 65, "r": 10},
                "buttons": buttons,
            }
        ],
        "sliders": [
            {
                "active": 0,
                "x": 0.17,
                "len": 0.83,
                "y": 0.0,
                "yanchor": "top",
                "pad": {"t": 55},
                "currentvalue": {"prefix": "t = ", "suffix": " s"},
                "steps": steps,
            }
        ],
    }


@dataclass(frozen=True)
class View:
    """A Plotly figure of a mechanism (``figure``: data, layout, frames, config): a notebook shows it,
    ``write_html`` makes a page of it."""

    figure: dict

    def _repr_mimebundle_(self, include=None, exclude=None) -> dict:
        return {MIME: self.figure, "text/plain": f"<mechanism view: {self.figure['layout']['title']['text']}>"}

    def to_json(self) -> str:
        return json.dumps(self.figure, separators=(",", ":"))

    def write_html(self, path: str | Path, text: str = "") -> Path:
        """One self-contained page (plotly.js inlined), ``text`` below the figure: opens offline in any browser."""
        path = Path(path)
        path.write_text(page(self.to_json(), self.figure["layout"]["title"]["text"], text))
        return path


def plotly_js() -> str:
    """plotly.js as the plotly wheel ships it (package_data/plotly.min.js)."""
    return files("plotly").joinpath("package_data", "plotly.min.js").read_text(encoding="utf-8")


def page(figure_json: str, title: str, text: str = "") -> str:
    """An HTML page drawing one figure with the inlined plotly.js; ``text`` (plain, escaped here) below it."""
    below = f'<pre style="margin:1em 3em;font-size:14px">{escape(text)}</pre>\n' if text else ""
    return (
        f'<!DOCTYPE html>\n<html><head><meta charset="utf-8"><title>{escape(title)}</title>\n'
        f"<script>{plotly_js()}</script></head>\n"
        f'<body style="margin:0;font-family:sans-serif">{embedded(figure_json, "view")}\n{below}</body></html>\n'
    )


def embedded(figure_json: str, ident: str) -> str:
    """The HTML that draws one figure into a page that has plotly.js: its element ``ident`` and the script that
    plays it. The figure's JSON is written so that nothing in it can end the script (``<``, ``>`` and ``&`` as
    JSON escapes)."""
    safe = figure_json.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")
    name = json.dumps(ident)
    return (
        f'<div id="{escape(ident)}" class="mbd-view" style="width:100%"></div>\n'
        f"<script>(() => {{\nconst figure = {safe};\n"
        f"Plotly.newPlot({name}, figure).then(() => Plotly.addFrames({name}, figure.frames || []));\n}})();</script>"
    )


def embed_views(nb, loader: str, prefix: str, check=None) -> int:
    """Give every view output of an executed notebook (``MIME``, which nbconvert's HTML does not draw) an HTML form
    that plays it in the page (``embedded``), ``loader`` (what brings plotly.js) before the first; ``check(figure)``
    (optional) returns the figure to draw, or None to leave the output as it is. Returns the number of views."""
    count = 0
    for cell in nb.cells:
        for output in cell.get("outputs", []) if cell.cell_type == "code" else []:
            figure = output.get("data", {}).get(MIME)
            figure = check(figure) if check is not None and figure is not None else figure
            if figure is None:
                continue
            count += 1
            html = embedded(json.dumps(figure, separators=(",", ":")), f"{prefix}-{count}")
            output["data"]["text/html"] = (loader + "\n" if count == 1 else "") + html
    return count


def result_view(
    model: Model,
    system,
    result: Result,
    *,
    max_frames: int = 120,
    speed: float = 1.0,
    trace: list[str] | None = None,
    plots: list[str] | None = None,
    reactions: list[str] | None = None,
    forces: list[str] | None = None,
    title: str | None = None,
) -> View:
    """The mechanism moving over a result, with the paths of the joints or points ``trace`` (a point: a label of
    the result's ``LABEL.x`` ... columns, ``mbd run --point``), the result columns ``plots``
    (CSV names, e.g. ``["crank.phi", "slider.x_d"]``) against time, a marker at the shown time, and the reaction
    force of each joint of ``reactions`` as an arrow at the joint (what the joint exerts on its second body,
    eq. 5.41/10.20, ``JOINT.Fx`` ...; the longest arrow of the run 0.4 of the mechanism's size), and the force of
    each force element of ``forces`` (a point force; a spring-damper-actuator, on both its bodies) as an arrow at
    its point (scaled on their own).

    Raises
    ------
    ValueError
        A result of another model, an unknown joint in ``trace`` or an unknown column in ``plots``, or a joint of
        ``reactions`` that the result has no reaction of (a dynamic or inverse-dynamic result has them), a name of
        ``forces`` that is no force element with a point (torques have none).
    """
    n = system.coordinates_per_body * len(model.bodies)
    if result.q.ndim != 2 or result.q.shape[1] != n:
        raise ValueError(f"the result has {result.q.shape[-1]} coordinates, the model {model.name!r} has {n}")
    columns = result_columns(result)
    unknown = [name for name in plots or () if name not in columns]
    if unknown:
        raise ValueError(f"no result column {', '.join(unknown)} (columns: {', '.join(columns)})")
    geometry = mechanism_geometry(model)
    arrows = [_Arrows.reactions(geometry, columns, reactions)] if reactions else []
    arrows += [_Arrows.applied(geometry, model, result, forces)] if forces else []
    shown = frame_indices(result.t, max_frames)
    states = result.q[shown]
    parts, low, high = _fit(geometry, states)
    kind = _kind(geometry.dimension)
    points = _traced_points(geometry, columns, trace or [])
    joints = [name for name in trace or () if name not in points]
    paths = {**(joint_paths(geometry, result, joints) if joints else {}), **points}

    def frame_data(k: int) -> list[dict]:
        index = shown[k]
        data = [_trace(kind, c) for c in parts.at(result.q[index])]
        if points:
            at = np.array([path[index] for path in points.values()])
            data.append(_trace(kind, _joined([at], geometry.dimension, parts.unit)))
        for arrow in arrows:
            data.append(_trace(kind, _joined(arrow.at(result.q[index], index), geometry.dimension, parts.unit)))
        data += [
            _trace("scatter", {"x": [float(result.t[index])], "y": [float(columns[c][index])]}) for c in plots or ()
        ]
        return data

    first = frame_data(0)
    styles = _style(geometry) + ([_point_style(list(points))] if points else [])
    styles += [arrow.style for arrow in arrows]
    axes = [f"y{k + 2}" for k in range(len(plots or ()))]
    markers = [
        {"mode": "markers", "marker": {"color": "black", "size": 8}, "showlegend": False, "yaxis": y, "xaxis": "x2"}
        for y in axes
    ]
    data = [{**style, **trace} for style, trace in zip([*styles, *markers], first, strict=True)]
    moving = list(range(len(data)))
    for name, path in paths.items():  # the whole path at once: the frames only move the mechanism along it
        line = {"color": "#666666", "width": 1, "dash": "dot"}
        data.append(
            _trace(
                kind,
                _joined([path], geometry.dimension, parts.unit),
                {"mode": "lines", "line": line, "name": f"path of {name}"},
            )
        )
    data.append(_ground(geometry))
    for name, y in zip(plots or (), axes, strict=True):
        data.append(
            {
                "type": "scatter",
                "mode": "lines",
                "name": name,
                "x": result.t.tolist(),
                "y": columns[name].tolist(),
                "xaxis": "x2",
                "yaxis": y,
            }
        )
    labels = [f"{result.t[i]:.3f}" for i in shown]
    frames = [{"name": label, "data": frame_data(k), "traces": moving} for k, label in enumerate(labels)]
    dt = float(result.t[shown[1]] - result.t[shown[0]]) if len(shown) > 1 else 0.1
    title = title if title is not None else f"{model.name}: {result.info.get('analysis', '')} analysis"
    layout = {
        "title": {"text": title},
        "height": 560 if geometry.dimension == 2 else 640,
        "margin": {"l": 50, "r": 20, "t": 50, "b": 130},
        "legend": {"orientation": "h", "y": 1.0, "yanchor": "bottom", "x": 1.0, "xanchor": "right"},
        **_scene_layout(geometry.dimension, low, high, np.asarray(model.gravity, dtype=float)),
        **_controls(labels, max(20.0, 1000.0 * dt / speed), redraw=geometry.dimension == 3),
    }
    if plots:
        _add_plot_axes(layout, plots, axes, spatial=geometry.dimension == 3)
    config = {**CONFIG, "scrollZoom": True}
    return View({"data": data, "layout": layout, "frames": frames, "config": config})


def _traced_points(geometry: Geometry, columns: dict, names: list[str]) -> dict[str, np.ndarray]:
    """The paths of the body points among ``names`` that the result has as columns (``LABEL.x``, ``LABEL.y``
    (, ``LABEL.z``): ``mbd run --point``, ``points=`` of an analysis): {label: (N, dimension)}. The other names
    must be joints (``animation.joint_paths``); a name that is neither is refused with both lists."""
    axes = "xyz"[: geometry.dimension]
    labels = sorted({c.rsplit(".", 1)[0] for c in columns if c.endswith(".x")} - {n for n, _ in geometry.joints})
    labels = [n for n in labels if all(f"{n}.{a}" in columns for a in axes) and n not in geometry.body_names]
    joints = {n for n, a in geometry.joints if a.body >= 0}
    unknown = [n for n in names if n not in labels and n not in joints]
    if unknown:
        raise ValueError(
            f"nothing to trace named {', '.join(unknown)} (joints: {', '.join(sorted(joints))}; "
            f"points of the result: {', '.join(labels) or 'none (mbd run --point)'})"
        )
    return {n: np.column_stack([columns[f"{n}.{a}"] for a in axes]) for n in names if n in labels}


def _point_style(labels: list[str]) -> dict:
    return {
        "mode": "markers+text",
        "name": "points",
        "text": labels,
        "textposition": "bottom right",
        "marker": {"color": "#9467bd", "size": 7, "symbol": "diamond"},
        "hovertemplate": "%{text}<extra></extra>",
        "showlegend": False,
    }


@dataclass(frozen=True)
class _Arrows:
    """Forces as arrows: each one a history of where it acts (``places``: one callable of (q, output index) per
    arrow) and of the force (``forces``: one (N, dimension) history per arrow), scaled by ``scale`` from its
    point, with a head of two barbs; ``style`` the trace's (its name in the legend and its colour)."""

    geometry: Geometry
    places: list
    forces: list[np.ndarray]
    scale: float
    style: dict

    @classmethod
    def make(cls, geometry: Geometry, places: list, forces: list[np.ndarray], name: str, color: str) -> _Arrows:
        """Arrows whose longest one over the run is 0.4 of the mechanism's size."""
        largest = max((float(np.max(np.linalg.norm(f, axis=1))) for f in forces), default=0.0)
        style = {"mode": "lines", "name": name, "line": {"color": color, "width": 4}, "hoverinfo": "skip"}
        return cls(geometry, places, forces, 0.4 * geometry.scale / largest if largest > 0 else 0.0, style)

    @classmethod
    def reactions(cls, geometry: Geometry, columns: dict, names: list[str]) -> _Arrows:
        """The reaction force of each joint of ``names`` at the joint (columns ``JOINT.Fx`` ...)."""
        axes = "xyz"[: geometry.dimension]
        joints = dict(geometry.joints)
        missing = [n for n in names if n not in joints or any(f"{n}.F{a}" not in columns for a in axes)]
        if missing:
            have = sorted({c.split(".")[0] for c in columns if c.endswith(".Fx")})
            raise ValueError(
                f"no reaction of {', '.join(missing)} in the result (reactions of: {', '.join(have) or 'none'}; "
                "a dynamic or inverse-dynamic result has them)"
            )
        forces = [np.column_stack([columns[f"{n}.F{a}"] for a in axes]) for n in names]
        places = [lambda q, index, at=joints[n]: at.at(q, geometry.dimension) for n in names]
        return cls.make(geometry, places, forces, "reaction forces", "#d62728")

    @classmethod
    def applied(cls, geometry: Geometry, model: Model, result: Result, names: list[str]) -> _Arrows:
        """The applied force of each force element of ``names`` (a point force, a spring-damper-actuator), on each
        body it acts on, at its point: the translational rows of the element's generalized forces Q_i
        (eq. 5.13; ``generalized_forces``), evaluated at every output time."""
        from .generalized_forces import build_forces

        elements = {e.name: e for e in build_forces(model).elements}
        drawn = {name: e for name, e in elements.items() if hasattr(e, "point") or hasattr(e, "si")}
        unknown = [n for n in names if n not in drawn]
        if unknown:
            turning = [n for n in unknown if n in elements]
            why = f" ({', '.join(turning)}: a torque, with no point to draw it at)" if turning else ""
            raise ValueError(
                f"no force element {', '.join(unknown)} to draw{why} (forces with a point: "
                f"{', '.join(sorted(drawn)) or 'none'})"
            )
        places, forces = [], []
        for name in names:
            for body, point, history in _element_forces(drawn[name], result, geometry.dimension):
                at = Attachment(body, point)
                places.append(lambda q, index, at=at: at.at(q, geometry.dimension))
                forces.append(history)
        return cls.make(geometry, places, forces, "applied forces", "#2ca02c")

    def at(self, q: np.ndarray, index: int) -> list[np.ndarray]:
        """Each arrow (shaft and head) at the coordinates q of output ``index``, as polylines."""
        dim, lines = self.geometry.dimension, []
        for place, force in zip(self.places, self.forces, strict=True):
            base = place(q, index)
            arrow = self.scale * force[index]
            length = float(np.linalg.norm(arrow))
            if length == 0.0:
                continue
            along = arrow / length
            across = np.array([-along[1], along[0]]) if dim == 2 else np.cross(along, _least_parallel(along))
            across = across / np.linalg.norm(across)
            tip, head = base + arrow, 0.25 * min(length, 0.1 * self.geometry.scale)
            lines.append(np.vstack([base, tip]))
            lines.append(np.vstack([tip - head * (along - 0.5 * across), tip, tip - head * (along + 0.5 * across)]))
        return lines or [np.full((1, dim), np.nan)]


def _element_forces(element, result: Result, dimension: int) -> list[tuple[int, np.ndarray, np.ndarray]]:
    """(body, body-frame point, (N, dimension) force history) of each body a force element acts on with a point:
    F_i = Q_i[:dimension], the force rows of its generalized force on body i (its moment rows aside)."""
    from .spatial.forces import GROUND

    width = 3 if dimension == 2 else 7
    ground = np.zeros(width) if dimension == 2 else GROUND  # ground's coordinates, as the force models pair them

    def block(x: np.ndarray, body: int, rest: np.ndarray) -> np.ndarray:
        return rest if body < 0 else x[width * body : width * body + width]

    sides = [(element.i, getattr(element, "point", getattr(element, "si", None)), 0)]
    if hasattr(element, "sj"):
        sides.append((element.j, element.sj, 1))
    histories = {side: np.zeros((result.t.size, dimension)) for _, _, side in sides}
    still = np.zeros(width)
    for k, t in enumerate(result.t):
        q, qd = result.q[k], result.qd[k]
        pair = element.forces(
            block(q, element.i, ground), block(q, element.j, ground), block(qd, element.i, still),
            block(qd, element.j, still), float(t),
        )  # fmt: skip
        for _, _, side in sides:
            histories[side][k] = pair[side][:dimension]
    return [(body, np.asarray(point, dtype=float), histories[side]) for body, point, side in sides if body >= 0]


def _least_parallel(direction: np.ndarray) -> np.ndarray:
    """The global axis least parallel to ``direction`` (an arrow head's plane in 3D)."""
    return np.eye(3)[int(np.argmin(np.abs(direction)))]


def _add_plot_axes(layout: dict, plots: list[str], axes: list[str], spatial: bool) -> None:
    """The mechanism on the left, the plots stacked on the right against one time axis."""
    split = 0.55
    if spatial:
        layout["scene"]["domain"] = {"x": [0.0, split - 0.05], "y": [0.0, 1.0]}
    else:
        layout["xaxis"]["domain"] = [0.0, split - 0.07]
    layout["xaxis2"] = {"domain": [split, 1.0], "anchor": axes[-1], "title": {"text": "t [s]"}}
    height = 1.0 / len(plots)
    for k, (name, y) in enumerate(zip(plots, axes, strict=True)):
        top = 1.0 - k * height
        layout[f"yaxis{y[1:]}"] = {
            "domain": [max(top - height + 0.06, 0.0), top],
            "anchor": "x2",
            "title": {"text": name},
        }
    layout["height"] = max(layout["height"], 200 + 160 * len(plots))


def model_view(
    model: Model, q: np.ndarray | None = None, *, before: np.ndarray | None = None, title: str | None = None
) -> View:
    """The mechanism at the coordinates q (by default as the model file places it), turnable when spatial;
    with ``before`` (e.g. the file's configuration when q is the assembled one), that configuration too, in grey."""
    geometry = mechanism_geometry(model)
    q = file_configuration(model) if q is None else np.asarray(q, dtype=float)
    states = np.vstack([q] if before is None else [q, before])
    parts, low, high = _fit(geometry, states)
    kind = _kind(geometry.dimension)
    data = []
    if before is not None:
        grey = {"mode": "lines", "line": {"color": "#b0b0b0", "width": 3, "dash": "dash"}, "hoverinfo": "skip"}
        for k, lines in enumerate(parts.at(np.asarray(before, dtype=float))[3 : 3 + len(geometry.body_names)]):
            data.append({**grey, **_trace(kind, lines), "name": "as the file places it", "showlegend": k == 0})
    data += [{**style, **_trace(kind, c)} for style, c in zip(_style(geometry, frames=True), parts.at(q), strict=True)]
    data.append(_ground(geometry))
    layout = {
        "title": {"text": title if title is not None else model.name},
        "margin": {"l": 50, "r": 20, "t": 50, "b": 40},
        **_scene_layout(geometry.dimension, low, high, np.asarray(model.gravity, dtype=float)),
    }
    return View({"data": data, "layout": {"height": 520, **layout}, "config": CONFIG})


def polyline_view(frames: list[list[np.ndarray]], labels: list[str], title: str, duration: float = 100.0) -> View:
    """Any motion drawn as polylines (planar (k, 2) or spatial (k, 3) arrays): ``frames[i]`` the lines shown at the
    slider's ``labels[i]``, one colour, equal scales, the box fitting every frame, z up."""
    dimension = frames[0][0].shape[1]
    points = np.vstack([line for lines in frames for line in lines])
    low, high = points.min(axis=0), points.max(axis=0)
    margin = 0.08 * max(float(np.max(high - low)), 1e-3)
    unit = 10.0**-DIGITS * max(float(np.max(high - low)), 1e-3)
    kind = _kind(dimension)
    style = {"type": kind, "mode": "lines", "line": {"color": COLORS[0], "width": 4}, "hoverinfo": "skip"}
    steps = [
        {"name": label, "data": [{**style, **_joined(lines, dimension, unit)}]}
        for label, lines in zip(labels, frames, strict=True)
    ]
    gravity = np.zeros(dimension)
    gravity[-1] = -1.0
    layout = {
        "title": {"text": title},
        "height": 560,
        "margin": {"l": 50, "r": 20, "t": 50, "b": 130},
        "showlegend": False,
        **_scene_layout(dimension, low - margin, high + margin, gravity),
        **_controls(labels, duration, redraw=dimension == 3),
    }
    layout["sliders"][0]["currentvalue"] = {"prefix": ""}
    return View({"data": steps[0]["data"], "layout": layout, "frames": steps, "config": CONFIG})


def animations_enabled() -> bool:
    """False while nbgrader validates a notebook (``NBGRADER_EXECUTION=validate``: only the grades count) or when
    ``MBD_ANIMATIONS=0``; while nbgrader autogrades, the views are made for the feedback page
    (``autograder/views.py``)."""
    return os.environ.get("NBGRADER_EXECUTION") != "validate" and os.environ.get("MBD_ANIMATIONS", "1") != "0"


def notebook_animation(model: Model, system, result: Result, max_frames: int = 60, **options) -> View | None:
    """The mechanism moving over a result, for a notebook cell (JupyterLab 4, classic Notebook, VS Code).

    Returns a ``View`` (the cell shows it: a slider, play/pause, a spatial scene turned with the mouse; nbgrader's
    feedback page plays it too), or None, after printing one line, while nbgrader validates (``animations_enabled``).
    ``options`` go to ``result_view`` (``speed``, ``trace``, ``plots``, ``title``).
    """
    if not animations_enabled():
        print("(animation skipped while nbgrader validates)")
        return None
    return result_view(model, system, result, max_frames=max_frames, **options)


def size_of(view: View) -> int:
    """Bytes of the figure as a notebook stores it (compact JSON)."""
    return len(view.to_json().encode())


__all__ = [
    "MIME",
    "View",
    "animations_enabled",
    "model_view",
    "notebook_animation",
    "page",
    "plotly_js",
    "polyline_view",
    "result_view",
    "size_of",
]
