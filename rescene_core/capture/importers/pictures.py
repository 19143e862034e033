"""Pictures of an imported capture for people: the segments over frames (a contact sheet) and a top-down
plan of the instance clouds with the camera path, in the aligned frame.

Written next to the capture: ``room.zarr`` -> ``room_contact.png`` and ``room_plan.png``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from rescene_core.capture.format import Capture
from rescene_core.capture.synth.pictures import instance_colors, overlay, picture_paths
from rescene_core.capture.validate import open_capture


def contact_sheet(capture: Capture, frames: int = 12, columns: int = 4, tile_width: int = 320) -> Image.Image:
    """Frames spread over the capture with every instance mask tinted and each object's id and label."""
    T = capture.num_frames
    W, H = capture.image_size
    picks = sorted({int(t) for t in np.linspace(0, T - 1, min(frames, T)).round()})
    labels = {int(i.id): i.label for i in capture.instances}
    colors = instance_colors(max(labels, default=1))
    structural = {int(i.id) for i in capture.instances if i.structural}
    scale = tile_width / W
    tw, th = tile_width, int(round(H * scale))
    rows = (len(picks) + columns - 1) // columns
    sheet = Image.new("RGB", (columns * tw, rows * (th + 14)), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    ys, xs = np.indices((H, W))
    for k, t in enumerate(picks):
        ids = np.asarray(capture.instance_masks[t])
        img = Image.fromarray(overlay(np.asarray(capture.rgb[t]), ids, colors, faint=structural))
        x0, y0 = (k % columns) * tw, (k // columns) * (th + 14)
        sheet.paste(img.resize((tw, th), Image.Resampling.BILINEAR), (x0, y0 + 14))
        draw.text((x0 + 3, y0 + 1), f"frame {t}", fill=(0, 0, 0))
        counts = np.bincount(ids.ravel())
        for i in np.flatnonzero(counts > max(30, ids.size // 400)):
            if i == 0 or int(i) in structural:
                continue
            m = ids == i
            text = f"{i}:{labels.get(int(i), '?')}"
            px, py = x0 + float(xs[m].mean()) * scale, y0 + 14 + float(ys[m].mean()) * scale
            draw.rectangle([px - 2, py - 6, px + 6 * len(text), py + 6], fill=(255, 255, 255))
            draw.text((px, py - 6), text, fill=(0, 0, 0))
    return sheet


def plan_figure(capture: Capture, path: Path) -> None:
    """Top-down plan: structure points grey, object clouds coloured with their ids, the camera path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pts, ids = capture.all_points()
    structural = {int(i.id) for i in capture.instances if i.structural}
    labels = {int(i.id): i.label for i in capture.instances}
    colors = instance_colors(max(labels, default=1)) / 255.0
    fig, ax = plt.subplots(figsize=(9, 8), dpi=110)
    st = np.isin(ids, list(structural))
    ax.scatter(pts[st, 0], pts[st, 1], s=0.3, c="0.75", label="floor / wall points")
    for i in sorted(set(ids[~st].tolist())):
        p = pts[ids == i]
        ax.scatter(p[:, 0], p[:, 1], s=0.6, color=colors[i])
        c = p.mean(axis=0)
        ax.text(c[0], c[1], f"{i}:{labels.get(i, '?')}", fontsize=6, ha="center", va="center")
    cams = capture.world_from_cam
    ax.plot(cams[:, 0, 3], cams[:, 1, 3], "-", color="0.3", lw=0.8, label="camera path")
    for t in range(0, len(cams), max(1, len(cams) // 40)):
        p, fwd = cams[t, :2, 3], cams[t, :2, 2]
        ax.annotate("", p + fwd * 0.25, p, arrowprops=dict(arrowstyle="-|>", color="tab:orange", lw=0.6))
    al = capture.attrs.get("alignment", {})
    how = (
        "NO FLOOR FOUND, up from the cameras" if al.get("method") == "cameras" else f"floor by {al.get('method', '?')}"
    )
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)
    ax.set_title(
        f"{capture.scene_id} ({capture.source}): {len(capture.object_instances)} objects; "
        f"{how}, {al.get('floor_to_camera_up_deg', float('nan')):.2f} deg from camera up",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def write_pictures(capture_path: str | Path) -> dict[str, Path]:
    """Write the contact sheet (segments over frames) and the plan next to the capture; their paths."""

    capture = open_capture(capture_path, validate=False)
    paths = picture_paths(capture_path)
    contact_sheet(capture, tile_width=min(320, capture.image_size[0] * 2)).save(paths["contact_sheet"])
    plan_figure(capture, paths["plan"])
    return paths
