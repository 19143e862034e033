"""``RUN/eval/report.html``: one self-contained page per run that opens offline in any browser.

Inside: the assembled scene in an interactive 3D viewer (``@google/model-viewer``, its module script
inlined from ``node_modules/@google/model-viewer/dist/model-viewer.min.js``; the scene as a GLB ``data:``
URL, +Y up as glTF wants, walls cut low so that the furniture shows from outside), the plan (the fused
graph over the top-down plan), a contact sheet of the key frames, before / after (registered vs attached)
views, rendered vs captured frames, the metrics tables, one row per object with its problems, the
physics check (``sim/simcheck.json``, or "not run"; Newton's beside it with the objects where the two engines
disagree, when ``sim/simcheck-newton.json`` exists), and what was not computed and why.
Nothing is fetched at view time: every image is a data: URL.
"""

from __future__ import annotations

import base64
import html
import io
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from PIL import Image

from rescene_core.capture import open_capture
from rescene_core.evaluation.judge import scene_views
from rescene_core.evaluation.rendering import _mean_color, scaled, scene_render_meshes
from rescene_core.evaluation.scene import LoadedScene, load_scene, placed_meshes
from rescene_core.export import ExportConfig, node_name, shell_meshes
from rescene_core.io import read_json, write_bytes_atomic
from rescene_core.paths import RunPaths
from rescene_core.render import Renderer, Shading

MODEL_VIEWER_ENV = "RESCENE_MODEL_VIEWER_JS"
"""Path of model-viewer.min.js, when not under the repository's node_modules."""
WALL_CUT_M = 0.4
"""Walls are cut to this height in the viewer's scene (m)."""


def model_viewer_js() -> str | None:
    """The model-viewer module script, or None when it is not installed (`npm install` at the repo root)."""
    candidates = [os.environ.get(MODEL_VIEWER_ENV)] if os.environ.get(MODEL_VIEWER_ENV) else []
    root = Path(__file__).resolve().parents[2]
    candidates.append(str(root / "node_modules" / "@google" / "model-viewer" / "dist" / "model-viewer.min.js"))
    for c in candidates:
        if c and Path(c).is_file():
            return Path(c).read_text(encoding="utf-8")
    return None


def _data_url(data: bytes, mime: str) -> str:
    return f"data:{mime};base64,{base64.b64encode(data).decode('ascii')}"


def _jpeg(rgb: np.ndarray, width: int | None = None) -> str:

    img = Image.fromarray(np.ascontiguousarray(rgb, np.uint8)).convert("RGB")
    if width and img.width > width:
        img = img.resize((width, max(1, round(img.height * width / img.width))), Image.Resampling.BILINEAR)
    buf = io.BytesIO()
    img.save(buf, format="JPEG", quality=85)
    return _data_url(buf.getvalue(), "image/jpeg")


def _png_file(path: Path, width: int | None = None) -> str | None:
    if not path.exists():
        return None

    try:
        return _jpeg(np.asarray(Image.open(path).convert("RGB")), width)
    except OSError:
        return None


def _paint(mesh: trimesh.Trimesh, rgba: np.ndarray) -> None:
    """One RGBA colour (uint8 [4]) on every face; a textured mesh gets plain face colours for the viewer."""
    colors = np.tile(rgba, (len(mesh.faces), 1))
    if isinstance(mesh.visual, trimesh.visual.ColorVisuals):
        mesh.visual.face_colors = colors
    else:
        mesh.visual = trimesh.visual.ColorVisuals(mesh, face_colors=colors)


def viewer_glb(
    placed: Mapping[int, tuple[str, trimesh.Trimesh]],
    shell: Mapping[str, trimesh.Trimesh],
    colors: Mapping[int, tuple[float, float, float]],
) -> bytes:
    """The scene for the viewer: objects (world frame) coloured, the floor, and walls cut to WALL_CUT_M,
    rotated from the world's +Z up to glTF's +Y up."""
    scene = trimesh.Scene()
    y_up = trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0])
    for i, (label, mesh) in sorted(placed.items()):
        m = mesh.copy()
        rgba = np.array([*colors.get(i, (0.6, 0.6, 0.6)), 1.0]) * 255
        _paint(m, rgba.astype(np.uint8))
        m.apply_transform(y_up)
        scene.add_geometry(m, node_name=node_name(i, label))
    for name, mesh in sorted(shell.items()):
        m = mesh.copy()
        if name != "shell_floor":
            floor_z = float(m.bounds[0][2])
            m = trimesh.intersections.slice_mesh_plane(m, [0, 0, -1], [0, 0, floor_z + WALL_CUT_M], cap=True)
            color = (200, 200, 195, 255)
        else:
            color = (150, 120, 95, 255)
        if len(m.faces) == 0:
            continue
        _paint(m, np.array(color, np.uint8))
        m.apply_transform(y_up)
        scene.add_geometry(m, node_name=name)
    return scene.export(file_type="glb")


def _fmt(v: Any, digits: int = 4) -> str:
    if v is None:
        return "n/a"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.{digits}g}"
    return html.escape(str(v))


def _table(header: list[str], rows: list[list[Any]], cls: str = "") -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{_fmt(c)}</td>" for c in r) + "</tr>" for r in rows)
    return f'<table class="{cls}"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


def _object_rows(metrics: dict[str, Any], doc: LoadedScene | None) -> list[list[Any]]:
    st = metrics.get("structural", {})
    oob = set(st.get("oob_objects", []))
    colliding: dict[int, list[int]] = {}
    for a, b in st.get("colliding", []):
        colliding.setdefault(a, []).append(b)
        colliding.setdefault(b, []).append(a)
    failures = st.get("contact_failures", {})
    geo = metrics.get("geometry", {})
    geo_rows = {r["instance"]: r for r in geo.get("ground_truth", {}).get("per_object", [])}
    sensor_rows = {r["instance"]: r for r in geo.get("sensor", {}).get("per_object", [])}
    iou = {r["instance"]: r["iou"] for r in metrics.get("rendering", {}).get("per_object", [])}
    rows = []
    for o in doc.scene.objects if doc is not None else ():
        i = int(o.instance)
        problems = []
        if i in oob:
            problems.append("out of the room")
        if i in colliding:
            problems.append("collides with " + ", ".join(str(j) for j in sorted(colliding[i])))
        problems += [f"{kind} contact fails" for kind, ids in failures.items() if i in ids]
        g = geo_rows.get(i, {}).get("sampled") or {}
        s = sensor_rows.get(i, {}).get("refused") or {}
        rows.append(
            [
                i,
                o.label,
                f"{o.relation or '-'} {o.parent if o.parent is not None else ''}",
                g.get("chamfer"),
                g.get("fscore@5cm"),
                s.get("chamfer"),
                iou.get(i),
                "; ".join(problems) or "none",
            ]
        )
    for m in metrics.get("missing_records", []):
        rows.append([m.get("instance"), "", "missing", None, None, None, None, f"{m.get('stage')}: {m.get('reason')}"])
    return rows


def _physics(metrics: dict[str, Any]) -> str:
    sim = metrics.get("physics")
    if not sim:
        reason = metrics.get("not_computed", {}).get("physics", "not run")
        return f'<p class="notrun">Physics check: not run ({html.escape(reason)}).</p>'
    flat = [[k, v] for k, v in sim.items() if isinstance(v, int | float | str | bool) or v is None]
    out = _table(["field", "value"], flat)
    for key, value in sim.items():
        if isinstance(value, list) and value and isinstance(value[0], dict):
            cols = list(dict.fromkeys(k for row in value for k in row))[:8]
            out += f"<h3>{html.escape(key)}</h3>" + _table(cols, [[row.get(c) for c in cols] for row in value])
    return out


def _physics_newton(metrics: dict[str, Any]) -> str:
    """Newton's check of the USD beside MuJoCo's: both stable fractions, then each object they disagree on
    with both drifts and the reasons the comparison found."""
    newton = metrics.get("physics_newton")
    if not newton:
        reason = metrics.get("not_computed", {}).get("physics_newton", "not run")
        return f'<p class="notrun">Newton check: not run ({html.escape(reason)}).</p>'
    s_newton = newton.get("summary", {})
    s_mujoco = (metrics.get("physics") or {}).get("summary", {})
    rows = [
        [engine, s.get("stable"), s.get("free"), s.get("stable_fraction"), s.get("penetration_t0_max")]
        for engine, s in (("MuJoCo (scene/mjcf/scene.xml)", s_mujoco), ("Newton (scene/scene.usda)", s_newton))
        if s
    ]
    out = _table(["engine", "stable", "free objects", "stable fraction", "t=0 penetration max (m)"], rows)
    differ = newton.get("disagreements")
    if differ is None:
        return out + "<p>No comparison: the MuJoCo check is missing or ran with other settings.</p>"
    if not differ:
        return out + "<p>The two engines agree on every free object.</p>"
    out += f"<h3>Where the engines disagree ({len(differ)})</h3>"
    return out + _table(
        ["object", "MuJoCo drift (m)", "Newton drift (m)", "why"],
        [
            [d.get("node"), d.get("drift_mujoco"), d.get("drift_newton"), "; ".join(d.get("reasons", []))]
            for d in differ
        ],
    )


def _scene_table(metrics: dict[str, Any]) -> str:
    geo = metrics.get("geometry", {})
    rows = []
    for ref, modes in (
        ("ground_truth", ("sampled", "refused")),
        ("sensor", ("objects_sampled", "objects_refused", "all_refused")),
    ):
        for mode in modes:
            m = geo.get(ref, {}).get(mode)
            if m:
                rows.append(
                    [
                        ref.replace("_", " "),
                        mode,
                        m["accuracy"],
                        m["completion"],
                        m["chamfer"],
                        m["precision@5cm"],
                        m["recall@5cm"],
                        m["fscore@5cm"],
                        m["normal_consistency"],
                    ]
                )
    if not rows:
        return '<p class="notrun">No geometry metrics (see "not computed").</p>'
    return _table(["reference", "mode", "accuracy (m)", "completion (m)", "CD (m)", "P@5", "R@5", "F@5", "NC"], rows)


def _rendering_table(metrics: dict[str, Any]) -> str:
    r = metrics.get("rendering")
    if not r or "psnr" not in r:
        return '<p class="notrun">No rendering metrics (see "not computed").</p>'
    d = r.get("depth") or {}
    rows = [
        ["frames (non-key)", len(r.get("frames", []))],
        ["image size", f"{r['image_size'][0]} x {r['image_size'][1]}"],
        ["PSNR masked (dB)", r["psnr_masked"]],
        ["SSIM masked", r["ssim_masked"]],
        ["PSNR full frame (dB)", r["psnr"]],
        ["SSIM full frame", r["ssim"]],
        ["LPIPS", r["lpips"] if r.get("lpips") is not None else "not run"],
        ["mask IoU, mean over placed objects", r["mask_iou_mean_placed"]],
        ["mask IoU, mean over all capture objects", r["mask_iou_mean_all"]],
        ["depth AbsRel", d.get("abs_rel")],
        ["depth RMSE (m)", d.get("rmse")],
        ["depth delta < 1.25", d.get("delta_1.25")],
    ]
    return _table(["metric", "value"], rows)


def _judge(metrics: dict[str, Any]) -> str:
    j = metrics.get("judge") or {}
    if j.get("status") != "ok":
        return f'<p class="notrun">Perceptual judge: {html.escape(j.get("status", "not run"))} ({html.escape(str(j.get("reason", "")))}).</p>'
    rows = [[a, j["scores"][a], j["comments"][a]] for a in j["scores"]]
    return f"<p>model {html.escape(str(j.get('model')))}</p>" + _table(["axis", "score (1-5)", "comment"], rows)


def _figures(run_dir: Path, metrics: dict[str, Any], doc: LoadedScene | None, capture: Any) -> dict[str, str]:
    """Images of the page as data: URLs (each one skipped when its input is missing)."""
    out: dict[str, str] = {}
    plan = _png_file(RunPaths(run_dir).graph_png, 900)
    if plan:
        out["plan"] = plan
    frames_dir = RunPaths(run_dir).frame_png(0).parent
    frames = sorted(frames_dir.glob("*.png"), key=lambda p: (len(p.stem), p.stem)) if frames_dir.exists() else []
    sheet = [u for u in (_png_file(p, 240) for p in frames[:24]) if u]
    for k, url in enumerate(sheet):
        out[f"sheet_{k}"] = url
    if doc is None or capture is None or not doc.scene.objects:
        return out

    shell = shell_meshes(doc.scene.shell, ExportConfig()) if doc.scene.shell is not None else {}
    after = placed_meshes(doc)
    before = placed_meshes(doc, {**doc.final_poses(), **doc.registered_poses()})
    for name, placed in (("before", before), ("after", after)):
        views = scene_views(placed, shell, capture, 1, 480, 360, 75.0)
        if views:
            out[name] = _jpeg(views[0])
    r = metrics.get("rendering") or {}
    if r.get("frames"):
        renderer = Renderer(scene_render_meshes(after, shell, capture), Shading(lights=(), ambient=1.0, gamma=1.0))
        pick = r["frames"][:: max(1, len(r["frames"]) // 3)][:3]
        for k, t in enumerate(pick):
            cam = scaled(capture.camera(t), 0.5)
            out[f"pair_{k}_captured"] = _jpeg(np.asarray(capture.rgb[t]), 320)
            out[f"pair_{k}_rendered"] = _jpeg(renderer.render(cam).rgb, 320)
            out[f"pair_{k}_frame"] = str(t)
    return out


CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:0 auto;max-width:1200px;padding:1em;color:#222}
h1{font-size:1.5em}h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:1.6em}
table{border-collapse:collapse;margin:.5em 0;font-size:.9em}td,th{border:1px solid #ddd;padding:3px 8px;text-align:left}
th{background:#f3f3f3}model-viewer{width:100%;height:560px;background:#eef1f4}
.grid img{width:240px;margin:2px}.pair{display:inline-block;margin:4px;text-align:center}.pair img{width:320px;display:block}
.notrun{color:#8a5a00}.muted{color:#666;font-size:.9em}
"""


def render_report_html(run_dir: str | Path, metrics: dict[str, Any], capture: Any | None = None) -> str:
    """The page (a string) for a run and its metrics."""

    run_dir = Path(run_dir)
    try:
        doc: LoadedScene | None = load_scene(run_dir)
    except FileNotFoundError:
        doc = None
    if capture is None and metrics.get("capture") and Path(metrics["capture"]).exists():
        capture = open_capture(metrics["capture"], validate=False)
    figs = _figures(run_dir, metrics, doc, capture)
    parts = [
        "<!doctype html><html lang='en'><head><meta charset='utf-8'>",
        f"<title>ReScene evaluation: {html.escape(run_dir.name)}</title><style>{CSS}</style>",
    ]
    js = model_viewer_js()
    viewer = ""
    if doc is not None and doc.scene.objects and js is not None:
        placed = placed_meshes(doc)
        shell = shell_meshes(doc.scene.shell, ExportConfig()) if doc.scene.shell is not None else {}
        colors = {i: (_mean_color(capture, [i]) if capture is not None else None) or (0.6, 0.6, 0.6) for i in placed}
        glb = viewer_glb(placed, shell, colors)
        parts.append("<script type='module'>" + js.replace("</script", "<\\/script") + "</script>")
        viewer = (
            f"<model-viewer src='{_data_url(glb, 'model/gltf-binary')}' alt='assembled scene' camera-controls "
            "camera-orbit='30deg 55deg auto' shadow-intensity='0.6' exposure='1.1'></model-viewer>"
            f"<p class='muted'>Walls cut at {WALL_CUT_M} m so that the furniture shows; drag to orbit, scroll to zoom.</p>"
        )
    elif js is None:
        viewer = "<p class='notrun'>3D viewer not available: node_modules/@google/model-viewer is not installed (`npm install`).</p>"
    else:
        viewer = "<p class='notrun'>No assembled scene to show.</p>"
    parts.append("</head><body>")
    parts.append(f"<h1>ReScene evaluation: {html.escape(str(run_dir))}</h1>")
    parts.append(f"<p class='muted'>capture: {html.escape(str(metrics.get('capture')))}</p>")
    parts.append("<h2>Scene</h2>" + viewer)
    if "plan" in figs:
        parts.append(f"<h2>Plan</h2><img alt='plan' src='{figs['plan']}' style='max-width:100%'>")
    sheet = [v for k, v in figs.items() if k.startswith("sheet_")]
    if sheet:
        parts.append(
            "<h2>Key frames</h2><div class='grid'>"
            + "".join(f"<img alt='key frame' src='{u}'>" for u in sheet)
            + "</div>"
        )
    if "before" in figs and "after" in figs:
        parts.append(
            "<h2>Before / after attachment</h2>"
            f"<div class='pair'><img alt='registered' src='{figs['before']}'>registered</div>"
            f"<div class='pair'><img alt='attached' src='{figs['after']}'>attached</div>"
        )
    pairs = sorted({k.split("_")[1] for k in figs if k.startswith("pair_")})
    if pairs:
        parts.append("<h2>Captured vs rendered (non-key frames)</h2>")
        for k in pairs:
            t = figs[f"pair_{k}_frame"]
            parts.append(
                f"<div class='pair'><img alt='captured {t}' src='{figs[f'pair_{k}_captured']}'>captured frame {t}</div>"
                f"<div class='pair'><img alt='rendered {t}' src='{figs[f'pair_{k}_rendered']}'>rendered</div>"
            )
    parts.append(
        "<h2>Summary</h2>" + _table(["metric", "value"], [[k, v] for k, v in metrics.get("summary", {}).items()])
    )
    parts.append("<h2>Geometry</h2>" + _scene_table(metrics))
    parts.append("<h2>Rendering</h2>" + _rendering_table(metrics))
    parts.append("<h2>Perceptual judge</h2>" + _judge(metrics))
    st = metrics.get("structural")
    if st:
        keys = [k for k, v in st.items() if isinstance(v, int | float) or v is None]
        parts.append("<h2>Structure</h2>" + _table(["metric", "value"], [[k, st[k]] for k in keys]))
    parts.append("<h2>Physics</h2>" + _physics(metrics))
    parts.append("<h2>Physics in a second engine</h2>" + _physics_newton(metrics))
    parts.append(
        "<h2>Objects</h2>"
        + _table(
            [
                "instance",
                "label",
                "relation parent",
                "CD vs GT (m)",
                "F@5 vs GT",
                "CD vs sensor (m)",
                "mask IoU",
                "problems",
            ],
            _object_rows(metrics, doc),
        )
    )
    nc = metrics.get("not_computed", {})
    if nc:
        parts.append(
            "<h2>Not computed</h2><ul>"
            + "".join(f"<li>{html.escape(k)}: {html.escape(str(v))}</li>" for k, v in nc.items())
            + "</ul>"
        )
    if metrics.get("timings_s"):
        parts.append("<h2>Time</h2>" + _table(["step", "seconds"], [[k, v] for k, v in metrics["timings_s"].items()]))
    parts.append("</body></html>")
    return "".join(parts)


def write_report_html(run_dir: str | Path, metrics: dict[str, Any] | None = None, capture: Any | None = None) -> Path:
    """Write RUN/eval/report.html (atomically) from ``metrics`` (default: RUN/eval/metrics.json)."""
    run_dir = Path(run_dir)
    if metrics is None:
        path = RunPaths(run_dir).metrics
        if not path.exists():
            raise FileNotFoundError(f"{path} does not exist; run `rescene eval {run_dir}` first")
        metrics = read_json(path)
    return write_bytes_atomic(RunPaths(run_dir).report_html, render_report_html(run_dir, metrics, capture).encode())


__all__ = ["model_viewer_js", "render_report_html", "viewer_glb", "write_report_html"]
