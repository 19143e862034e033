"""A picture of the scene graph over the top-down plan: floor polygon, walls, instances, parent arrows."""

from __future__ import annotations

import io

import numpy as np

from rescene_core.capture import Capture
from rescene_core.records import RoomShell, Root, SceneGraph

POINTS_PER_INSTANCE = 400
"""Points drawn per instance (uniform subsample)."""


def plot_graph(graph: SceneGraph, capture: Capture, shell: RoomShell | None, dpi: int = 110) -> bytes:
    """PNG bytes: every instance's points seen from above, an arrow from each child to its object parent,
    a square marker for floor children and a line to the nearest wall for wall children. Edge colour =
    confidence; uncertain edges dashed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 8))
    if shell is not None and len(shell.floor_polygon) >= 3:
        poly = np.asarray(shell.floor_polygon + (shell.floor_polygon[0],))
        ax.plot(poly[:, 0], poly[:, 1], color="0.6", lw=1)
        for wall in shell.walls:
            (x0, y0), (x1, y1) = wall.segment
            ax.plot([x0, x1], [y0, y1], color="0.2", lw=3)
    labels = {int(i.id): i.label for i in capture.instances}
    centre: dict[int, np.ndarray] = {}
    rng = np.random.default_rng(0)
    cmap = plt.get_cmap("RdYlGn")
    for e in graph.edges:
        pts = np.asarray(capture.point_cloud(int(e.child)).points, dtype=np.float64)
        if not len(pts):
            continue
        sub = pts[rng.choice(len(pts), min(len(pts), POINTS_PER_INSTANCE), replace=False)]
        ax.scatter(sub[:, 0], sub[:, 1], s=1, alpha=0.3)
        centre[int(e.child)] = np.median(pts[:, :2], axis=0)
    for e in graph.edges:
        c = centre.get(int(e.child))
        if c is None:
            continue
        colour = cmap(float(e.confidence))
        style = "--" if "uncertain" in e.flags else "-"
        if e.parent == Root.FLOOR:
            ax.plot(*c, marker="s", color=colour, ms=6)
        elif e.parent == Root.WALL and shell is not None and shell.walls:
            best = min(shell.walls, key=lambda w: abs(w.plane.signed_distance(np.r_[c, 0.0][None])[0]))
            n = np.asarray(best.plane.normal[:2])
            d = best.plane.signed_distance(np.r_[c, 0.0][None])[0]
            ax.plot([c[0], c[0] - d * n[0]], [c[1], c[1] - d * n[1]], style, color=colour, lw=2)
        elif not isinstance(e.parent, Root) and int(e.parent) in centre:
            p = centre[int(e.parent)]
            ax.annotate("", xy=p, xytext=c, arrowprops={"arrowstyle": "->", "color": colour, "ls": style, "lw": 1.5})
        ax.text(c[0], c[1], f"{int(e.child)} {labels.get(int(e.child), '')}", fontsize=6)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("scene graph (square: floor, line: wall, arrow: object; colour: confidence)")
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()
