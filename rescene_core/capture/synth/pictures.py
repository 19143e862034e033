"""Pictures of a synthetic capture for people: a contact sheet of frames with coloured instance masks, and
a top-down plan with the ground-truth relations drawn as arrows.

Both are written next to the capture: ``room.zarr`` -> ``room_contact.png`` and ``room_plan.png``.
"""

from __future__ import annotations

import colorsys
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from PIL import Image, ImageDraw

from rescene_core.records import Relation, Root


def picture_paths(capture_path: str | Path) -> dict[str, Path]:
    """Where the pictures of the capture at ``capture_path`` go: {"contact_sheet": ..., "plan": ...}."""
    p = Path(capture_path)
    stem = p.name[: -len(".zarr")] if p.name.endswith(".zarr") else p.name
    return {"contact_sheet": p.parent / f"{stem}_contact.png", "plan": p.parent / f"{stem}_plan.png"}


def instance_colors(max_id: int) -> NDArray[np.uint8]:
    """A distinct, deterministic RGB colour per instance id [max_id + 1, 3] (id 0 black)."""
    out = np.zeros((max_id + 1, 3), np.uint8)
    for i in range(1, max_id + 1):
        h = (i * 0.618033988749895) % 1.0
        r, g, b = colorsys.hsv_to_rgb(h, 0.75, 0.95)
        out[i] = (int(r * 255), int(g * 255), int(b * 255))
    return out


def overlay(
    rgb: NDArray[np.uint8],
    ids: NDArray[np.int32],
    colors: NDArray[np.uint8],
    alpha: float = 0.45,
    faint: set[int] | None = None,
):
    """RGB [H, W, 3] with each instance tinted by its colour and mask boundaries drawn dark.

    faint: ids tinted only lightly (structure), so the objects stand out.
    """
    tint = colors[np.clip(ids, 0, len(colors) - 1)].astype(np.float32)
    a = np.full(ids.shape, alpha, np.float32)
    if faint:
        a[np.isin(ids, list(faint))] = alpha * 0.25
    a[ids == 0] = 0.0
    out = rgb.astype(np.float32) * (1 - a[..., None]) + tint * a[..., None]
    edge = np.zeros(ids.shape, bool)
    edge[:, 1:] |= ids[:, 1:] != ids[:, :-1]
    edge[1:] |= ids[1:] != ids[:-1]
    out[edge] *= 0.25
    return out.astype(np.uint8)


def contact_sheet(scene, frames: int = 12, columns: int = 4, tile_width: int = 320) -> Image.Image:
    """Frames spread over the capture (walk, close-ups and distant views), masks tinted and labelled."""
    a = scene.arrays
    T, H, W = a.instance_masks.shape
    kinds = scene.plan.kinds
    picks = list(np.linspace(0, T - 1, frames).round().astype(int))
    for kind in ("closeup", "distant"):
        idx = [t for t in range(T) if kinds[t] == kind]
        if idx and not any(kinds[t] == kind for t in picks):
            picks[-1 if kind == "closeup" else -2] = idx[len(idx) // 2]
    picks = sorted(set(int(t) for t in picks))
    labels = {int(i.id): i.label for i in a.instances}
    colors = instance_colors(int(max(labels)) if labels else 1)
    structural = {int(i.id) for i in a.instances if i.structural}
    scale = tile_width / W
    tw, th = tile_width, int(round(H * scale))
    rows = (len(picks) + columns - 1) // columns
    sheet = Image.new("RGB", (columns * tw, rows * (th + 14)), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    for k, t in enumerate(picks):
        ids = a.instance_masks[t]
        img = Image.fromarray(overlay(a.rgb[t], ids, colors, faint=structural)).resize(
            (tw, th), Image.Resampling.BILINEAR
        )
        x0, y0 = (k % columns) * tw, (k // columns) * (th + 14)
        sheet.paste(img, (x0, y0 + 14))
        draw.text((x0 + 3, y0 + 1), f"frame {t} ({kinds[t]})", fill=(0, 0, 0))
        counts = np.bincount(ids.ravel())
        ys, xs = np.indices(ids.shape)
        for i in np.flatnonzero(counts > max(30, ids.size // 400)):
            if i == 0 or labels.get(int(i)) in (None, "wall", "floor", "ceiling"):
                continue
            m = ids == i
            cy, cx = float(ys[m].mean()), float(xs[m].mean())
            text = f"{i}:{labels[int(i)]}"
            px, py = x0 + cx * scale, y0 + 14 + cy * scale
            draw.rectangle([px - 2, py - 6, px + 6 * len(text), py + 6], fill=(255, 255, 255))
            draw.text((px, py - 6), text, fill=(0, 0, 0))
    return sheet


def plan_figure(scene, path: Path) -> None:
    """Top-down plan: walls with ids, object footprints by category, GT relations as arrows, cameras."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Polygon as MplPolygon

    lay, gt = scene.layout, scene.gt
    fig, ax = plt.subplots(figsize=(9, 8), dpi=110)
    floor = np.asarray(gt.shell.floor_polygon)
    ax.add_patch(MplPolygon(floor, closed=True, facecolor=(0.93, 0.9, 0.85), edgecolor="none"))
    for wall in gt.shell.walls:
        (x0, y0), (x1, y1) = wall.segment
        ax.plot([x0, x1], [y0, y1], color="0.2", lw=4, solid_capstyle="round")
        n = np.asarray(wall.plane.normal[:2])
        mx, my = (x0 + x1) / 2 - n[0] * 0.18, (y0 + y1) / 2 - n[1] * 0.18
        ax.text(mx, my, f"wall {wall.id}", ha="center", va="center", fontsize=7, color="0.3")
    labels = sorted({o.label for o in lay.objects})
    cmap = plt.get_cmap("tab20")
    color_of = {lab: cmap(k % 20) for k, lab in enumerate(labels)}
    centre = {}
    order = sorted(lay.objects, key=lambda o: o.z0)
    for o in order:
        xy = np.asarray(o.footprint.exterior.coords)
        on_floor = o.relation == Relation.RESTS_ON and o.parent == Root.FLOOR
        ax.add_patch(
            MplPolygon(
                xy,
                closed=True,
                facecolor=color_of[o.label],
                edgecolor="k",
                lw=0.6 if on_floor else 1.0,
                alpha=0.85 if on_floor else 0.95,
                zorder=2 + o.z0,
            )
        )
        c = np.asarray(o.footprint.centroid.coords[0])
        centre[o.object_id] = c
        ax.text(c[0], c[1], f"{o.object_id}", ha="center", va="center", fontsize=6, zorder=10, color="k")
    for rel in gt.relations:
        c = centre[rel.child]
        if rel.relation == Relation.MOUNTS_ON:
            wall = gt.shell.walls[rel.wall_id]
            n = np.asarray(wall.plane.normal[:2])
            d = float(np.asarray(wall.plane.normal) @ np.array([c[0], c[1], 0.0]) + wall.plane.offset)
            tip = c - n * d
            start = c + n * 0.35
            ax.annotate("", tip, start, arrowprops=dict(arrowstyle="->", color="tab:blue", lw=1.2), zorder=11)
        elif isinstance(rel.parent, Root):
            ax.plot(*c, marker="o", ms=3, color="tab:green", zorder=11)
        else:
            p = centre[int(rel.parent)]
            start = c if np.linalg.norm(p - c) > 0.05 else c + np.array([0.2, 0.2])
            ax.annotate(
                "",
                p,
                start + (start - p) * 0.0 + np.array([0.12, 0.12]),
                arrowprops=dict(arrowstyle="->", color="tab:red", lw=1.2),
                zorder=11,
            )
    cams = scene.plan.world_from_cam
    kinds = scene.plan.kinds
    walk = np.array([cams[t][:2, 3] for t in range(len(kinds)) if kinds[t] in ("walk", "head")])
    if len(walk):
        ax.plot(walk[:, 0], walk[:, 1], "-", color="0.5", lw=0.6, zorder=12)
    for t in range(len(kinds)):
        p, fwd = cams[t][:2, 3], cams[t][:2, 2]
        color = {"walk": "0.35", "closeup": "tab:orange", "distant": "tab:purple", "head": "tab:cyan"}[kinds[t]]
        ax.annotate("", p + fwd * 0.25, p, arrowprops=dict(arrowstyle="-|>", color=color, lw=0.6), zorder=12)
    handles = [plt.Line2D([], [], color=color_of[lab], marker="s", ls="", ms=8, label=lab) for lab in labels]
    handles += [
        plt.Line2D([], [], color="tab:red", label="rests-on object (child -> parent)"),
        plt.Line2D([], [], color="tab:blue", label="mounts-on wall"),
        plt.Line2D([], [], color="tab:green", marker="o", ls="", label="rests-on floor"),
        plt.Line2D([], [], color="tab:orange", label="close-up camera"),
        plt.Line2D([], [], color="tab:purple", label="distant camera"),
        plt.Line2D([], [], color="0.35", label="walk camera"),
    ]
    if "head" in kinds:
        handles.append(plt.Line2D([], [], color="tab:cyan", label="head-mounted camera"))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)
    ax.set_aspect("equal")
    x0, y0 = floor.min(0) - 0.3
    x1, y1 = floor.max(0) + 0.3
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{scene.arrays.scene_id}: {len(gt.objects)} objects, ceiling {gt.shell.ceiling_height:.2f} m")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def write_pictures(capture_path: str | Path, scene) -> dict[str, Path]:
    """Write the contact sheet and the plan next to the capture; returns their paths."""
    paths = picture_paths(capture_path)
    tile = min(320, scene.arrays.rgb.shape[2] * 2)
    contact_sheet(scene, tile_width=tile).save(paths["contact_sheet"])
    plan_figure(scene, paths["plan"])
    return paths
