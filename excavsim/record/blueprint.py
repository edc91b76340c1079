"""The layouts recordings open with (Rerun blueprints), in a small vocabulary, and the trench's.

A task's recorder (:meth:`~excavsim.record.base.EpisodeRecorder.blueprint`) builds its layout from
:func:`world_view`, :func:`series_view`, :func:`document_view`, :func:`log_view`, :func:`tabs`,
:func:`row`, :func:`column` and :func:`layout` without importing rerun. Every layout starts with its
side panels collapsed and, unless a series view says otherwise, the time axis following the cursor.

:func:`default_blueprint` is trenching's, chosen from screenshots of the stock viewer (``excavsim replay
FILE --screenshot PNG``), not from the code: the T3's wrist F/T spikes to ~14 kN while the servos are
saturated (the park move at the start, fast moves between digs), so the force plots have fixed ranges
that show the few hundred newtons of digging and clip those spikes (the log names each saturated
interval and its peak); the per-dig numbers and the summary grow after every dig, on ``sim_time``; the
3-D camera looks at the trench.
"""

from __future__ import annotations

from collections.abc import Sequence

import rerun.blueprint as rrb

# The y ranges of the T3's force plots: digging forces are a few hundred newtons, the moves at saturated
# servos reach ~14 kN (F) and ~4 kN m (M) and would squash them to a flat line.
DIG_FORCE_RANGE_N = (-1000.0, 1500.0)
WRIST_FORCE_RANGE_N = (-1500.0, 1500.0)
WRIST_MOMENT_RANGE_NM = (-1000.0, 1000.0)


def world_view(name: str, *, origin: str = "/world", hide: Sequence[str] = (), eye: Sequence[float] | None = None,
               target: Sequence[float] | None = None) -> rrb.Spatial3DView:
    """A 3-D view of ``origin`` and below, without the entities ``hide``; the camera starts at ``eye``
    looking at ``target`` [m, world frame] (None: the viewer's own choice)."""
    eye_controls = (rrb.EyeControls3D(kind=rrb.Eye3DKind.Orbital, position=eye, look_target=target, eye_up=(0, 0, 1))
                    if eye is not None and target is not None else None)
    contents = [f"+ {origin}/**", *(f"- {h}" for h in hide)] if hide else "$origin/**"
    return rrb.Spatial3DView(name=name, origin=origin, contents=contents, eye_controls=eye_controls)


def series_view(name: str, *paths: str, y_range: tuple[float, float] | None = None,
                whole: bool = False) -> rrb.TimeSeriesView:
    """A time-series view of ``paths`` (``/metrics/cost``, ``/joint_deg/**``), its legend in the top right
    corner (clear of the y axis); a fixed ``y_range``; with ``whole`` the time axis shows the whole
    recording (a series of one point per dig or pass), else it follows the time cursor."""
    axis = rrb.ScalarAxis(range=y_range, zoom_lock=False) if y_range else None
    every = rrb.TimeRange(start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.infinite())
    return rrb.TimeSeriesView(name=name, origin="/", contents=[f"+ {p}" for p in paths], axis_y=axis,
                              axis_x=rrb.TimeAxis(view_range=every) if whole else None,
                              plot_legend=rrb.PlotLegend(rrb.Corner2D.RightTop, visible=True))


def document_view(name: str, origin: str) -> rrb.TextDocumentView:
    """A markdown document (``/summary``, ``/config``)."""
    return rrb.TextDocumentView(name=name, origin=origin)


def log_view(name: str = "log", origin: str = "/log") -> rrb.TextLogView:
    """The text log."""
    return rrb.TextLogView(name=name, origin=origin)


def view_3d(name: str, origin: str) -> rrb.Spatial3DView:
    """A 3-D view of a space that is not the world (the planner's feasible set)."""
    return rrb.Spatial3DView(name=name, origin=origin)


def tabs(*views) -> rrb.Tabs:
    """Views as tabs, one shown at a time."""
    return rrb.Tabs(*views)


def row(*views, shares: Sequence[float] | None = None) -> rrb.Horizontal:
    """Views side by side, their widths in the proportions ``shares``."""
    return rrb.Horizontal(*views, column_shares=shares)


def column(*views, shares: Sequence[float] | None = None) -> rrb.Vertical:
    """Views one above the other, their heights in the proportions ``shares``."""
    return rrb.Vertical(*views, row_shares=shares)


def layout(root, *, timeline: str = "sim_time") -> rrb.Blueprint:
    """The whole layout: ``root`` with the side panels and the time panel (on ``timeline``) collapsed."""
    return rrb.Blueprint(root, rrb.BlueprintPanel(state="collapsed"), rrb.SelectionPanel(state="collapsed"),
                         rrb.TimePanel(timeline=timeline, state="collapsed"))


def default_blueprint(eye: Sequence[float] | None = None, target: Sequence[float] | None = None, *,
                      fixed_ranges: bool = True) -> rrb.Blueprint:
    """Trenching's layout: the world (truth and map), the feasible set, the signals, the per-dig summary.

    Args:
        eye, target: where the 3-D world views' camera starts and what it looks at [m, world frame]
            (the recorder frames the trench); None: the viewer's own choice.
        fixed_ranges: the force plots on the T3's fixed ranges (see the module docstring); False: on
            the data's own (a machine with other forces).
    """
    def fixed(r):
        return r if fixed_ranges else None

    return layout(row(
        column(
            tabs(world_view("world (true terrain)", hide=["/world/soil/scan"], eye=eye, target=target),
                 world_view("world (scanned map)", hide=["/world/soil/truth"], eye=eye, target=target)),
            row(view_3d("feasible set (k, alpha, d1)", "/plan"),
                tabs(document_view("summary", "/summary"), log_view(), document_view("how to read", "/notes"),
                     document_view("config", "/config")),
                shares=[2, 3]),
            shares=[3, 2]),
        column(
            tabs(series_view("forces while digging [N]", "/ft/tip/**", "/truth/**", y_range=fixed(DIG_FORCE_RANGE_N),
                             whole=True),
                 series_view("wrist F [N], clipped", "/ft/force/**", y_range=fixed(WRIST_FORCE_RANGE_N), whole=True),
                 series_view("wrist M [N m], clipped", "/ft/torque/**", y_range=fixed(WRIST_MOMENT_RANGE_NM),
                             whole=True)),
            tabs(series_view("actuator torque [N m]", "/torque/**", whole=True),
                 series_view("joint angles [deg]", "/joint_deg/**", whole=True)),
            tabs(series_view("soil [l]", "/metrics/predicted_l", "/metrics/bucket_l", "/metrics/removed_l", whole=True),
                 series_view("efficiency, stalls", "/metrics/efficiency", "/metrics/stall", whole=True),
                 series_view("times [s]", "/wall/planning_s", "/metrics/sim_s", whole=True),
                 series_view("map error [cm]", "/metrics/map_rms_cm", whole=True)),
            shares=[3, 2, 2]),
        shares=[3, 2]))
