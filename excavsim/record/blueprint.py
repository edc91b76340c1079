"""The default Rerun blueprint of an episode recording.

Chosen from screenshots of the stock viewer (``excavsim replay FILE --screenshot PNG``), not from
the code: the wrist F/T spikes to ~14 kN while the servos are saturated (the park move at the start,
fast moves between digs), so the force plots have fixed ranges that show the few hundred newtons
of digging and clip those spikes (the log names each saturated interval and its peak); the per-dig
numbers and the summary grow after every dig, on ``sim_time``; the side panels start collapsed and
the 3-D camera looks at the trench.
"""

from __future__ import annotations

from collections.abc import Sequence

import rerun.blueprint as rrb

# The y ranges of the force plots: digging forces are a few hundred newtons, the moves at saturated
# servos reach ~14 kN (F) and ~4 kN m (M) and would squash them to a flat line.
DIG_FORCE_RANGE_N = (-1000.0, 1500.0)
WRIST_FORCE_RANGE_N = (-1500.0, 1500.0)
WRIST_MOMENT_RANGE_NM = (-1000.0, 1000.0)


def _series(name: str, *paths: str, y_range: tuple[float, float] | None = None) -> rrb.TimeSeriesView:
    """A time-series view of ``paths``, its legend in the top right corner (clear of the y axis)."""
    axis = rrb.ScalarAxis(range=y_range, zoom_lock=False) if y_range else None
    # the whole episode on the time axis, also for the per-dig series (one point after one dig)
    whole = rrb.TimeRange(start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.infinite())
    return rrb.TimeSeriesView(name=name, origin="/", contents=[f"+ {p}" for p in paths], axis_y=axis,
                              axis_x=rrb.TimeAxis(view_range=whole),
                              plot_legend=rrb.PlotLegend(rrb.Corner2D.RightTop, visible=True))


def default_blueprint(eye: Sequence[float] | None = None, target: Sequence[float] | None = None) -> rrb.Blueprint:
    """The layout a recording opens with: the world (truth and map), the feasible set, the signals,
    the per-dig summary.

    Args:
        eye, target: where the 3-D world views' camera starts and what it looks at [m, world frame]
            (the recorder frames the trench); None: the viewer's own choice.
    """
    world = ["+ /world/**"]
    eye_controls = (rrb.EyeControls3D(kind=rrb.Eye3DKind.Orbital, position=eye, look_target=target, eye_up=(0, 0, 1))
                    if eye is not None and target is not None else None)

    def world_view(name: str, hide: str) -> rrb.Spatial3DView:
        return rrb.Spatial3DView(name=name, origin="/world", contents=world + [f"- {hide}"],
                                 eye_controls=eye_controls)

    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                rrb.Tabs(world_view("world (true terrain)", "/world/soil/scan"),
                         world_view("world (scanned map)", "/world/soil/truth")),
                rrb.Horizontal(
                    rrb.Spatial3DView(name="feasible set (k, alpha, d1)", origin="/plan"),
                    rrb.Tabs(rrb.TextDocumentView(name="summary", origin="/summary"),
                             rrb.TextLogView(name="log", origin="/log"),
                             rrb.TextDocumentView(name="how to read", origin="/notes"),
                             rrb.TextDocumentView(name="config", origin="/config")),
                    column_shares=[2, 3]),
                row_shares=[3, 2]),
            rrb.Vertical(
                rrb.Tabs(_series("forces while digging [N]", "/ft/tip/**", "/truth/**", y_range=DIG_FORCE_RANGE_N),
                         _series("wrist F [N], clipped", "/ft/force/**", y_range=WRIST_FORCE_RANGE_N),
                         _series("wrist M [N m], clipped", "/ft/torque/**", y_range=WRIST_MOMENT_RANGE_NM)),
                rrb.Tabs(_series("actuator torque [N m]", "/torque/**"),
                         _series("joint angles [deg]", "/joint_deg/**")),
                rrb.Tabs(_series("soil [l]", "/metrics/predicted_l", "/metrics/bucket_l", "/metrics/removed_l"),
                         _series("efficiency, stalls", "/metrics/efficiency", "/metrics/stall"),
                         _series("times [s]", "/wall/planning_s", "/metrics/sim_s"),
                         _series("map error [cm]", "/metrics/map_rms_cm")),
                row_shares=[3, 2, 2]),
            column_shares=[3, 2]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(timeline="sim_time", state="collapsed"),
    )
