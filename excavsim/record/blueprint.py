"""The default Rerun blueprint of an episode recording."""

from __future__ import annotations

import rerun.blueprint as rrb


def default_blueprint() -> rrb.Blueprint:
    """The layout a recording opens with: the world (truth and map), the feasible set, the signals."""
    world = ["+ /world/**"]

    def series(name: str, *paths: str) -> rrb.TimeSeriesView:
        return rrb.TimeSeriesView(name=name, origin="/", contents=[f"+ {p}" for p in paths])

    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                rrb.Tabs(rrb.Spatial3DView(name="world (true terrain)", origin="/world",
                                           contents=world + ["- /world/soil/scan"]),
                         rrb.Spatial3DView(name="world (scanned map)", origin="/world",
                                           contents=world + ["- /world/soil/truth"])),
                rrb.Spatial3DView(name="feasible set (k, alpha, d1)", origin="/plan"),
                row_shares=[3, 2]),
            rrb.Vertical(
                rrb.Tabs(series("F/T force [N]", "/ft/force/**", "/ft/tip/**"),
                         series("F/T moment [N m]", "/ft/torque/**"),
                         series("soil force on the bucket [N]", "/truth/**")),
                rrb.Tabs(series("actuator torque [N m]", "/torque/**"),
                         series("joint angles [deg]", "/joint_deg/**")),
                rrb.Tabs(series("soil per dig [l]", "/metrics/predicted_l", "/metrics/bucket_l", "/metrics/removed_l"),
                         series("efficiency, stalls", "/metrics/efficiency", "/metrics/stall"),
                         series("times [s]", "/wall/planning_s", "/metrics/sim_s"),
                         series("map RMS error [cm]", "/metrics/map_rms_cm")),
                rrb.Tabs(rrb.TextDocumentView(name="summary", origin="/summary"),
                         rrb.TextLogView(name="log", origin="/log"),
                         rrb.TextDocumentView(name="config", origin="/config")),
                row_shares=[2, 2, 2, 2]),
            column_shares=[3, 2]),
        rrb.TimePanel(timeline="sim_time"),
    )
