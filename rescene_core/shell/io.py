"""Writing a room shell: ``shell.json`` and a top-down picture of the floor polygon over the points."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from rescene_core.capture import Capture
from rescene_core.io import read_json, write_bytes_atomic, write_json_atomic
from rescene_core.records import RoomShell

PLOT_MAX_POINTS = 60000
"""Points drawn in the top-down picture at most (a random subset, seeded)."""


def save_shell(path: str | Path, shell: RoomShell) -> Path:
    """Write ``shell.json`` atomically."""
    return write_json_atomic(path, shell.to_json())


def load_shell(path: str | Path) -> RoomShell:
    return RoomShell.from_json(read_json(path))


def plot_shell(path: str | Path, shell: RoomShell, capture: Capture | None = None) -> Path:
    """Top-down PNG: points (grey structure, coloured objects), the floor's extent with its open sides, the
    floor seen, walls with inward normals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 7), dpi=110)
    if capture is not None:
        pts, ids = capture.all_points()
        keep = np.isfinite(pts).all(axis=1)
        pts, ids = pts[keep], ids[keep]
        if len(pts) > PLOT_MAX_POINTS:
            pick = np.random.default_rng(0).choice(len(pts), PLOT_MAX_POINTS, replace=False)
            pts, ids = pts[pick], ids[pick]
        structural = np.isin(ids, [int(i.id) for i in capture.instances if i.structural])
        ax.scatter(pts[structural, 0], pts[structural, 1], s=0.3, c="0.7", label="structure points")
        ax.scatter(
            pts[~structural, 0],
            pts[~structural, 1],
            s=0.5,
            c=ids[~structural] % 20,
            cmap="tab20",
            label="object points",
        )
        cams = capture.world_from_cam[:, :3, 3]
        ax.plot(cams[:, 0], cams[:, 1], "k.", ms=3, label="cameras")
    poly = np.asarray(shell.floor_polygon + shell.floor_polygon[:1])
    ax.plot(poly[:, 0], poly[:, 1], "-", color="tab:green", lw=2, label="floor extent")
    for k in shell.open_edges():
        ax.plot(poly[k : k + 2, 0], poly[k : k + 2, 1], ":", color="tab:orange", lw=3)
    if shell.open_edges():
        ax.plot([], [], ":", color="tab:orange", lw=3, label="open side (no wall seen)")
    if shell.seen_floor_polygon is not None and shell.seen_floor_polygon != shell.floor_polygon:
        seen = np.asarray(shell.seen_floor_polygon + shell.seen_floor_polygon[:1])
        ax.plot(seen[:, 0], seen[:, 1], "--", color="tab:olive", lw=1, label="floor seen")
    for w in shell.walls:
        (x0, y0), (x1, y1) = w.segment
        ax.plot([x0, x1], [y0, y1], "-", color="tab:red", lw=3, alpha=0.7)
        mx, my = (x0 + x1) / 2, (y0 + y1) / 2
        ax.arrow(mx, my, 0.3 * w.plane.normal[0], 0.3 * w.plane.normal[1], head_width=0.08, color="tab:red")
        ax.annotate(f"wall {w.id}", (mx, my), fontsize=8)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"room shell: floor z = {-shell.floor.offset:.3f} m, {len(shell.walls)} walls")
    ax.legend(loc="upper right", fontsize=7, markerscale=5)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", bbox_inches="tight")
    plt.close(fig)
    return write_bytes_atomic(path, buf.getvalue())
